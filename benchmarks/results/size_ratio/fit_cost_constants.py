"""The fit behind the constants of `search_cell` (src/geometry/grid.rs), 2026-12-03.

The pair search's cost over ratio 1 (10th percentiles, runs_2026-12-03_branch_free_refit.txt,
the cell divisor forced to s) is fitted, by non-negative least squares, to the terms of
the cost estimate computed on the benchmark's packs (/tmp/ratio_pack_RATIO.txt, written
by search_ab.rs): small particles' candidates and rows, large particles' candidates,
rows and count. Needs numpy and scipy. Prints the fit and the divisor that the rounded
constants choose at each ratio from the engine's set.
"""

import numpy as np
from scipy.optimize import nnls

MEASURED = {
    2: {1: 1.57, 1.25: 1.59, 1.5: 1.95, 1.75: 2.49, 2: 2.75, 2.5: 3.60, 3: 4.03, 4: 4.33, 6: 4.34},
    4: {1: 2.50, 1.25: 1.88, 1.5: 1.76, 1.75: 1.79, 2: 1.91, 2.5: 2.50, 3: 3.54, 4: 5.89, 6: 5.29},
    8: {1: 3.84, 1.25: 2.59, 1.5: 2.00, 1.75: 1.81, 2: 1.75, 2.5: 1.94, 3: 2.38, 4: 3.46, 6: 4.87},
}
KEYS = ["small_candidates", "small_rows", "large_candidates", "large_rows", "large"]


def load(ratio):
    a = np.loadtxt(f"/tmp/ratio_pack_{float(ratio)}.txt".replace(".0.txt", ".txt"))
    return a[:, :3], a[:, 3] + 0.001


def terms(x, reach, s):
    """The estimate's terms per particle, as search_cell computes them (3D)."""
    reach_max = reach.max()
    coarse = 2 * reach_max
    cell = coarse / s
    volume = np.prod(np.maximum(x.max(0) - x.min(0), coarse))
    n = len(x)
    density = n / volume
    small = reach <= 0.5 * cell
    side = 2 * np.ceil((reach[~small] + reach_max) / cell) + 1
    return {
        "small_candidates": small.sum() * density * (3 * cell) ** 3 / n,
        "small_rows": small.sum() * 9 / n,
        "large_candidates": (0.52 * density * (side * cell) ** 3).sum() / n,
        "large_rows": (0.79 * side**2).sum() / n,
        "large": (~small).sum() / n,
        "cells": min(volume / cell**3 / n, 8),
    }


rows, y = [], []
for ratio, by_s in MEASURED.items():
    x, reach = load(ratio)
    for s, t in by_s.items():
        rows.append(terms(x, reach, s))
        y.append(t)
x1, reach1 = load(1)
rows.append(terms(x1, reach1, 1))
y.append(1.0)
a = np.array([[r[k] for k in KEYS] for r in rows])
coef, residual = nnls(a, np.array(y))
unit = coef[0]
print(
    "fit, in small candidates:",
    {k: round(c / unit, 1) for k, c in zip(KEYS, coef, strict=True)},
    "residual",
    round(residual, 3),
)

# the engine's constants (rounded from the fit) and the divisor each ratio gets
K = {
    "small_candidates": 1,
    "small_rows": 10,
    "large_candidates": 3,
    "large_rows": 4,
    "large": 300,
    "cells": 1,
}
for ratio in MEASURED:
    x, reach = load(ratio)
    cost = {s: sum(K[k] * v for k, v in terms(x, reach, s).items()) for s in [1, 1.5, 2, 3, 4, 6]}
    best = min(cost, key=cost.get)
    print(
        f"ratio {ratio}: chooses s = {best}, measured {MEASURED[ratio][best]:.2f} "
        f"(best measured {min(MEASURED[ratio].values()):.2f})"
    )
