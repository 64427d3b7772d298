#!/usr/bin/python3
"""Tests of the irace integration (scripts/irace_tune.py, scripts/irace_target_runner.py).

Usage: /usr/bin/python3 scripts/test_irace_tune.py runner|race INSID WORKDIR

runner  The target runner, called as irace calls it (CONFIG_ID INSTANCE_ID SEED INSTANCE
        SWITCHES...), prints the same cost as `insid identify` run directly with that
        configuration and seed (fitness_gap_relative of its JSON, bit for bit); a second
        configuration and a second seed each give another cost (the switches and the seed reach
        insid). Needs no R.
race    A short irace run (tiny budget: 2 flights of 60 s, 20 evaluations per run) through
        irace_tune.py ends with elites whose values lie inside the ranges declared in its
        parameters.txt (integers for integer parameters), with their statistics, and tune.json's
        INS runs = experiments used x evaluations, within the budget. Skipped (exit 77, with a
        message) when R or its irace package is absent.
Exit 0 when every check passes, 1 otherwise (prints what failed).
"""
import json
import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import irace_tune  # noqa: E402

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL: " + what)


def simulate(insid, out, seed):
    if not os.path.isfile(os.path.join(out, "meta.json")):
        subprocess.run([insid, "simulate", "--preset", "paper", "--flight-s", "60", "--seed",
                        str(seed), "--out", out, "--quiet"], check=True)
    return out


def runner_cost(insid, data, seed, switches, evaluations):
    out = subprocess.run(["/usr/bin/python3", os.path.join(HERE, "irace_target_runner.py"),
                          "--insid", insid, "--evaluations", str(evaluations), "--", "7", "2",
                          str(seed), data] + switches,
                         stdout=subprocess.PIPE, check=True, text=True).stdout
    lines = out.strip().splitlines()
    check(len(lines) == 1, "runner printed one line, got %r" % out)
    return float(lines[-1])


def identify_cost(insid, data, seed, params, evaluations, out):
    cmd = [insid, "identify", "--data", data, "--algo", "dvpio", "--seed", str(seed),
           "--iterations", "0", "--evaluations", str(evaluations), "--uncertainty-replicas", "0",
           "--quiet", "--out", out]
    for p in params:
        cmd += ["--param", p]
    subprocess.run(cmd, check=True)
    with open(out) as f:
        return json.load(f)["fitness_gap_relative"]


def test_runner(insid, work):
    data = simulate(insid, os.path.join(work, "flight"), 3)
    params = ["population=7", "R=0.11", "d_initial_sigma=0.02", "d_min_sigma=0.0001",
              "d_max_sigma=1.5", "dist_threshold_sigma=0.3"]
    switches = ["--algo", "dvpio"] + sum([["--param", p] for p in params], [])
    seed = 1234567
    direct = identify_cost(insid, data, seed, params, 60, os.path.join(work, "direct.json"))
    via_runner = runner_cost(insid, data, seed, switches, 60)
    check(via_runner == direct,
          "runner cost %r == identify's fitness_gap_relative %r" % (via_runner, direct))
    # The switches and the seed reach insid: another R, another seed each change the cost.
    other_r = runner_cost(insid, data, seed, [s.replace("R=0.11", "R=0.4") for s in switches], 60)
    check(other_r != via_runner, "R=0.4 gives another cost than R=0.11 (%r)" % other_r)
    other_seed = runner_cost(insid, data, seed + 1, switches, 60)
    check(other_seed != via_runner, "seed+1 gives another cost (%r)" % other_seed)
    print("runner: cost %r (identify %r), R=0.4: %r, seed+1: %r" %
          (via_runner, direct, other_r, other_seed))


def test_race(insid, work):
    version = irace_tune.irace_version("Rscript")
    if version is None:
        print("SKIP: R's irace package is not installed (apt-get install r-cran-irace, or "
              "scripts/install-deps.sh); the irace race test needs it")
        return 77
    out = os.path.join(work, "race")
    shutil.rmtree(out, ignore_errors=True)
    max_experiments, evaluations = 90, 20
    proc = subprocess.run(["/usr/bin/python3", os.path.join(HERE, "irace_tune.py"), "--insid",
                           insid, "--out", out, "--algos", "dvpio,pio", "--flight", "paper:60",
                           "--noise-seeds", "1,2", "--evaluations", str(evaluations),
                           "--max-experiments", str(max_experiments), "--parallel", "2",
                           "--nb-iterations", "2", "--first-test", "2"])
    check(proc.returncode == 0, "irace_tune.py exit 0, got %d" % proc.returncode)
    if proc.returncode != 0:
        return 1
    declared = irace_tune.declared_parameters(os.path.join(out, "parameters.txt"))
    with open(os.path.join(out, "tune.json")) as f:
        tune = json.load(f)
    elites = tune["elites"]
    check(len(elites) >= 1, "at least one elite")
    check(os.path.getsize(os.path.join(out, "irace.log")) > 0, "irace.log written")
    for e in elites:
        check(e["algo"] in declared["algo"][2], "elite algo %r in %r" %
              (e["algo"], declared["algo"][2]))
        for name, (switch, kind, values, cond) in declared.items():
            if name == "algo":
                continue
            applies = cond == "" or ('"%s"' % e["algo"]) in cond
            if not applies:
                check(name not in e["parameters"], "%s absent for %s (condition %s)" %
                      (name, e["algo"], cond))
                continue
            check(name in e["parameters"], "elite %d has %s" % (e["irace_id"], name))
            if name not in e["parameters"]:
                continue
            v = e["parameters"][name]
            lo, hi = values
            check(lo <= v <= hi, "elite %d: %s = %r in [%r, %r]" % (e["irace_id"], name, v, lo,
                                                                   hi))
            if kind == "i":
                check(isinstance(v, int), "elite %d: %s = %r is an integer" %
                      (e["irace_id"], name, v))
        check(e["runs"] >= 1 and e["mean_cost"] == e["mean_cost"],
              "elite %d has statistics (runs %r, mean %r)" %
              (e["irace_id"], e["runs"], e["mean_cost"]))
    check(0 < tune["experiments_used"] <= max_experiments,
          "experiments used %r in (0, %d]" % (tune["experiments_used"], max_experiments))
    check(tune["ins_runs"] == tune["experiments_used"] * evaluations, "INS runs = experiments x "
          "evaluations (%r)" % tune["ins_runs"])
    print("race: %d elites, %d experiments, best %s" %
          (len(elites), tune["experiments_used"], " ".join(elites[0]["insid_args"])))
    return 0


def main(argv):
    if len(argv) != 3 or argv[0] not in ("runner", "race"):
        print(__doc__)
        return 2
    mode, insid, work = argv
    insid = os.path.abspath(insid)
    os.makedirs(work, exist_ok=True)
    if mode == "runner":
        test_runner(insid, work)
    else:
        rc = test_race(insid, work)
        if rc == 77:
            return 77
    if failures:
        print("%d check(s) failed" % len(failures))
        return 1
    print("all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
