#!/usr/bin/env bash
# The sanitizer suite: build with AddressSanitizer + UndefinedBehaviorSanitizer (RelWithDebInfo,
# so the kernel-heavy tests finish) into ./build-asan and run the whole ctest suite there.
# Any sanitizer report fails the run (halt_on_error). LeakSanitizer reads
# scripts/lsan-suppressions.txt: only leaks whose whole stack is inside Open MPI's own
# libraries (allocations made by MPI_Init that Open MPI frees at exit only partially); see the
# file. Extra arguments go to ctest (e.g. -R Dataset).
# The tests that launch the insid binary pass the sanitizer options on through the environment.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DINSID_SANITIZE=ON \
      -DINSID_BUILD_BENCHMARKS=OFF >&2
cmake --build build-asan -j"$(nproc)" >&2
export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:abort_on_error=0:strict_string_checks=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export LSAN_OPTIONS="suppressions=$PWD/scripts/lsan-suppressions.txt:print_suppressions=1"
ctest --test-dir build-asan --output-on-failure -j"$(nproc)" --timeout 3600 "$@"
