"""The two ensembles side by side: for each statistic, the mean of the double and the
single precision builds' packs (same scene, same seeds), the difference of the means in
sd of the double precision ensemble, and the paired t of the seed-by-seed differences.
Run from this folder: python compare.py > compare.txt
"""

from __future__ import annotations

import numpy as np
import polars as pl

STATS = [
    "n_particles", "phi", "phi_core", "z", "z_mech", "n_rattlers",
    "a_r_mag", "a_n_mag", "a_t_mag", "stress_zz", "k0", "unbalanced",
]  # fmt: skip


def main() -> None:
    a = pl.read_csv("ensemble_f64.csv").sort("pack")
    b = pl.read_csv("ensemble_f32.csv").sort("pack")
    assert a["pack"].to_list() == b["pack"].to_list()
    print(f"{len(a)} packs each, the same seeds")
    print("| statistic | f64 mean | f32 mean | f64 sd | f32 sd | difference / f64 sd | paired t |")
    print("|---|---|---|---|---|---|---|")
    for c in STATS:
        x, y = a[c].to_numpy().astype(float), b[c].to_numpy().astype(float)
        d, sd = y - x, x.std(ddof=1)
        t = d.mean() / (d.std(ddof=1) / np.sqrt(len(d)))
        print(
            f"| {c} | {x.mean():.5g} | {y.mean():.5g} | {sd:.3g} | {y.std(ddof=1):.3g} "
            f"| {d.mean() / sd:+.2f} | {t:+.2f} |"
        )


if __name__ == "__main__":
    main()
