#!/usr/bin/env bash
# The main job: install dependencies, build, simulate the paper's flight and run the paper
# reproduction. Outputs go under results/run/ (not committed).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
insid=build/bench/insid
out=results/run
mkdir -p "$out"
echo "== simulate the paper preset (Table 3, Sec. 3.2 injected errors)" >&2
"$insid" simulate --preset paper --out "$out/paper-data" --seed 1
echo "== navigate without compensation" >&2
"$insid" navigate --data "$out/paper-data" --summary "$out/navigate-uncompensated.json"
echo "== navigate compensating the injected errors" >&2
comp=$(/usr/bin/python3 -c 'import json,sys; m=json.load(open(sys.argv[1]))["injected"]; print(" ".join(f"--compensate {k}={v!r}" for k,v in m.items()))' "$out/paper-data/meta.json")
# shellcheck disable=SC2086
"$insid" navigate --data "$out/paper-data" $comp --summary "$out/navigate-compensated.json"
/usr/bin/python3 - "$out" <<'PY'
import json, sys
d = sys.argv[1]
a = json.load(open(f"{d}/navigate-uncompensated.json"))
b = json.load(open(f"{d}/navigate-compensated.json"))
print(f"Eq. 15 fitness, uncompensated:            {a['fitness']:.4g}  (rms {a['rms_dvh_mps']:.4g} m/s)")
print(f"Eq. 15 fitness, injected errors removed:  {b['fitness']:.4g}  (rms {b['rms_dvh_mps']:.4g} m/s)")
PY
