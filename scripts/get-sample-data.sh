#!/usr/bin/env bash
# The public recordings the README's worked examples read, where they read them
# (../shared/data/<folder>/ beside the repository, or --dest DIR).
#
#   scripts/get-sample-data.sh [--dest DIR] [--check] [--base-url URL]
#
# Each file is named by its public repository, commit and path (the folder READMEs of
# ../shared/data say where each comes from) and checked against its SHA-256. A file already
# present with the right checksum is used as it is (CI and tests never download: they have
# ../shared/data); one present with another checksum is an error and is left alone; an absent one
# is downloaded (curl or wget) to a temporary name, checked, then moved into place.
# --check only verifies what is present and says what is missing. --base-url (default
# https://github.com) serves URL/<repository>/raw/<commit>/<path>: a mirror, or the local server
# of scripts/test_get_sample_data.sh. Nothing is ever written into
# this repository: the recordings carry their own licences (CC BY-SA 3.0, BSD-3, MIT), recorded in
# an ATTRIBUTION.txt beside each downloaded folder.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
dest="$root/../shared/data"
check_only=0
base_url="https://github.com"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --dest) dest="${2:?--dest needs a directory}"; shift 2 ;;
    --check) check_only=1; shift ;;
    --base-url) base_url="${2:?--base-url needs a URL}"; shift 2 ;;
    -h|--help) sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "get-sample-data: unknown option '$1' (--dest DIR, --check, --base-url URL)" >&2; exit 2 ;;
  esac
done

# folder | file | sha256 | repository | commit | path in the repository | licence
files=(
  "rtklib-walk|imu_1730_sf.csv|cf6a76f67050161a88c25616b6694ed5cf50d74e79860ef1779ac3012fbc6474|rtklibexplorer/GNSS_IMU|8235ee6c5f34|data/walk_0827/imu_1730_sf.csv|BSD-3-Clause"
  "rtklib-walk|gnss_1730_sf.pos|5f2e17184047fb9e35c0d8fe8c317524d92bf490cd7fc66c41ae53df027eedf8|rtklibexplorer/GNSS_IMU|8235ee6c5f34|data/walk_0827/gnss_1730_sf.pos|BSD-3-Clause"
  "ardupilot-copter|log171.bin|a4a3883fa13f28d55878c041cb4cc14deb3e5335aad6b9091f235c9b4e0d95f0|dronekit/dronekit-la-testdata|c7b97dec13ba6d01deda1db53bacf7454ad8ea5f|log171.bin|CC BY-SA 3.0 (DroneKit LA Test Data contributors)"
  "px4-ulog|sample.ulg|81952e6059bc095717e7911c010e07f85749d6b04d332a5ffc51575a3fd0a558|PX4/pyulog|3cf17793f147|test/sample.ulg|BSD-3-Clause"
  "px4-ulog|sample_log_small.ulg|68d1020f688109f027dba08d2950247cc0ae34aaefdcf37e4a7d60838f3e1aa3|PX4/pyulog|3cf17793f147|test/sample_log_small.ulg|BSD-3-Clause"
  "px4-ulog|sample_logging_tagged_and_default_params.ulg|32f564608d46caf5a4cbb1cb0cd0dc839fb9512b06c6d1384fb96ec3d6c9173d|PX4/pyulog|3cf17793f147|test/sample_logging_tagged_and_default_params.ulg|BSD-3-Clause"
  "px4-ulog|sample_px4_events.ulg|4b43a23a7b7f649004facba5c7835d800bbc8cc13e71cbc96678d971451e3d7e|PX4/pyulog|3cf17793f147|test/sample_px4_events.ulg|BSD-3-Clause"
  "px4-ulog-real|esc_status_log.ulg|471f4af4b57a94adbeb7006f1994cbc4742f0510a5ae8bc562b41c125282e860|Auterion/px4-ulog-rs|86e033f2a115d939dee9bdd38a9a01df1a0920a0|tests/fixtures/esc_status_log.ulg|MIT"
)

sha256_of() { sha256sum "$1" | cut -d' ' -f1; }

download() {  # url, output file
  if command -v curl >/dev/null; then
    curl --fail --location --silent --show-error --retry 2 --output "$2" "$1"
  elif command -v wget >/dev/null; then
    wget --quiet --output-document="$2" "$1"
  else
    echo "get-sample-data: needs curl or wget (apt-get install curl)" >&2
    return 1
  fi
}

present=0 fetched=0 missing=0 failed=0
for row in "${files[@]}"; do
  IFS='|' read -r folder file sha repo commit path licence <<<"$row"
  target="$dest/$folder/$file"
  if [[ -e "$target" ]]; then
    got="$(sha256_of "$target")"
    if [[ "$got" != "$sha" ]]; then
      echo "get-sample-data: $target: SHA-256 $got, expected $sha (from $repo@$commit:$path);" \
        "left as it is: move it away to download the published file" >&2
      failed=$((failed + 1))
      continue
    fi
    present=$((present + 1))
    continue
  fi
  if [[ $check_only == 1 ]]; then
    echo "get-sample-data: missing: $target ($repo@$commit:$path)"
    missing=$((missing + 1))
    continue
  fi
  mkdir -p "$dest/$folder"
  url="$base_url/$repo/raw/$commit/$path"
  tmp="$target.download-$$"
  echo "get-sample-data: $url -> $target"
  if ! download "$url" "$tmp"; then
    rm -f "$tmp"
    echo "get-sample-data: $url: download failed" >&2
    failed=$((failed + 1))
    continue
  fi
  got="$(sha256_of "$tmp")"
  if [[ "$got" != "$sha" ]]; then
    rm -f "$tmp"
    echo "get-sample-data: $url: SHA-256 $got, expected $sha: not kept" >&2
    failed=$((failed + 1))
    continue
  fi
  mv "$tmp" "$target"
  printf '%s: %s, commit %s, path %s; licence %s.\n' "$file" "$repo" "$commit" "$path" \
    "$licence" >>"$dest/$folder/ATTRIBUTION.txt"
  fetched=$((fetched + 1))
done

echo "get-sample-data: $dest: $present present and verified, $fetched downloaded," \
  "$missing missing, $failed failed"
[[ $failed == 0 && $missing == 0 ]]
