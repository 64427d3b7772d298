#!/usr/bin/python3
"""Tune DVPIO (and/or PIO) on insid's identification problem with irace, in one command.

  /usr/bin/python3 scripts/irace_tune.py --out tune/dvpio            # DVPIO, defaults below
  /usr/bin/python3 scripts/irace_tune.py --out DIR --algos dvpio,pio --max-experiments 600

Needs the R package irace (Debian: r-cran-irace; scripts/install-deps.sh installs it) and a
built insid (default build/cli/insid). What it does, in OUT:

1. data/: the instances. Each flight (--flight PRESET:FLIGHT_S, repeatable; or --data DIR, your
   own datasets) is simulated once per noise seed (--noise-seeds), so instances = flights x noise
   seeds. Then the data's own optimum (insid identify's multi-start local fit) is found once per
   instance and cached in the dataset directory. Nothing is simulated or searched again later:
   the target runner only reads the cache. Existing datasets in OUT/data are reused.
2. parameters.txt (irace's parameter file: names, insid switches, types, ranges, conditions),
   instances.txt, scenario.txt and target-runner (calls scripts/irace_target_runner.py: one
   `insid identify` run for one configuration on one instance with irace's seed as the
   optimizer's seed; prints its cost, the final Eq. 15 fitness relative to the data's optimum,
   (f - f_opt) / f_opt; the runner's docstring says why this cost).
3. irace, run in parallel on the local cores (scenario option parallel = --parallel, default
   all cores); its output is in irace.log and its full record in irace.Rdata.
4. elites.csv and tune.json: the final elite configurations in irace's order (best sum of ranks
   first), each with the number of runs it had (irace's instance-seed pairs), its mean and median
   cost over them, and the same configuration as insid
   options (`--param KEY=VALUE`, sigma units) and as campaign parameters (normalised box units);
   tune.json also states the budget: experiments used x evaluations per run = INS runs spent.

Budget: every experiment (one target-runner call) is one optimizer run with an evaluation budget
of --evaluations INS runs (--iterations 0), so irace's maxExperiments = --max-experiments spends
at most max_experiments x evaluations INS runs (plus one optimum search per instance before the
race). An evaluation budget (not iterations) keeps configurations with different populations on
the same footing.

Parameters (sigma units for the distances, the paper's four estimated over [-4, 4] sigma):
DVPIO: population, R, d_initial, d_min, d_max, dist_threshold; PIO: population, R,
landmark_fraction. The d ranges do not overlap (d_min <= d_initial <= d_max always holds), so no
forbidden file is needed. With --algos dvpio,pio the categorical `algo` decides, and each
algorithm's own parameters carry the condition `| algo == "..."`.

Exit status 0 on success; 1 on a failure (insid, irace) with the reason; 2 on bad options;
3 when R or the irace package is missing (the message says how to install it).
"""
import argparse
import csv
import json
import os
import shlex
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

# name, insid --param key (None: the --algo switch), irace type, range or values, algorithms.
# Distances are in sigma units (the _sigma keys of `insid identify --param`); the defaults
# (optimizers/README.md) lie inside: population 10, R 0.05, d_initial 0.05 sigma, d_min 4e-6
# sigma, d_max 2 sigma, dist_threshold 0.2 sigma, landmark_fraction 0.25.
PARAMETERS = [
    ("population", "population", "i", (4, 40), ("dvpio", "pio")),
    ("R", "R", "r,log", (0.005, 0.5), ("dvpio", "pio")),
    ("d_initial", "d_initial_sigma", "r,log", (0.005, 0.5), ("dvpio",)),
    ("d_min", "d_min_sigma", "r,log", (0.000001, 0.004), ("dvpio",)),
    ("d_max", "d_max_sigma", "r,log", (0.5, 4.0), ("dvpio",)),
    ("dist_threshold", "dist_threshold_sigma", "r,log", (0.02, 2.0), ("dvpio",)),
    ("landmark_fraction", "landmark_fraction", "r", (0.0, 0.5), ("pio",)),
]
ALGORITHMS = ("dvpio", "pio")
# The search box of the paper's four is [-4, 4] sigma = [-1, 1] normalised: 4 sigma per unit.
SIGMA_PER_BOX_UNIT = 4.0
# irace rounds real parameters to this many decimal places (d_min's lower end needs 6).
DIGITS = 10


