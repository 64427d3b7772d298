#!/usr/bin/env bash
# Configure and build insid (Release) into ./build: the program, build/cli/insid.
#   scripts/build.sh [--all] [CMAKE_ARGS ...]
# --all also builds the tests, the micro-benchmarks and the research programs in build/tools/
# (insid-*-study, insid-diagnose-campaign, insid-paper-table) and the Python module (build/python/,
# when pybind11 is installed); scripts/test.sh does. Other
# arguments go to cmake.
set -euo pipefail
cd "$(dirname "$0")/.."
targets=(--target insid)
args=()
for a in "$@"; do
  if [[ "$a" == "--all" ]]; then targets=(); else args+=("$a"); fi
done
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "${args[@]}" >&2
cmake --build build -j"$(nproc)" "${targets[@]}" >&2
