#!/usr/bin/env python3
"""insid's identification problem as an IOHexperimenter problem, logged for IOHanalyzer.

`ioh.wrap_problem` makes Eq. 15 on the box [-1, 1]^d an ioh problem (minimised) and an
`ioh.logger.Analyzer` writes its evaluations in IOHprofiler's format, the format `insid export
--to iohprofiler` writes for insid's own campaigns: IOHanalyzer reads both alike. insid scores a
generation in one batch; the ioh problem then sees the candidates one by one, in order, and logs
each. Any ask/tell optimizer drives it the same way; here Debian's `cmaes`.
Usage: ioh_logged.py DATASET_DIR [BUDGET [SEED [LOG_ROOT]]]   (PYTHONPATH holds the built module)
"""
import glob
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
    logger = ioh.logger.Analyzer(root=log_root, folder_name="insid", algorithm_name="cmaes",
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
    """What IOHanalyzer will read: one .info naming the problem, its dimension and the run's
    evaluations and best; a .dat whose last best-so-far is the run's best. -> failures."""
    failures = []
    infos = glob.glob(os.path.join(log_root, "insid*", "IOHprofiler_f*.info"))
    if len(infos) != 1:
        return [f"ioh wrote {len(infos)} .info files under {log_root}, expected 1"]
    with open(infos[0]) as fh:
        header, _, runs = (fh.readline().strip(), fh.readline(), fh.readline().strip())
    fields = dict(kv.split(" = ", 1) for kv in header.split(", "))
    if fields.get("DIM") != "4" or "insid_identification" not in fields.get("funcName", ""):
        failures.append(f"ioh .info header: {header}")
    if fields.get("maximization", "").strip() not in ("F", "False", "0"):
        failures.append(f"ioh logged a maximisation: {header}")
    data_file, *records = [s.strip() for s in runs.split(",")]
    last_evaluations, last_best = records[-1].split(":")[1].split("|")
    if int(last_evaluations) != evaluations or not np.isclose(float(last_best), best_f,
                                                                rtol=1e-9, atol=0):
        failures.append(f"ioh .info run record {records[-1]}: expected {evaluations} "
                        f"evaluations, best {best_f!r}")
    with open(os.path.join(os.path.dirname(infos[0]), data_file)) as fh:
        lines = [line.split() for line in fh if line.strip()]
    if lines[0][:2] != ["evaluations", "raw_y"]:
        failures.append(f"ioh .dat header {lines[0]}")
    elif not np.isclose(float(lines[-1][1]), best_f, rtol=1e-9, atol=0):
        failures.append(f"ioh .dat last best-so-far {lines[-1][1]} != {best_f!r}")
    return failures


if __name__ == "__main__":
    p = insid.Problem(data=sys.argv[1], fitness="fast")
    budget = int(sys.argv[2]) if len(sys.argv) > 2 else 2000
    seed = int(sys.argv[3]) if len(sys.argv) > 3 else 1
    root = sys.argv[4] if len(sys.argv) > 4 else "ioh-runs"
    x, f, n = minimize(p, budget, seed, root)
    print(f"ioh + cmaes: Eq. 15 = {f:.6g} after {n} evaluations at {p.to_si(x)}; logs in {root}/")