class Failure(Exception):
    pass


def say(text):
    sys.stderr.write("irace_tune: " + text + "\n")
    sys.stderr.flush()


def run(cmd, what, **kw):
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)
    if proc.returncode != 0:
        raise Failure("%s failed (exit %d): %s\ncommand: %s" %
                      (what, proc.returncode, (proc.stderr or proc.stdout).strip(),
                       " ".join(shlex.quote(c) for c in cmd)))
    return proc.stdout


def irace_version(rscript):
    if shutil.which(rscript) is None:
        return None
    proc = subprocess.run([rscript, "-e", "suppressMessages(library(irace)); "
                           "cat(as.character(packageVersion('irace')))"],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return proc.stdout.strip() if proc.returncode == 0 else None


def selected_parameters(algos):
    return [p for p in PARAMETERS if any(a in p[4] for a in algos)]


def parameter_file(algos):
    """irace's parameter file: name, switch, type, range, condition."""
    lines = ["# insid irace parameters (scripts/irace_tune.py): name switch type range [| condition]",
             "# distances in sigma units of the estimated parameters (insid identify --param "
             "KEY_sigma=...)"]
    lines.append('algo "--algo " c (%s)' % ", ".join(algos))
    for name, key, kind, values, owners in selected_parameters(algos):
        own = [a for a in algos if a in owners]
        cond = ""
        if len(own) < len(algos):
            cond = " | algo %%in%% c(%s)" % ", ".join('"%s"' % a for a in own)
        lines.append('%s "--param %s=" %s (%s, %s)%s' % (name, key, kind, fmt(values[0]),
                                                          fmt(values[1]), cond))
    return "\n".join(lines) + "\n"


def fmt(v):
    return str(v) if isinstance(v, int) else ("%.10g" % v)


def declared_parameters(path):
    """Read back a parameter file written by parameter_file: {name: (switch, type, values,
    condition)} (what the tests check the elites against)."""
    out = {}
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            name, rest = line.split(" ", 1)
            switch = rest[1:rest.index('"', 1)]
            rest = rest[rest.index('"', 1) + 1:].strip()
            kind, rest = rest.split(" ", 1)
            values = rest[rest.index("(") + 1:rest.index(")")]
            cond = rest.split("|", 1)[1].strip() if "|" in rest else ""
            items = [v.strip() for v in values.split(",")]
            if kind.startswith("c"):
                values = items
            else:
                values = (float(items[0]), float(items[1]))
            out[name] = (switch, kind, values, cond)
    return out


def simulate_instances(args, insid, data_dir):
    instances = []
    for flight in args.flight:
        preset, _, flight_s = flight.partition(":")
        for noise in args.noise_seeds:
            name = "%s-%ss-noise%d" % (preset, flight_s or "preset", noise)
            d = os.path.join(data_dir, name)
            if not os.path.isfile(os.path.join(d, "meta.json")):
                cmd = [insid, "simulate", "--preset", preset, "--seed", str(noise), "--out", d,
                       "--quiet"]
                if flight_s:
                    cmd += ["--flight-s", flight_s]
                say("simulating %s" % name)
                run(cmd, "insid simulate (%s)" % name)
            instances.append(d)
    for d in args.data:
        if not os.path.isfile(os.path.join(d, "meta.json")):
            raise Failure("--data %s: no meta.json there (expected an insid dataset directory)" % d)
        instances.append(os.path.abspath(d))
    return instances


def warm_optimum_cache(insid, instances, args):
    """Find each instance's optimum once (identify caches it in the dataset directory); the
    target runner's identify calls then read it. Same estimate/alignment options as the runner
    (the cache key includes them)."""
    for d in instances:
        cache = os.path.join(d, "insid-optimum-cache.json")
        say("the data's optimum of %s%s" % (os.path.basename(d),
                                            " (cached)" if os.path.isfile(cache) else ""))
        warm = os.path.join(d, "insid-tune-warm.json")
        run([insid, "identify", "--data", d, "--algo", "dvpio", "--iterations", "1",
             "--uncertainty-replicas", "0", "--threads", str(args.parallel), "--quiet", "--out",
             warm] + args.identify_arg, "insid identify (optimum of %s)" % d)
        with open(warm) as f:
            opt = json.load(f).get("optimum_fitness")
        os.remove(warm)
        if opt is None or not os.path.isfile(cache):
            raise Failure("no cached optimum in %s after insid identify" % d)


def write_files(args, out, insid, instances):
    with open(os.path.join(out, "parameters.txt"), "w") as f:
        f.write(parameter_file(args.algos))
    with open(os.path.join(out, "instances.txt"), "w") as f:
        f.write("".join(d + "\n" for d in instances))
    runner = os.path.join(out, "target-runner")
    extra = "".join(" %s" % shlex.quote("--identify-arg=" + a) for a in args.identify_arg)
    with open(runner, "w") as f:
        f.write("#!/bin/sh\n# irace target runner (scripts/irace_tune.py): irace's arguments "
                "CONFIG_ID INSTANCE_ID SEED INSTANCE SWITCHES...\nexec /usr/bin/python3 %s "
                "--insid %s --evaluations %d --iterations 0%s -- \"$@\"\n" %
                (shlex.quote(os.path.join(HERE, "irace_target_runner.py")), shlex.quote(insid),
                 args.evaluations, extra))
    os.chmod(runner, 0o755)
    exec_dir = os.path.join(out, "exec")
    os.makedirs(exec_dir, exist_ok=True)
    scenario = {
        "parameterFile": os.path.join(out, "parameters.txt"),
        "trainInstancesDir": "",
        "trainInstancesFile": os.path.join(out, "instances.txt"),
        "targetRunner": runner,
        "execDir": exec_dir,
        "logFile": os.path.join(out, "irace.Rdata"),
        "maxExperiments": args.max_experiments,
        "parallel": args.parallel,
        "seed": args.seed,
        "digits": DIGITS,
        "deterministic": 0,
    }
    if args.nb_iterations:
        scenario["nbIterations"] = args.nb_iterations
    if args.first_test:
        scenario["firstTest"] = args.first_test
    with open(os.path.join(out, "scenario.txt"), "w") as f:
        f.write("## irace scenario (scripts/irace_tune.py). Budget: maxExperiments optimizer runs "
                "of %d INS runs each = at most %d INS runs.\n" %
                (args.evaluations, args.max_experiments * args.evaluations))
        for k, v in scenario.items():
            f.write("%s = %s\n" % (k, json.dumps(v)))


EXTRACT_R = r"""
suppressMessages(library(irace))
args <- commandArgs(trailingOnly = TRUE)
load(args[1])
r <- iraceResults
elites <- r$allElites[[length(r$allElites)]]
conf <- r$allConfigurations[match(elites, r$allConfigurations$.ID.), , drop = FALSE]
ex <- r$experiments[, as.character(elites), drop = FALSE]
out <- data.frame(rank = seq_along(elites), id = elites,
                  conf[, r$parameters$names, drop = FALSE],
                  runs = colSums(!is.na(ex)),
                  mean_cost = colMeans(ex, na.rm = TRUE),
                  median_cost = apply(ex, 2, median, na.rm = TRUE), check.names = FALSE)
write.csv(out, args[2], row.names = FALSE, na = "")
cat(r$state$experimentsUsedSoFar, nrow(r$allConfigurations), length(r$allElites), "\n")
"""


def collect(args, out, rscript, version):
    elites_csv = os.path.join(out, "elites.csv")
    used, configurations, iterations = run(
        [rscript, "-e", EXTRACT_R, os.path.join(out, "irace.Rdata"), elites_csv],
        "reading irace.Rdata").split()
    declared = declared_parameters(os.path.join(out, "parameters.txt"))
    keys = {p[0]: p[1] for p in PARAMETERS}
    elites = []
    with open(elites_csv) as f:
        for row in csv.DictReader(f):
            params, insid_params, campaign = {}, [], {}
            for name, (_, kind, _, _) in declared.items():
                text = row[name]
                if name == "algo" or text == "":
                    continue  # NA: the parameter does not apply to this algorithm
                value = int(text) if kind == "i" else float(text)
                params[name] = value
                key = keys[name]
                insid_params.append("%s=%s" % (key, text))
                if key.endswith("_sigma"):
                    campaign[key[:-len("_sigma")]] = value / SIGMA_PER_BOX_UNIT
                else:
                    campaign[key] = value
            elites.append({
                "rank": int(row["rank"]), "irace_id": int(row["id"]), "algo": row["algo"],
                "parameters": params,
                "insid_args": ["--algo", row["algo"]] + sum([["--param", p] for p in insid_params],
                                                           []),
                "campaign_parameters": campaign,
                "runs": int(row["runs"]), "mean_cost": float(row["mean_cost"]),
                "median_cost": float(row["median_cost"])
            })
    used = int(used)
    summary = {
        "format": "insid-irace-tune/1",
        "irace_version": version,
        "cost": "fitness_gap_relative = (f - f_opt) / f_opt, final Eq. 15 fitness vs the data's "
                "own optimum (scripts/irace_target_runner.py)",
        "algorithms": args.algos,
        "instances": [os.path.basename(d) for d in open(os.path.join(out, "instances.txt")).read()
                      .split()],
        "evaluations_per_run": args.evaluations,
        "max_experiments": args.max_experiments,
        "experiments_used": used,
        "ins_runs": used * args.evaluations,
        "configurations_sampled": int(configurations),
        "irace_iterations": int(iterations),
        "parallel": args.parallel,
        "seed": args.seed,
        "elites": elites,
    }
    with open(os.path.join(out, "tune.json"), "w") as f:
        json.dump(summary, f, indent=2)
        f.write("\n")
    return summary


def main(argv):
    ap = argparse.ArgumentParser(
        description="Tune DVPIO/PIO with irace on insid's identification problem.",
        epilog="See the module docstring (head of this file) for the files written.")
    ap.add_argument("--out", required=True, help="results folder")
    ap.add_argument("--insid", default=os.path.join(ROOT, "build", "cli", "insid"),
                    help="insid binary (default: build/cli/insid)")
    ap.add_argument("--algos", default="dvpio", help="dvpio, pio or dvpio,pio (default dvpio)")
    ap.add_argument("--flight", action="append", default=None,
                    help="PRESET[:FLIGHT_S] to simulate, repeatable (default paper:300)")
    ap.add_argument("--noise-seeds", default="1,2,3,4",
                    help="noise seeds of the simulated flights (default 1,2,3,4)")
    ap.add_argument("--data", action="append", default=[],
                    help="a dataset directory used as an instance as it is (repeatable)")
    ap.add_argument("--evaluations", type=int, default=400,
                    help="INS runs per optimizer run (default 400, the paper's 10 x 40)")
    ap.add_argument("--max-experiments", type=int, default=300,
                    help="irace's maxExperiments: optimizer runs in all (default 300)")
    ap.add_argument("--parallel", type=int, default=os.cpu_count() or 1,
                    help="target-runner calls at once (irace's parallel; default all cores)")
    ap.add_argument("--seed", type=int, default=1, help="irace's seed (default 1)")
    ap.add_argument("--nb-iterations", type=int, default=0,
                    help="irace's nbIterations (0: irace's default); for tiny budgets")
    ap.add_argument("--first-test", type=int, default=0,
                    help="irace's firstTest (0: irace's default, 5); for tiny budgets")
    ap.add_argument("--identify-arg", action="append", default=[],
                    help="one more argument for every insid identify call, e.g. "
                    "--identify-arg=--alignment=fixed (repeatable)")
    ap.add_argument("--rscript", default="Rscript", help="Rscript binary (default Rscript)")
    args = ap.parse_args(argv)

    def bad(text):
        say("error: " + text)
        return 2

    args.algos = [a.strip() for a in args.algos.split(",") if a.strip()]
    for a in args.algos:
        if a not in ALGORITHMS:
            return bad("--algos %s: expected dvpio and/or pio" % a)
    if not args.algos or len(set(args.algos)) != len(args.algos):
        return bad("--algos: expected dvpio, pio or dvpio,pio")
    try:
        args.noise_seeds = [int(s) for s in args.noise_seeds.split(",")]
    except ValueError:
        return bad("--noise-seeds %s: expected whole numbers separated by commas" %
                   args.noise_seeds)
    if args.flight is None:
        args.flight = [] if args.data else ["paper:300"]
    for f in args.flight:
        p, _, s = f.partition(":")
        if not p or (s and not s.replace(".", "", 1).isdigit()):
            return bad("--flight %s: expected PRESET or PRESET:FLIGHT_S" % f)
    for d in args.data:
        if not os.path.isfile(os.path.join(d, "meta.json")):
            return bad("--data %s: no meta.json there (expected an insid dataset directory)" % d)
    for name in ("evaluations", "max_experiments", "parallel"):
        if getattr(args, name) < 1:
            return bad("--%s %d: expected at least 1" % (name.replace("_", "-"),
                                                          getattr(args, name)))
    insid = os.path.abspath(args.insid)
    if not os.access(insid, os.X_OK):
        return bad("--insid %s: not an executable (build insid first: scripts/build.sh)" % insid)
    version = irace_version(args.rscript)
    if version is None:
        say("error: R's irace package is not available (%s -e 'library(irace)' failed); install "
            "it with `apt-get install r-cran-irace` (scripts/install-deps.sh does)" % args.rscript)
        return 3

    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    try:
        instances = simulate_instances(args, insid, os.path.join(out, "data"))
        warm_optimum_cache(insid, instances, args)
        write_files(args, out, insid, instances)
        say("irace %s: %d instances, %d experiments x %d evaluations = at most %d INS runs, "
            "parallel %d" % (version, len(instances), args.max_experiments, args.evaluations,
                             args.max_experiments * args.evaluations, args.parallel))
        log_path = os.path.join(out, "irace.log")
        with open(log_path, "w") as log:
            proc = subprocess.run([args.rscript, "-e", "irace::irace.cmdline()", "--scenario",
                                   os.path.join(out, "scenario.txt")],
                                  stdout=log, stderr=subprocess.STDOUT, cwd=out)
        if proc.returncode != 0:
            tail = open(log_path).read().strip().splitlines()[-15:]
            raise Failure("irace failed (exit %d); the end of %s:\n%s" %
                          (proc.returncode, log_path, "\n".join(tail)))
        summary = collect(args, out, args.rscript, version)
    except Failure as e:
        say("error: " + str(e))
        return 1
    best = summary["elites"][0]
    say("%d experiments (%d INS runs); best of %d elites: %s (mean cost %.4g over %d runs)"
        % (summary["experiments_used"], summary["ins_runs"], len(summary["elites"]),
           " ".join(best["insid_args"]), best["mean_cost"], best["runs"]))
    say("wrote %s/tune.json, elites.csv, irace.log, irace.Rdata" % out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
