#!/usr/bin/env bash
# The main job: install dependencies, build, and reproduce the paper's comparison (Figure 9):
# the `paper-fig9` campaign (the `paper` flight simulated in memory, GA / PSO / PIO / DVPIO with
# Table 4 settings, 31 seeds), then its statistics, figures and report.
#   scripts/run.sh                 # 31 seeds
#   scripts/run.sh --seeds 5       # a quick look; any `insid bench` option is passed through
# Output: results/run/paper-fig9/{manifest.json,runs/,summary.json,report.md,figures/}.
# Interrupted? Run the same command again: finished runs are kept.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
out=results/run/paper-fig9
mkdir -p "$out"
build/cli/insid bench --preset paper-fig9 --out "$out" "$@"
/usr/bin/python3 scripts/campaign_report.py "$out"
echo "insid: report in $out/report.md" >&2
sed -n '/^### Result$/,/^### Statistics/p' "$out/report.md" | head -n 40
