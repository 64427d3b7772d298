#!/usr/bin/env python3
"""insid's identification problem as an IOHexperimenter problem, logged for IOHanalyzer.

`ioh.wrap_problem` makes Eq. 15 on the box [-1, 1]^d an ioh problem (minimised) and an
`ioh.logger.Analyzer` writes its evaluations for IOHanalyzer (a .json of the run and a .dat of
its improvements), which loads them beside insid's own campaigns (`insid export --to
iohprofiler`, the .info form of the same format). insid scores a
generation in one batch; the ioh problem then sees the candidates one by one, in order, and logs
each. Any ask/tell optimizer drives it the same way; here Debian's `cmaes`.
Usage: ioh_logged.py DATASET_DIR [BUDGET [SEED [LOG_ROOT]]]   (PYTHONPATH holds the built module)
"""
import glob
import json
import os
import sys

import ioh
import numpy as np
from cmaes import CMA

import insid


class BatchScored:
    """The function ioh wraps: the value insid gave x in the batch scored last (x alone, else)."""

    def __init__(self, problem):
        self.problem, self.values = problem, {}

    def score(self, X):
        self.values = {x.tobytes(): v for x, v in zip(X, self.problem.evaluate(X))}

    def __call__(self, x):
        x = np.asarray(x, dtype=float)
        value = self.values.get(x.tobytes())
        return float(value) if value is not None else float(self.problem(x))


def minimize(problem, budget, seed, log_root="ioh-runs", name="insid_identification"):
    """Eq. 15's minimum in problem's box within `budget` evaluations: (x, f, evaluations); the
    run is logged under log_root/insid/ (IOHprofiler format)."""
    scored = BatchScored(problem)
    f = ioh.wrap_problem(scored, name=name, problem_class=ioh.ProblemClass.REAL,
                         dimension=problem.dimension, instance=1,
                         optimization_type=ioh.OptimizationType.MIN, lb=-1.0, ub=1.0)
    # Every improvement (the default trigger skips those under ioh's delta, 1e-10).
    logger = ioh.logger.Analyzer(triggers=[ioh.logger.trigger.ON_IMPROVEMENT],
                                 root=log_root, folder_name="insid", algorithm_name="cmaes",
                                 algorithm_info=f"Debian cmaes, sigma0 0.3, seed {seed}, "
                                                f"insid fitness {problem.fitness}")
    f.attach_logger(logger)
    es = CMA(mean=np.zeros(problem.dimension), sigma=0.3,
             bounds=np.column_stack([problem.lower, problem.upper]), seed=seed)
    best_x, best_f = None, np.inf
    while f.state.evaluations + es.population_size <= budget and not es.should_stop():
        X = np.array([es.ask() for _ in range(es.population_size)])
        scored.score(X)
        values = [f(x) for x in X]  # logged one by one, in order
        es.tell(list(zip(X, values)))
        if min(values) < best_f:
            best_x, best_f = X[int(np.argmin(values))], float(min(values))
    evaluations = f.state.evaluations
    f.reset()
    logger.close()
    return best_x, best_f, evaluations


def check_logs(log_root, best_f, evaluations):
    """What IOHanalyzer will read (ioh's Analyzer: a .json of the run, a .dat of its
    evaluations): the problem, minimised, in insid's dimension, the run's evaluations and best,
    and a .dat whose best value is that best. -> failures."""
    metas = glob.glob(os.path.join(log_root, "insid*", "IOHprofiler_f*.json"))
    if len(metas) != 1:
        return [f"ioh wrote {len(metas)} .json files under {log_root}, expected 1"]
    with open(metas[0]) as fh:
        meta = json.load(fh)
    failures = []
    scenario = meta["scenarios"][0]
    run = scenario["runs"][-1]
    if meta["function_name"] != "insid_identification" or meta["maximization"]:
        failures.append(f"ioh logged {meta['function_name']}, maximization {meta['maximization']}")
    if scenario["dimension"] != 4 or run["evals"] != evaluations:
        failures.append(f"ioh logged dimension {scenario['dimension']}, {run['evals']} "
                        f"evaluations; expected 4, {evaluations}")
    if run["best"]["y"] != best_f:
        failures.append(f"ioh logged the best {run['best']['y']!r}, the run's is {best_f!r}")
    with open(os.path.join(os.path.dirname(metas[0]), scenario["path"])) as fh:
        rows = [line.split() for line in fh if line.strip()]
    if rows[0] != ["evaluations", "raw_y"]:
        failures.append(f"ioh .dat header {rows[0]}")
    elif not np.isclose(min(float(r[1]) for r in rows[1:]), best_f, rtol=1e-9, atol=0):
        failures.append(f"the .dat's best {min(float(r[1]) for r in rows[1:])} != {best_f!r}")
    return failures


if __name__ == "__main__":
    p = insid.Problem(data=sys.argv[1], fitness="fast")
    budget = int(sys.argv[2]) if len(sys.argv) > 2 else 2000
    seed = int(sys.argv[3]) if len(sys.argv) > 3 else 1
    root = sys.argv[4] if len(sys.argv) > 4 else "ioh-runs"
    x, f, n = minimize(p, budget, seed, root)
    print(f"ioh + cmaes: Eq. 15 = {f:.6g} after {n} evaluations at {p.to_si(x)}; logs in {root}/")
