#!/usr/bin/env python3
"""insid's identification problem under pycma (package `cma`), the CMA-ES most researchers use.

pycma asks for a population; insid scores it in one batch on its vectorised kernel.
Usage: pycma_cmaes.py DATASET_DIR [BUDGET [SEED]]   (PYTHONPATH holds the built insid module)
"""
import sys

import cma
import numpy as np

import insid


def minimize(problem, budget, seed):
    """Eq. 15's minimum in problem's box within `budget` evaluations: (x, f, evaluations)."""
    es = cma.CMAEvolutionStrategy(np.zeros(problem.dimension), 0.3,
                                  {"bounds": [problem.lower, problem.upper], "seed": seed,
                                   "maxfevals": budget, "verbose": -9})
    while not es.stop() and es.countevals + es.popsize <= budget:  # whole generations only
        X = es.ask()
        es.tell(X, problem.evaluate(np.array(X)).tolist())
    return np.array(es.result.xbest), float(es.result.fbest), int(es.result.evaluations)


if __name__ == "__main__":
    p = insid.Problem(data=sys.argv[1], fitness="fast")
    budget = int(sys.argv[2]) if len(sys.argv) > 2 else 2000
    x, f, n = minimize(p, budget, int(sys.argv[3]) if len(sys.argv) > 3 else 1)
    print(f"pycma: Eq. 15 = {f:.6g} after {n} evaluations at {p.to_si(x)}")
