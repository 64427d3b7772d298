#!/usr/bin/env python3
"""The Python examples (python/examples/) against insid's own optimizers (ctest `python_examples`;
issue 48).

On the paper flight (`insid simulate --preset paper --seed 1`), each example minimises Eq. 15 with
its library at insid's budget (2000 evaluations, seed 1, the fast search fitness, as `insid
identify` searches) and must end where insid's own optimizer of its family ends, `insid identify
--algo cmaes` or `--algo de` at the same budget: every parameter within insid's sd (identify's
100 noise replicas), and the exact Eq. 15 of both points printed beside each other.

The examples whose library is Debian's (cmaes: python3-cmaes; SciPy: python3-scipy) must run;
pycma, nevergrad, pymoo and IOHexperimenter are not Debian packages: they run where the set-up put
them in build/venv (scripts/python-env.sh, from PyPI) and are skipped, by name, where not.

Usage: test_examples.py INSID_PROGRAM BUILD_DIR     (PYTHONPATH holds the built module)
"""
import importlib.util
import json
import os
import subprocess
import sys
import tempfile

BUDGET, SEED = 2000, 1
HERE = os.path.dirname(os.path.abspath(__file__))
# (example, the package it needs, where the package comes from, insid's optimizer to match)
EXAMPLES = [
    ("cmaes_debian", "cmaes", "debian:python3-cmaes", "cmaes"),
    ("scipy_de", "scipy", "debian:python3-scipy", "de"),
    ("pycma_cmaes", "cma", "pypi:cma", "cmaes"),
    ("nevergrad_de", "nevergrad", "pypi:nevergrad", "de"),
    ("pymoo_de", "pymoo", "pypi:pymoo", "de"),
    ("ioh_logged", "ioh", "pypi:ioh", "cmaes"),
]


def reexec_in_venv(build_dir):
    """Runs this test with build/venv's interpreter when the set-up made one (it sees the PyPI
    packages and, with --system-site-packages, Debian's)."""
    venv_python = os.path.join(build_dir, "venv", "bin", "python")
    if os.path.exists(venv_python) and os.path.realpath(sys.prefix) != os.path.realpath(
            os.path.join(build_dir, "venv")):
        os.execv(venv_python, [venv_python] + sys.argv)


def identify(program, data, algo, out, replicas):
    subprocess.run([program, "identify", "--data", data, "--algo", algo, "--iterations", "0",
                    "--evaluations", str(BUDGET), "--seed", str(SEED), "--fixed-box",
                    "--no-reference-optimum", "--uncertainty-replicas", str(replicas), "--quiet",
                    "--out", out], check=True)
    with open(out) as f:
        return json.load(f)


def main():
    program, build_dir = sys.argv[1], sys.argv[2]
    reexec_in_venv(build_dir)
    try:
        import numpy as np
    except ImportError:
        print("python_examples: skipped: numpy is missing (python3-numpy)")
        return 77
    try:
        import insid
    except ImportError as e:
        print(f"python_examples: FAIL: the module does not import: {e}")
        return 1
    print(f"python_examples: {sys.executable}")
    failures, ran, skipped = [], [], []
    venv = os.path.join(build_dir, "venv")
    if os.path.realpath(sys.prefix) == os.path.realpath(venv):
        # The set-up's venv finds the module without PYTHONPATH (scripts/python-env.sh).
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        found = subprocess.run([sys.executable, "-c", "import insid; print(insid.__file__)"],
                               env=env, capture_output=True, text=True)
        if found.returncode != 0:
            failures.append(f"build/venv does not import insid: {found.stderr.strip()}")
            print("FAIL:", failures[-1])
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "paper")
        subprocess.run([program, "simulate", "--preset", "paper", "--seed", "1", "--out", data],
                       check=True, stderr=subprocess.DEVNULL)
        # insid's own optimizers at the same budget; sd from CMA-ES's end point (identify's
        # uncertainty; the two end points lie far within it of each other, checked below).
        ref = {"cmaes": identify(program, data, "cmaes", os.path.join(tmp, "c.json"), 100),
               "de": identify(program, data, "de", os.path.join(tmp, "d.json"), 0)}
        fast = insid.Problem(data=data, fitness="fast")
        exact = insid.Problem(data=data)
        names = fast.names
        sd = np.array([q["sd_in_sigma_units"] for q in ref["cmaes"]["parameters"]])
        box = np.array(fast.box_sigma)
        mid, half = box.mean(axis=1), (box[:, 1] - box[:, 0]) / 2
        insid_sigma = {k: np.array([r["estimate_in_sigma_units"][n] for n in names])
                       for k, r in ref.items()}
        print(f"sd (sigma units): {sd}")
        gap = np.max(np.abs(insid_sigma["cmaes"] - insid_sigma["de"]) / sd)
        print(f"insid cmaes vs insid de: {gap:.3g} sd apart; exact Eq. 15 "
              f"{ref['cmaes']['fitness']:.9g} and {ref['de']['fitness']:.9g}")
        if not gap <= 1:
            failures.append(f"insid's own CMA-ES and DE end {gap:.3g} sd apart")

        for example, package, origin, family in EXAMPLES:
            if importlib.util.find_spec(package) is None:
                kind, name = origin.split(":")
                if kind == "debian":
                    failures.append(f"{example}: {package} is missing: apt-get install {name} "
                                    "(scripts/install-deps.sh)")
                    print("FAIL:", failures[-1])
                else:
                    skipped.append(example)
                    print(f"{example}: skipped: the Python package {package} is not installed "
                          f"(not a Debian package: scripts/python-env.sh puts it in build/venv "
                          f"from PyPI, where PyPI is reachable)")
                continue
            spec = importlib.util.spec_from_file_location(
                example, os.path.join(HERE, "examples", example + ".py"))
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            with tempfile.TemporaryDirectory() as logs:
                kwargs = {"log_root": logs} if example == "ioh_logged" else {}
                x, f_search, evaluations = module.minimize(fast, BUDGET, SEED, **kwargs)
                if example == "ioh_logged":  # what IOHanalyzer will read
                    for failure in module.check_logs(logs, f_search, evaluations):
                        failures.append(f"{example}: {failure}")
                        print("FAIL:", failures[-1])
            x = np.asarray(x, dtype=float)
            x_sigma = mid + half * x
            apart = np.abs(x_sigma - insid_sigma[family]) / sd
            f_exact = exact(x)
            ran.append(example)
            print(f"{example}: {evaluations} evaluations, exact Eq. 15 {f_exact:.9g} (insid "
                  f"{family}: {ref[family]['fitness']:.9g}), search {f_search:.9g}; "
                  f"|x - insid {family}| / sd = {np.array2string(apart, precision=3)}")
            if evaluations > BUDGET:
                failures.append(f"{example}: {evaluations} evaluations, budget {BUDGET}")
            if not np.all(apart <= 1):
                failures.append(f"{example}: {np.max(apart):.3g} sd from insid's {family} "
                                f"({names[int(np.argmax(apart))]})")
                print("FAIL:", failures[-1])

    if failures:
        print(f"python_examples: {len(failures)} failure(s)")
        return 1
    print(f"python_examples: {', '.join(ran)} end within insid's sd of its own optimizer"
          + (f"; skipped (package not installed): {', '.join(skipped)}" if skipped else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
