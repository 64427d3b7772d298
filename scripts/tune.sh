#!/usr/bin/env bash
# results/tune: DVPIO tuned by irace vs the best of an `insid sweep` grid, then both (and the
# Table 4 default) on fresh flights and fresh seeds in one campaign (Mann-Whitney + Holm).
# Run from the repository root after the build: scripts/tune.sh [WORK_DIR].
# WORK_DIR (default /tmp/insid-tune) keeps the datasets and run files, which are not committed;
# the summaries are copied into results/tune/.
set -euo pipefail
insid=build/cli/insid
work=${1:-/tmp/insid-tune}
here=results/tune
mkdir -p "$work" "$here"

# 1. irace: 4 instances (the paper flight, 300 s, noise seeds 1-4), 300 experiments of 400
#    evaluations = at most 120000 INS runs, on all cores.
nice -n 15 /usr/bin/python3 scripts/irace_tune.py --out "$work/irace" --flight paper:300 \
  --noise-seeds 1,2,3,4 --evaluations 400 --max-experiments 300 --seed 1

# 2. The grid (resumed if WORK_DIR has it): 3 x 3 x 3 x 3 = 81 settings x 4 seeds on the paper
#    flight (300 s, noise seed 1),
#    400 evaluations each = 129600 INS runs (at least irace's budget).
nice -n 15 "$insid" sweep --algo dvpio --grid R=0.01,0.05,0.2 --grid d0_sigma=0.01,0.05,0.2 \
  --grid dist_threshold_sigma=0.05,0.2,0.8 --grid population=6,10,20 --seeds 4 \
  --preset paper --flight-s 300 --iterations 0 --evaluations 400 --out "$work/sweep" --quiet

# 3. The comparison campaign: fresh flights (noise seeds 101, 102) and fresh optimizer seeds
#    (1001-1031), irace's best, the grid's best and the Table 4 default, 400 evaluations each.
/usr/bin/python3 - "$work" > "$here/compare-config.json" <<'EOF'
import json, sys
work = sys.argv[1]
irace = json.load(open(work + "/irace/tune.json"))["elites"][0]
grid = json.load(open(work + "/sweep/sweep.json"))["best"][0]["parameters"]
# sweep keys: d0 = d_initial; *_sigma distances in sigma units; the campaign wants box units
# ([-4, 4] sigma = [-1, 1]).
grid_params = {}
for k, v in grid.items():
    k = "d_initial_sigma" if k == "d0_sigma" else ("d_initial" if k == "d0" else k)
    if k.endswith("_sigma"):
        grid_params[k[:-6]] = v / 4.0
    else:
        grid_params[k] = v
config = {
    "name": "tune-compare",
    "scenarios": [{"name": "fresh%d" % s, "preset": "paper", "flight_s": 300, "data_seed": s}
                  for s in (101, 102)],
    "algorithms": [
        {"label": "irace-best", "name": irace["algo"], "parameters": irace["campaign_parameters"]},
        {"label": "grid-best", "name": "dvpio", "parameters": grid_params},
        {"label": "table4", "name": "dvpio"},
    ],
    "seeds": list(range(1001, 1032)),
    "max_iterations": 0,
    "max_evaluations": 400,
}
json.dump(config, sys.stdout, indent=2)
print()
EOF
nice -n 15 "$insid" bench --config "$here/compare-config.json" --out "$work/compare" --quiet
/usr/bin/python3 scripts/campaign_report.py "$work/compare"

# 4. Copy the summaries (not the datasets, run files or irace's exec folder).
mkdir -p "$here/irace" "$here/sweep" "$here/compare"
cp "$work"/irace/{parameters.txt,scenario.txt,instances.txt,target-runner,tune.json,elites.csv,irace.log,irace.Rdata} "$here/irace/"
cp "$work"/sweep/{sweep.json,sweep.csv,manifest.json} "$here/sweep/"
cp -r "$work"/compare/{manifest.json,summary.json,report.md,figures} "$here/compare/"
# 5. Pack them as committed (results/README.md "What is committed, and how").
/usr/bin/python3 scripts/pack_results.py --png "$here"
