#!/usr/bin/env bash
# Install dependencies, build, and run the whole test suite with ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh --all -DINSID_WERROR=ON  # everything, warning-free
scripts/python-env.sh      # the Python examples' optimisers from PyPI (build/venv), where reachable
ctest --test-dir build --output-on-failure -j"$(nproc)" --timeout 900
