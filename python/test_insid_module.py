#!/usr/bin/env python3
"""The insid Python module against the command line (ctest `python_module`; issue 48).

- the same values as `insid identify` for the same candidates: the positions and fitness that
  `insid identify --positions` records, mapped back to the normalised box;
- a batch gives what the same candidates give one at a time, in any order;
- the thread count changes nothing;
- the box, names and units are identify's;
- bad input raises (wrong shape, NaN, a bad option, both or neither of data= and preset=,
  a directory that is not a dataset), with insid's message.

Also runs the README's example ("From Python").

Usage: test_insid_module.py INSID_PROGRAM README.md     (PYTHONPATH holds the built module)
"""
import json
import os
import subprocess
import sys
import tempfile

try:
    import numpy as np
except ImportError:
    print("python_module: skipped: numpy is missing (python3-numpy)")
    sys.exit(77)
try:
    import insid
except ImportError as e:
    print(f"python_module: FAIL: the module does not import: {e}")
    sys.exit(1)

failures = []


def expect(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what)


def raises(kind, fn, needle):
    try:
        fn()
    except kind as e:
        expect(needle in str(e), f"{kind.__name__} without {needle!r}: {e}")
        return
    except Exception as e:  # noqa: BLE001 - the wrong kind is a failure too
        expect(False, f"expected {kind.__name__} ({needle!r}), got {type(e).__name__}: {e}")
        return
    expect(False, f"expected {kind.__name__} ({needle!r}), nothing raised")


