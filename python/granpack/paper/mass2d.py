"""The two 2D mass conventions side by side, for ``granpack paper``.

A 2D particle has the mass of a disc of unit thickness (``inertia_2d="disc"``, the
presets' default and the convention of LAMMPS ``density/disc`` and PFC2D) or of a sphere
of its radius (``"sphere"``). The paper does not say which it used, and the choice moves
phi by up to 0.05 (docs/physics.md). So ``granpack paper`` also runs every 2D case under
the other convention, which costs little beside the 3D cases, and reports both beside the
paper's phi and LAMMPS' (``data/lammps_2d.csv``, disc mass, one pack per case).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path

import numpy as np
import polars as pl

from ..ensemble import PackTask, ensemble_tasks
from ..scene import PackScene

__all__ = [
    "OTHER",
    "case_dir",
    "lammps_phi",
    "other_convention_tasks",
    "convention_table",
    "report_lines",
]

#: The convention each one is compared with.
OTHER = {"sphere": "disc", "disc": "sphere"}


def case_dir(example: str, rotations: bool, convention: str) -> str:
    """Folder of a case's packs under the other convention: ``4.1-on-disc-mass``."""
    return f"{example}-{'on' if rotations else 'off'}-{convention}-mass"


def lammps_phi() -> dict[tuple[str, bool], float]:
    """LAMMPS' bulk phi per 2D case {(example, rotations): phi}, from data/lammps_2d.csv."""
    text = resources.files("granpack").joinpath("data/lammps_2d.csv").read_text()
    df = pl.read_csv(text.encode(), comment_prefix="#", schema_overrides={"example": pl.String})
    return {
        (ex, bool(rot)): float(phi)
        for ex, rot, phi in df.select("example", "rotations", "phi_bulk").iter_rows()
    }


def other_convention_tasks(
    scenes: Mapping[tuple[str, bool], PackScene], n_packs: int, packs_dir: Path, seed: int
) -> dict[tuple[str, bool], list[PackTask]]:
    """The packs of every 2D case again, under the other convention (same seeds and
    streams, so pack k differs from its twin only by the mass)."""
    out = {}
    for (ex, rot), scene in scenes.items():
        if scene.dim != 2:
            continue
        other = OTHER[scene.inertia_2d]
        label = f"{ex} {'ON' if rot else 'OFF'} {other} mass"
        out[ex, rot] = ensemble_tasks(
            scene.replace(inertia_2d=other),
            n_packs,
            packs_dir / case_dir(ex, rot, other),
            seed,
            label,
        )
    return out


def _mean_sd(values: Sequence[float]) -> tuple[float, float]:
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return math.nan, math.nan
    return float(v.mean()), float(v.std(ddof=1)) if v.size > 1 else math.nan


def convention_table(
    scenes: Mapping[tuple[str, bool], PackScene],
    phi: Mapping[tuple[str, bool], Sequence[float]],
    other_phi: Mapping[tuple[str, bool], Sequence[float]],
    paper_phi: Mapping[tuple[str, bool], Sequence[float]],
) -> pl.DataFrame:
    """One row per 2D case: phi (mean and sd, ddof = 1) under each convention, LAMMPS'
    phi, and the paper's.

    Parameters
    ----------
    scenes : the cases' scenes as run (their ``inertia_2d`` is the default convention).
    phi : per case, each pack's phi under the scene's convention.
    other_phi : per case, each pack's phi under the other convention.
    paper_phi : per case, the paper's per-pack phi (may lack a case).

    Returns
    -------
    pl.DataFrame
        Columns example, rotations ("ON"/"OFF"), packs, phi_sphere_mass, sd_sphere_mass,
        phi_disc_mass, sd_disc_mass, phi_lammps (disc mass; null where not run), phi_paper,
        sd_paper (null where the paper has no table).
    """
    lammps = lammps_phi()
    rows = []
    for (ex, rot), scene in scenes.items():
        if scene.dim != 2 or (ex, rot) not in other_phi:
            continue
        by = {scene.inertia_2d: phi[ex, rot], OTHER[scene.inertia_2d]: other_phi[ex, rot]}
        s_mean, s_sd = _mean_sd(by["sphere"])
        d_mean, d_sd = _mean_sd(by["disc"])
        p_mean, p_sd = _mean_sd(paper_phi.get((ex, rot), []))
        rows.append(
            {
                "example": ex,
                "rotations": "ON" if rot else "OFF",
                "packs": len(by["sphere"]),
                "phi_sphere_mass": s_mean,
                "sd_sphere_mass": s_sd,
                "phi_disc_mass": d_mean,
                "sd_disc_mass": d_sd,
                "phi_lammps": lammps.get((ex, rot)),
                "phi_paper": None if math.isnan(p_mean) else p_mean,
                "sd_paper": None if math.isnan(p_sd) else p_sd,
            }
        )
    schema = {
        "example": pl.String,
        "rotations": pl.String,
        "packs": pl.Int64,
        **{
            k: pl.Float64
            for k in (
                "phi_sphere_mass",
                "sd_sphere_mass",
                "phi_disc_mass",
                "sd_disc_mass",
                "phi_lammps",
                "phi_paper",
                "sd_paper",
            )
        },
    }
    return pl.DataFrame(rows, schema=schema)


def report_lines(table: pl.DataFrame, default: str, link: str | None = None) -> list[str]:
    """The report's section on the two conventions (empty without 2D cases)."""
    if table.height == 0:
        return []

    def ms(mean, sd) -> str:
        if mean is None or math.isnan(mean):
            return "n/a"
        return f"{mean:.3f}" + ("" if sd is None or math.isnan(sd) else f" ± {sd:.3f}")

    lines = [
        "## The 2D mass convention",
        "",
        f"Every 2D case ran under both conventions, with the same seeds: sphere mass "
        f"(m = 4/3 π r³ ρ) and unit-thickness disc mass (m = π r² ρ, LAMMPS `density/disc`). "
        f"The presets' default is {default} mass; the other convention's packs are in "
        f"`packs/<case>-{OTHER[default]}-mass/`. LAMMPS: one pack per case, disc mass, on "
        "the same job (`granpack/data/lammps_2d.csv`).",
        "",
        "| example | rotations | packs | phi, sphere mass | phi, disc mass | phi, LAMMPS "
        "| phi, paper |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in table.iter_rows(named=True):
        lam = "n/a" if r["phi_lammps"] is None else f"{r['phi_lammps']:.3f}"
        lines.append(
            f"| {r['example']} | {r['rotations']} | {r['packs']} "
            f"| {ms(r['phi_sphere_mass'], r['sd_sphere_mass'])} "
            f"| {ms(r['phi_disc_mass'], r['sd_disc_mass'])} | {lam} "
            f"| {ms(r['phi_paper'], r['sd_paper'])} |"
        )
    lines += ["", f"Table: [csv]({link})" if link else "", ""]
    return lines
