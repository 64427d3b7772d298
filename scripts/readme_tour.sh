#!/usr/bin/env bash
# Runs the README's five-minute tour (the sh block between `<!-- tour:begin` and
# `<!-- tour:end -->`) exactly as written, so that the README cannot rot: a renamed option, a
# changed preset or a failing command fails this script (ctest `readme_tour`).
#   scripts/readme_tour.sh [BUILD_DIR]     (default: build)
# It runs in a fresh temporary directory in which `build` and `scripts` point at the real ones,
# then checks that every JSON file the tour writes parses and that the report was written.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:-$root/build}" && pwd)"
work="$(mktemp -d "${TMPDIR:-/tmp}/insid-tour.XXXXXX")"
trap 'rm -rf "$work"' EXIT
ln -s "$build" "$work/build"
ln -s "$root/scripts" "$work/scripts"
block="$(sed -n '/^<!-- tour:begin/,/^<!-- tour:end -->/p' "$root/README.md" | sed '1,2d;$d' | sed '$d')"
if [ -z "$block" ] || ! grep -q 'insid' <<<"$block"; then
  echo "readme_tour: no tour block found in $root/README.md" >&2
  exit 1
fi
cd "$work"
echo "readme_tour: running the README tour in $work" >&2
bash -euo pipefail -c "$block" > tour.log 2>&1 || {
  echo "readme_tour: a README tour command failed; its output:" >&2
  tail -n 30 tour.log >&2
  exit 1
}
n=0
for f in $(find tour -name '*.json' | sort); do
  /usr/bin/python3 -c "import json,sys; json.load(open(sys.argv[1]))" "$f" || {
    echo "readme_tour: $f is not valid JSON" >&2
    exit 1
  }
  n=$((n + 1))
done
test -s tour/quick/report.md || { echo "readme_tour: tour/quick/report.md missing" >&2; exit 1; }
echo "readme_tour: every tour command ran; $n JSON files parse; report written"
