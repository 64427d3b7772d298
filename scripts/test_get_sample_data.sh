#!/usr/bin/env bash
# Tests scripts/get-sample-data.sh's download path without the internet (ctest
# `get_sample_data`): the shared recordings are laid out as GitHub serves them
# (<repository>/raw/<commit>/<path>) under a local HTTP server (Debian's python3 -m http.server),
# and the script is pointed at it with --base-url.
#   1. into an empty --dest: all 8 files downloaded, each checked, ATTRIBUTION.txt written;
#   2. run again: all 8 present and verified, nothing downloaded;
#   3. a mirror file with one byte changed: refused by its SHA-256, not kept, exit 1;
#   4. a file missing from the mirror: the download fails, exit 1, the others still fetched;
#   5. --check on a partial folder lists what is missing and exits 1.
# Skips (exit 77) without ../shared/data (the recordings to serve) or curl/wget.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
shared="${1:-$root/../shared}/data"
script="$root/scripts/get-sample-data.sh"
if [[ ! -d "$shared" ]]; then
  echo "test_get_sample_data: $shared is absent (the shared recordings are what it serves); skipped"
  exit 77
fi
if ! command -v curl >/dev/null && ! command -v wget >/dev/null; then
  echo "test_get_sample_data: neither curl nor wget; skipped"
  exit 77
fi
work="$(mktemp -d "${TMPDIR:-/tmp}/insid-sample-data.XXXXXX")"
server_pid=""
cleanup() {
  [[ -n "$server_pid" ]] && kill "$server_pid" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "test_get_sample_data: FAILED: $*" >&2; exit 1; }

# The mirror: every row of the script's table, at its GitHub path.
mirror="$work/mirror"
rows="$(sed -n '/^files=(/,/^)/p' "$script" | grep '^  "' | tr -d '"' | sed 's/^ *//')"
n=0
while IFS='|' read -r folder file sha repo commit path licence; do
  mkdir -p "$mirror/$repo/raw/$commit/$(dirname "$path")"
  cp "$shared/$folder/$file" "$mirror/$repo/raw/$commit/$path"
  n=$((n + 1))
done <<<"$rows"
[[ $n == 8 ]] || fail "expected 8 files in the script's table, found $n"

port="$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')"
(cd "$mirror" && exec /usr/bin/python3 -m http.server "$port" --bind 127.0.0.1 >"$work/server.log" 2>&1) &
server_pid=$!
for _ in $(seq 50); do
  curl --silent --output /dev/null "http://127.0.0.1:$port/" 2>/dev/null && break
  sleep 0.1
done
url="http://127.0.0.1:$port"

# 1. Everything downloaded and checked.
out="$(bash "$script" --dest "$work/d1" --base-url "$url" 2>&1)" || fail "first download: $out"
grep -q "0 present and verified, 8 downloaded, 0 missing, 0 failed" <<<"$out" || fail "$out"
while IFS='|' read -r folder file sha repo commit path licence; do
  [[ "$(sha256sum "$work/d1/$folder/$file" | cut -d' ' -f1)" == "$sha" ]] || fail "$folder/$file"
  grep -q "^$file: $repo, commit $commit" "$work/d1/$folder/ATTRIBUTION.txt" ||
    fail "$folder/ATTRIBUTION.txt does not name $file"
done <<<"$rows"
# 2. A second run downloads nothing.
out="$(bash "$script" --dest "$work/d1" --base-url "$url" 2>&1)" || fail "second run: $out"
grep -q "8 present and verified, 0 downloaded" <<<"$out" || fail "$out"
# 3. A changed byte in the mirror: refused, not kept.
changed="$(find "$mirror" -name log171.bin)"
printf 'X' | dd of="$changed" bs=1 seek=1000 conv=notrunc status=none
if out="$(bash "$script" --dest "$work/d3" --base-url "$url" 2>&1)"; then fail "a changed file was accepted: $out"; fi
grep -q "log171.bin: SHA-256 .* expected a4a3883f.*: not kept" <<<"$out" || fail "$out"
[[ ! -e "$work/d3/ardupilot-copter/log171.bin" ]] || fail "the changed file was kept"
ls "$work/d3/ardupilot-copter/" | grep -q download && fail "a temporary file was left"
grep -q "7 downloaded, 0 missing, 1 failed" <<<"$out" || fail "$out"
# 4. A file missing from the mirror: that download fails, the rest are fetched.
rm "$(find "$mirror" -name esc_status_log.ulg)"
if out="$(bash "$script" --dest "$work/d4" --base-url "$url" 2>&1)"; then fail "a missing file passed: $out"; fi
grep -q "esc_status_log.ulg: download failed" <<<"$out" || fail "$out"
# 5. --check on the partial folder of 4.
if out="$(bash "$script" --dest "$work/d4" --check 2>&1)"; then fail "--check passed a partial folder"; fi
grep -q "missing: $work/d4/px4-ulog-real/esc_status_log.ulg" <<<"$out" || fail "$out"
echo "test_get_sample_data: 8 files served locally, downloaded, verified; a changed and a missing file refused"
