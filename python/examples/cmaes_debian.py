#!/usr/bin/env python3
"""insid's identification problem under `cmaes` (Debian's python3-cmaes; the CMA-ES of Optuna).

An ask/tell loop: each generation's candidates are scored in one batch by insid's kernel.
Usage: cmaes_debian.py DATASET_DIR [BUDGET [SEED]]   (PYTHONPATH holds the built insid module)
"""
import sys

import numpy as np
from cmaes import CMA

import insid


def minimize(problem, budget, seed):
    """Eq. 15's minimum in problem's box within `budget` evaluations: (x, f, evaluations)."""
    bounds = np.column_stack([problem.lower, problem.upper])
    es = CMA(mean=np.zeros(problem.dimension), sigma=0.3, bounds=bounds, seed=seed)
    best_x, best_f, evaluations = None, np.inf, 0
    while evaluations + es.population_size <= budget and not es.should_stop():
        X = np.array([es.ask() for _ in range(es.population_size)])
        f = problem.evaluate(X)
        es.tell(list(zip(X, f)))
        evaluations += len(f)
        if f.min() < best_f:
            best_x, best_f = X[np.argmin(f)], float(f.min())
    return best_x, best_f, evaluations


if __name__ == "__main__":
    p = insid.Problem(data=sys.argv[1], fitness="fast")
    budget = int(sys.argv[2]) if len(sys.argv) > 2 else 2000
    x, f, n = minimize(p, budget, int(sys.argv[3]) if len(sys.argv) > 3 else 1)
    print(f"cmaes: Eq. 15 = {f:.6g} after {n} evaluations at {p.to_si(x)}")
