"""``report.md``: one page that says what was run and links the tables and figures.

`ensemble_report` is written by ``granpack generate``; the paper's report, written by
``granpack paper``, is `granpack.paper.report.paper_report` (``paper_report`` here too,
for existing scripts). Links are relative to the report, so the output folder can be
moved or published as it is.
"""

from __future__ import annotations

import datetime as _dt
import importlib
import math
import os
import platform
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ._files import atomic_write

# paper_report comes from __getattr__ below
__all__ = ["paper_report", "ensemble_report"]  # noqa: F822


def __getattr__(name: str):
    # paper_report's former home: loaded by name on first use, as granpack.paper.report
    # builds on the functions of this module (an import statement here would make the two
    # modules import each other)
    if name == "paper_report":
        return importlib.import_module("granpack.paper.report").paper_report
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _rel(path: Path, base: Path) -> str:
    return Path(os.path.relpath(Path(path).resolve(), Path(base).resolve())).as_posix()


def _mean_sd(values: Sequence[float], digits: int = 3) -> str:
    v = np.asarray([x for x in values if x is not None], dtype=np.float64)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return "n/a"
    if v.size == 1:
        return f"{v[0]:.{digits}f}"
    return f"{v.mean():.{digits}f} ± {v.std(ddof=1):.{digits}f}"


def _col(records: Sequence[Mapping], key: str) -> list[float]:
    return [float(r[key]) if r.get(key) is not None else float("nan") for r in records]


def _grouped_links(files: Sequence[Path], base: Path) -> dict[str, list[tuple[str, str]]]:
    """{stem: [(suffix, relative link)]} for files that share a stem (x.md, x.csv)."""
    groups: dict[str, list[tuple[str, str]]] = {}
    for f in files:
        f = Path(f)
        groups.setdefault(f.stem, []).append((f.suffix.lstrip("."), _rel(f, base)))
    for v in groups.values():
        v.sort(key=lambda s: (s[0] != "md", s[0]))
    return groups


def _environment_line(wall_time: float) -> str:
    from ._core import __version__

    when = _dt.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z")
    return (
        f"granpack {__version__}, {when}, {platform.node() or 'this machine'} "
        f"({os.cpu_count()} cores), wall time {_duration(wall_time)}"
    )


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


def _dev_banner(dev_changes: Mapping) -> list[str]:
    if not dev_changes:
        return []
    parts = ", ".join(f"{k} {v}" for k, v in dev_changes.items())
    return [
        f"> **Development run, not the paper's scenes:** {parts}. "
        "Do not compare these numbers with the paper.",
        "",
    ]


