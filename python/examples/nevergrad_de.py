#!/usr/bin/env python3
"""insid's identification problem under nevergrad (its differential evolution).

nevergrad's ask/tell with a generation in flight (`num_workers`): insid scores it in one batch.
Usage: nevergrad_de.py DATASET_DIR [BUDGET [SEED]]   (PYTHONPATH holds the built insid module)
"""
import sys

import nevergrad as ng
import numpy as np

import insid


def minimize(problem, budget, seed, population=10):
    """Eq. 15's minimum in problem's box within `budget` evaluations: (x, f, evaluations)."""
    space = ng.p.Array(shape=(problem.dimension,)).set_bounds(np.array(problem.lower),
                                                              np.array(problem.upper))
    space.random_state = np.random.RandomState(seed)
    # insid's DE settings (population 10, CR 0.9, F 0.8), one generation per batch
    family = ng.optimizers.DifferentialEvolution(popsize=population, crossover=0.9, F1=0.8, F2=0.8)
    optimizer = family(parametrization=space, budget=budget, num_workers=population)
    evaluations = 0
    while evaluations + population <= budget:
        candidates = [optimizer.ask() for _ in range(population)]
        f = problem.evaluate(np.array([c.value for c in candidates]))
        for c, value in zip(candidates, f):
            optimizer.tell(c, float(value))
        evaluations += population
    best = optimizer.provide_recommendation().value
    return best, float(problem(best)), evaluations


if __name__ == "__main__":
    p = insid.Problem(data=sys.argv[1], fitness="fast")
    budget = int(sys.argv[2]) if len(sys.argv) > 2 else 2000
    x, f, n = minimize(p, budget, int(sys.argv[3]) if len(sys.argv) > 3 else 1)
    print(f"nevergrad DE: Eq. 15 = {f:.6g} after {n} evaluations at {p.to_si(x)}")
