#!/usr/bin/env python3
"""insid's identification problem under pymoo (its differential evolution, DE/rand/1/bin).

A vectorised pymoo Problem: `_evaluate` receives the population and insid scores it in one batch.
Usage: pymoo_de.py DATASET_DIR [BUDGET [SEED]]   (PYTHONPATH holds the built insid module)
"""
import sys

import numpy as np
from pymoo.algorithms.soo.nonconvex.de import DE
from pymoo.core.problem import Problem
from pymoo.optimize import minimize as pymoo_minimize

import insid


class InsidProblem(Problem):
    def __init__(self, problem):
        super().__init__(n_var=problem.dimension, n_obj=1, xl=np.array(problem.lower),
                         xu=np.array(problem.upper))
        self.problem = problem

    def _evaluate(self, X, out, *args, **kwargs):
        out["F"] = self.problem.evaluate(X)


def minimize(problem, budget, seed, population=10):
    """Eq. 15's minimum in problem's box within `budget` evaluations: (x, f, evaluations)."""
    # insid's DE settings: population 10, CR 0.9, F 0.8
    algorithm = DE(pop_size=population, variant="DE/rand/1/bin", CR=0.9, F=0.8)
    result = pymoo_minimize(InsidProblem(problem), algorithm, ("n_eval", budget), seed=seed,
                            verbose=False)
    return np.array(result.X), float(result.F[0]), int(result.algorithm.evaluator.n_eval)


if __name__ == "__main__":
    p = insid.Problem(data=sys.argv[1], fitness="fast")
    budget = int(sys.argv[2]) if len(sys.argv) > 2 else 2000
    x, f, n = minimize(p, budget, int(sys.argv[3]) if len(sys.argv) > 3 else 1)
    print(f"pymoo DE: Eq. 15 = {f:.6g} after {n} evaluations at {p.to_si(x)}")
