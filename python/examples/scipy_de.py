#!/usr/bin/env python3
"""insid's identification problem under SciPy's differential evolution (Debian's python3-scipy).

`vectorized=True` hands the whole population to insid in one batch (SciPy passes it as (d, S)).
Usage: scipy_de.py DATASET_DIR [BUDGET [SEED]]   (PYTHONPATH holds the built insid module)
"""
import sys

from scipy.optimize import differential_evolution

import insid


def minimize(problem, budget, seed, population_per_dimension=5):
    """Eq. 15's minimum in problem's box within `budget` evaluations: (x, f, evaluations)."""
    population = population_per_dimension * problem.dimension
    evaluations = 0

    def f(X):  # X: (d, S), the population
        nonlocal evaluations
        evaluations += X.shape[1]
        return problem.evaluate(X.T)

    result = differential_evolution(
        f, list(zip(problem.lower, problem.upper)),
        popsize=population_per_dimension, maxiter=budget // population - 1, tol=0, seed=seed,
        polish=False, vectorized=True, updating="deferred")
    return result.x, float(result.fun), evaluations


if __name__ == "__main__":
    p = insid.Problem(data=sys.argv[1], fitness="fast")
    budget = int(sys.argv[2]) if len(sys.argv) > 2 else 2000
    x, f, n = minimize(p, budget, int(sys.argv[3]) if len(sys.argv) > 3 else 1)
    print(f"scipy DE: Eq. 15 = {f:.6g} after {n} evaluations at {p.to_si(x)}")
