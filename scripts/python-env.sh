#!/usr/bin/env bash
# The Python examples' optimisers that Debian does not package (pycma, nevergrad, pymoo,
# IOHexperimenter's ioh) into a virtual environment build/venv, from PyPI (issue 48). The venv sees
# Debian's packages (--system-site-packages: numpy, scipy, cmaes) and the insid module the build
# made; the system interpreter is left as it is. Where PyPI cannot be reached the venv is made
# without them and ctest `python_examples` skips their examples by name; nothing else needs them.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=build/venv
if [ ! -x "$venv/bin/python" ] && ! /usr/bin/python3 -m venv --system-site-packages "$venv" >&2; then
  echo "insid: could not make build/venv (python3-venv missing?): python_examples runs with" \
       "/usr/bin/python3 and skips the examples of the optimisers Debian does not package" >&2
  exit 0  # what venv left there is not removed: the test uses build/venv only with its python
fi
# The module the build made (build/python/insid*.so): `build/venv/bin/python -c "import insid"`.
site=$("$venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
echo "$PWD/build/python" > "$site/insid.pth"
if "$venv/bin/python" -c "import cma, nevergrad, pymoo, ioh" >/dev/null 2>&1; then
  exit 0
fi
if ! "$venv/bin/pip" install -q --retries 1 --timeout 20 cma nevergrad pymoo ioh >&2; then
  echo "insid: PyPI was not reachable: build/venv has no pycma, nevergrad, pymoo or ioh;" \
       "ctest python_examples skips their examples (the Debian-packaged ones still run)" >&2
fi