def main():
    program, readme = sys.argv[1], sys.argv[2]
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "flight")
        subprocess.run([program, "simulate", "--preset", "rich", "--flight-s", "200", "--grade",
                        "nav", "--seed", "3", "--out", data], check=True,
                       stderr=subprocess.DEVNULL)
        result = os.path.join(tmp, "r.json")
        subprocess.run([program, "identify", "--data", data, "--algo", "dvpio", "--iterations", "3",
                        "--seed", "2", "--positions", "--fitness", "exact",
                        "--uncertainty-replicas", "0", "--no-reference-optimum", "--quiet",
                        "--out", result], check=True)
        with open(result) as f:
            r = json.load(f)

        p = insid.Problem(data=data)
        # The box, names and units are identify's.
        expect(p.names == [e["name"] for e in r["estimated"]], f"names {p.names}")
        expect(p.sigma == [e["sigma"] for e in r["estimated"]], f"sigma {p.sigma}")
        expect(p.dimension == 4 and p.lower == [-1.0] * 4 and p.upper == [1.0] * 4,
               f"box {p.lower} {p.upper}")
        expect(p.grade == "nav" and p.window_s == 0.0 and p.fitness == "exact",
               f"grade {p.grade}, window {p.window_s}, fitness {p.fitness}")

        # The same values as insid identify: its recorded positions (sigma units) and fitness.
        box = np.array(p.box_sigma)
        mid, half = box.mean(axis=1), (box[:, 1] - box[:, 0]) / 2
        X, f_cli = [], []
        for h in r["history"]:
            X += [(np.array(s) - mid) / half for s in h["positions_sigma"]]
            f_cli += h["positions_fitness"]
        X, f_cli = np.array(X), np.array(f_cli)
        f = p.evaluate(X)
        worst = np.max(np.abs(f - f_cli) / f_cli)
        print(f"{len(f)} of identify's candidates: worst relative difference {worst:.2e}")
        # The positions went through sigma units and back (to_sigma, JSON, from_sigma): their
        # last bits move, nothing else.
        expect(worst <= 1e-12, f"identify's candidates differ by {worst:.2e} relative")

        # A batch gives what the candidates give alone, in any order; threads change nothing.
        singles = np.array([p(x) for x in X])
        expect(np.array_equal(singles, f), "batch != singles")
        order = np.random.default_rng(1).permutation(len(X))
        expect(np.array_equal(p.evaluate(X[order]), f[order]), "a permuted batch differs")
        one = insid.Problem(data=data, threads=1)
        expect(np.array_equal(one.evaluate(X), f), "1 thread differs from the default")
        si = p.to_si(X[0])
        expect(set(si) == set(p.names), f"to_si names {si}")
        expect(abs(si[p.names[0]] - (mid[0] + half[0] * X[0][0]) * p.sigma[0]) <=
               1e-15 + 1e-12 * abs(si[p.names[0]]), f"to_si value {si}")

        # How sure a point is, as identify reports it: identify's best with its uncertainty (in the
        # box as given: a widened box would change the flags that read the box).
        full = os.path.join(tmp, "full.json")
        subprocess.run([program, "identify", "--data", data, "--algo", "dvpio", "--iterations", "3",
                        "--seed", "2", "--fitness", "exact", "--no-reference-optimum", "--quiet",
                        "--fixed-box", "--out", full], check=True)
        with open(full) as fh:
            rf = json.load(fh)
        best = (np.array([rf["estimate_in_sigma_units"][n] for n in p.names]) - mid) / half
        rep = p.report(best)
        expect(abs(rep["fitness"] - rf["fitness"]) <= 1e-12 * rf["fitness"],
               f"report fitness {rep['fitness']} vs identify's {rf['fitness']}")
        for mine, cli in zip(rep["parameters"], rf["parameters"]):
            expect(mine["name"] == cli["name"] and mine["flags"] == cli["flags"],
                   f"report {mine['name']} {mine['flags']} vs {cli['name']} {cli['flags']}")
            expect(abs(mine["sd"] - cli["sd"]) <= 1e-9 * cli["sd"],
                   f"report sd of {cli['name']}: {mine['sd']} vs identify's {cli['sd']}")
        raises(ValueError, lambda: p.report(best, replicas=5), "replicas")

        # The fast search fitness is there too, within its tolerance of the exact one.
        fast = insid.Problem(data=data, fitness="fast")
        expect(fast.fitness == "fast", f"fitness {fast.fitness}")
        rel = np.max(np.abs(fast.evaluate(X) - f) / f)
        expect(0 < rel <= 1e-4, f"fast vs exact {rel:.2e}")

        # Bad input raises, with insid's message.
        raises(ValueError, lambda: p.evaluate(np.zeros((3, 5))), "shape (n, 4)")
        raises(ValueError, lambda: p.evaluate(np.zeros(4)), "shape (n, 4)")
        bad = X[:2].copy()
        bad[1, 2] = np.nan
        raises(ValueError, lambda: p.evaluate(bad), "X[1, 2] is not finite")
        raises(ValueError, lambda: p(np.zeros((2, 4))), "one candidate")
        raises(ValueError, lambda: insid.Problem(data=data, fitness="slow"), "fast")
        raises(ValueError, lambda: insid.Problem(data=data, preset="paper"), "exactly one")
        raises(ValueError, lambda: insid.Problem(), "exactly one")
        raises(ValueError, lambda: insid.Problem(data=data, estimate=["no_such_effect"]),
               "no_such_effect")
        raises(ValueError, lambda: insid.Problem(preset="no-such-preset"), "no-such-preset")
        raises(RuntimeError, lambda: insid.Problem(data=tmp), tmp)

        # A simulated preset, as `insid simulate --preset` would make it.
        q = insid.Problem(preset="rich", flight_s=200, seed=3)
        expect(q.dimension == 4, f"preset dimension {q.dimension}")

    # The README's example ("From Python"), as it stands there.
    with open(readme) as f:
        text = f.read()
    section = text[text.index("### From Python"):]
    example = section[section.index("```python\n") + 10:section.index("```\n", section.index(
        "```python\n") + 10)]
    try:
        exec(compile(example, "README.md (From Python)", "exec"), {})
    except Exception as e:  # noqa: BLE001 - any failure of the example is the test's failure
        expect(False, f"the README's example fails: {type(e).__name__}: {e}")

    if failures:
        print(f"python_module: {len(failures)} failure(s)")
        return 1
    print("python_module: the module gives insid identify's values, batch = singles, "
          "any order and thread count, and refuses bad input")
    return 0


if __name__ == "__main__":
    sys.exit(main())