def ensemble_report(
    out_dir: str | Path,
    *,
    scene_name: str,
    scene,
    records: Sequence[Mapping],
    table_files: Sequence[Path],
    figures: Sequence[Path],
    wall_time: float,
    dev_changes: Mapping | None = None,
) -> Path:
    """Writes ``out_dir/report.md`` for ``granpack generate`` and returns its path:
    the scene, per-pack phi, Z and size, and links to tables and figures."""
    out = Path(out_dir)
    rot = "ON" if scene.rotations else "OFF"
    lines = [
        f"# granpack: {len(records)} pack(s) of {scene_name}, rotations {rot}",
        "",
        *_dev_banner(dev_changes or {}),
        f"Scene: [scene.toml](scene.toml) (dim {scene.dim}, base {list(scene.base)} m, "
        f"H_d = {scene.height} m, {scene.radius_law} radii r_mean = {scene.r_mean} m), "
        f"master seed {scene.seed} (pack k uses random stream k). "
        f"{_environment_line(wall_time)}.",
        "",
        f"phi = {_mean_sd(_col(records, 'phi'), 4)}, Z = {_mean_sd(_col(records, 'z'), 3)} "
        "(mean ± sample standard deviation).",
        "",
        *_trim_lines(records, scene),
        *_density_lines(records),
        *_grading_lines(scene, records),
        "| pack | N | layers | H_top (m) | phi | Z | Z_m | unbalanced | seconds | file |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for rec in records:
        k = rec["pack"]
        lines.append(
            f"| {k} | {rec['n_particles']} | {rec.get('n_layers', '')} "
            f"| {rec['height']:.4f} | {rec['phi']:.4f} | {_fmt(rec.get('z'))} "
            f"| {_fmt(rec.get('z_mech'))} | {_fmt_ratio(rec.get('unbalanced'))} "
            f"| {rec.get('wall_time', float('nan')):.1f} "
            f"| [pack_{k:03d}.npz](packs/pack_{k:03d}.npz) |"
        )
    lines += ["", "## Tables", ""]
    groups = _grouped_links(table_files, out)
    for stem in sorted(groups):
        links = " · ".join(f"[{suffix}]({link})" for suffix, link in groups[stem])
        lines.append(f"- {stem}: {links}")
    if figures:
        lines += ["", "## Figures", ""]
        lines.append(" · ".join(f"[{Path(f).stem}]({_rel(f, out)})" for f in figures))
    lines += [
        "",
        "Each pack's microstructure is in `micro/pack_k.json`; "
        "`granpack export PACK --format vtk|lammps-data|csv|parquet` converts a pack.",
        "",
    ]
    return atomic_write(out / "report.md", "\n".join(lines).encode())


def _trim_lines(records: Sequence[Mapping], scene) -> list[str]:
    """The flat top's line of the report (empty for packs made without it)."""
    if not any("phi_hd" in rec for rec in records):
        return []
    return [
        f"Flat top (trim): every particle above H_d = {scene.height} m removed, then a relax; "
        f"removed per pack {_mean_sd(_col(records, 'trim_removed'), 1)}, final top "
        f"{_mean_sd(_col(records, 'trim_top'), 4)} m, phi to H_d "
        f"{_mean_sd(_col(records, 'phi_hd'), 4)}.",
        "",
    ]


def _density_lines(records: Sequence[Mapping]) -> list[str]:
    """The density target's line of the report (empty for packs made without one)."""
    if not any("density_phi" in rec for rec in records):
        return []
    rec = records[0]
    where = (
        "between the floor and the lid"
        if rec["density_measure"] == "sample"
        else ("in the core window")
    )
    return [
        f"Density target {rec['density_target']} = {rec['density_target_value']:g}, phi "
        f"measured {where}: phi {_mean_sd(_col(records, 'density_phi'), 4)}; "
        f"{rec['density_method']} (deposition friction "
        f"{_mean_sd(_col(records, 'density_friction'), 3)}), "
        f"{_mean_sd(_col(records, 'density_generations'), 1)} pack(s) generated per pack.",
        "",
        *(
            [
                f"The model's e_min {_mean_sd(_col(records, 'density_e_min'), 4)} and e_max "
                f"{_mean_sd(_col(records, 'density_e_max'), 4)} (each pack's own seed and "
                f"stream); relative density Dr "
                f"{_mean_sd(_col(records, 'density_relative_density'), 3)}.",
                "",
            ]
            if "density_e_min" in rec
            else []
        ),
    ]


def _grading_lines(scene, records: Sequence[Mapping]) -> list[str]:
    """The realised grading by mass (mean ± sd over the packs) against the target of
    the scene's radius law (docs/grading.md); nothing for records without it."""
    if not records or "d50_mass" not in records[0]:
        return []
    from .grading import target_grading

    target = target_grading(scene).to_dict()
    keys = ("d10_mass", "d50_mass", "d90_mass", "cu_mass", "cc_mass")
    names = ("D10 (m)", "D50 (m)", "D90 (m)", "Cu", "Cc")
    return [
        "Grading by mass, realised (mean ± sd over the packs) and the radius law's target:",
        "",
        "| | " + " | ".join(names) + " |",
        "|---|" + "---|" * len(keys),
        "| realised | " + " | ".join(_mean_sd(_col(records, k), 4) for k in keys) + " |",
        "| target | " + " | ".join(f"{target[k]:.4f}" for k in keys) + " |",
        "",
    ]


def _fmt_ratio(value) -> str:
    """An unbalanced-force ratio, or a blank where the analysis had none."""
    if value is None or not math.isfinite(float(value)):
        return ""
    return f"{float(value):.1e}"


def _fmt(v) -> str:
    if v is None:
        return "n/a"
    try:
        return f"{float(v):.3f}"
    except (TypeError, ValueError):
        return str(v)
