#!/usr/bin/env bash
# Install insid's build and script dependencies from Debian 12 packages (as root).
# Only missing packages are installed; nothing happens when all are present.
set -euo pipefail
packages=(build-essential cmake git libeigen3-dev nlohmann-json3-dev libcli11-dev
          libbenchmark-dev libgtest-dev libboost-dev libssl-dev
          libpagmo-dev libceres-dev libnlopt-cxx-dev
          libopenmpi-dev openmpi-bin
          python3 python3-numpy python3-scipy python3-matplotlib
          python3-dev pybind11-dev  # the insid Python module (python/)
          python3-cmaes python3-venv  # its examples (python/examples/; build/venv)
          r-cran-irace)  # irace: scripts/irace_tune.py (optional: without it only that test skips)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "insid: installing ${missing[*]}" >&2
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
fi
