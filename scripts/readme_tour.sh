#!/usr/bin/env bash
# Runs a README block exactly as written, so that the README cannot rot: a renamed option, a
# changed preset or a failing command fails this script (ctest `readme_tour`, `readme_drone`).
#   scripts/readme_tour.sh [BUILD_DIR] [BLOCK]     (default: build, tour)
# BLOCK: `tour`, the five-minute tour (the sh block between `<!-- tour:begin` and
# `<!-- tour:end -->`), or `drone`, the ArduPilot walk-through (`<!-- drone:begin` ...), which
# reads ../shared/data and is skipped (exit 77) where the copter log is absent.
# It runs in a fresh temporary directory `clone` in which `build` and `scripts` point at the real
# ones and `../shared` at the shared recordings, then checks that every JSON file the block
# writes parses, and what the block must have written.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:-$root/build}" && pwd)"
name="${2:-tour}"
case "$name" in
  tour | drone) ;;
  *) echo "readme_tour: unknown block '$name' (tour, drone)" >&2; exit 2 ;;
esac
if [[ $name == drone && ! -f "$root/../shared/data/ardupilot-copter/log171.bin" ]]; then
  echo "readme_tour: skipped: ../shared/data/ardupilot-copter/log171.bin is absent (the README's" \
    "drone walk-through reads it; scripts/get-sample-data.sh puts it there)"
  exit 77
fi
work="$(mktemp -d "${TMPDIR:-/tmp}/insid-$name.XXXXXX")"
trap 'rm -rf "$work"' EXIT
mkdir "$work/clone"
ln -s "$build" "$work/clone/build"
ln -s "$root/scripts" "$work/clone/scripts"
[[ -d "$root/../shared" ]] && ln -s "$(cd "$root/../shared" && pwd)" "$work/shared"
block="$(sed -n "/^<!-- $name:begin/,/^<!-- $name:end -->/p" "$root/README.md" | sed '1,2d;$d' | sed '$d')"
if [ -z "$block" ] || ! grep -q 'insid' <<<"$block"; then
  echo "readme_tour: no $name block found in $root/README.md" >&2
  exit 1
fi
cd "$work/clone"
echo "readme_tour: running the README's $name block in $work/clone" >&2
bash -euo pipefail -c "$block" > "$name.log" 2>&1 || {
  echo "readme_tour: a README $name command failed; its output:" >&2
  tail -n 30 "$name.log" >&2
  exit 1
}
n=0
for f in $(find "$name" -name '*.json' | sort); do
  /usr/bin/python3 -c "import json,sys; json.load(open(sys.argv[1]))" "$f" || {
    echo "readme_tour: $f is not valid JSON" >&2
    exit 1
  }
  n=$((n + 1))
done
if [[ $name == tour ]]; then
  test -s tour/quick/report.md || { echo "readme_tour: tour/quick/report.md missing" >&2; exit 1; }
  echo "readme_tour: every tour command ran; $n JSON files parse; report written"
else
  for f in drone/dvpio.json drone/ekf.json; do
    /usr/bin/python3 -c "import json,sys; assert json.load(open(sys.argv[1]))['autopilot_comparison']" "$f" || {
      echo "readme_tour: $f has no autopilot_comparison" >&2
      exit 1
    }
  done
  grep -q "insid against the autopilot" drone.log || { echo "readme_tour: no autopilot table printed" >&2; exit 1; }
  echo "readme_tour: every drone command ran; $n JSON files parse; both results hold the autopilot comparison"
fi
