"""``report.md``: one page that says what was run and links the tables and figures.

`ensemble_report` is written by ``granpack generate``; the paper's report, written by
``granpack paper``, is `granpack.paper.report.paper_report`. Links are relative to the
report, so the output folder can be moved or published as it is.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path

from ._contact_model import model_text
from ._files import atomic_write
from ._report_page import column, dev_banner, environment_line, grouped_links, mean_sd, rel_link

__all__ = ["ensemble_report"]


def __getattr__(name: str):
    # paper_report's former home, until the next release; it warns on first use only, as
    # the name is then bound here
    if name == "paper_report":
        warnings.warn(
            "granpack.report.paper_report is now granpack.paper.report.paper_report; "
            "granpack.report.paper_report is removed in the next release",
            DeprecationWarning,
            stacklevel=2,
        )
        from .paper.report import paper_report

        globals()[name] = paper_report
        return paper_report
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
        *dev_banner(dev_changes or {}),
        f"Scene: [scene.toml](scene.toml) (dim {scene.dim}, base {list(scene.base)} m, "
        f"H_d = {scene.height} m, {scene.radius_law} radii r_mean = {scene.r_mean} m), "
        f"master seed {scene.seed} (pack k uses random stream k). "
        f"{environment_line(wall_time)}.",
        "",
        model_text(scene.material),
        "",
        *_engine_lines(records),
        f"phi = {mean_sd(column(records, 'phi'), 4)}, Z = {mean_sd(column(records, 'z'), 3)} "
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
    groups = grouped_links(table_files, out)
    for stem in sorted(groups):
        links = " · ".join(f"[{suffix}]({link})" for suffix, link in groups[stem])
        lines.append(f"- {stem}: {links}")
    if figures:
        lines += ["", "## Figures", ""]
        lines.append(" · ".join(f"[{Path(f).stem}]({rel_link(f, out)})" for f in figures))
    lines += [
        "",
        "Each pack's microstructure is in `micro/pack_k.json`; "
        "`granpack export PACK --format vtk|lammps-data|csv|parquet` converts a pack.",
        "",
    ]
    return atomic_write(out / "report.md", "\n".join(lines).encode())


def _engine_lines(records: Sequence[Mapping]) -> list[str]:
    """The engine that ran the layer loops' DEM, where it was not granpack's own."""
    engines = sorted(
        {(r["engine"], r["engine_version"], r["engine_ranks"]) for r in records if "engine" in r}
    )
    if not engines:
        return []
    runs = ", ".join(
        f"{name.upper()} {version} on {ranks} MPI rank(s)" for name, version, ranks in engines
    )
    return [
        f"Engine: the layers were jammed by {runs} (docs/mpi.md: the same statistics as "
        "granpack's engine, not the same bits).",
        "",
    ]


def _trim_lines(records: Sequence[Mapping], scene) -> list[str]:
    """The flat top's line of the report (empty for packs made without it)."""
    if not any("phi_hd" in rec for rec in records):
        return []
    return [
        f"Flat top (trim): every particle above H_d = {scene.height} m removed, then a relax; "
        f"removed per pack {mean_sd(column(records, 'trim_removed'), 1)}, final top "
        f"{mean_sd(column(records, 'trim_top'), 4)} m, phi to H_d "
        f"{mean_sd(column(records, 'phi_hd'), 4)}.",
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
        f"measured {where}: phi {mean_sd(column(records, 'density_phi'), 4)}; "
        f"{rec['density_method']} (deposition friction "
        f"{mean_sd(column(records, 'density_friction'), 3)}"
        + (
            f", rolling friction {mean_sd(column(records, 'density_rolling_friction'), 3)}"
            if "density_rolling_friction" in rec
            else ""
        )
        + "), "
        f"{mean_sd(column(records, 'density_generations'), 1)} pack(s) generated per pack.",
        "",
        *(
            [
                f"The model's e_min {mean_sd(column(records, 'density_e_min'), 4)} and e_max "
                f"{mean_sd(column(records, 'density_e_max'), 4)} (each pack's own seed and "
                f"stream); relative density Dr "
                f"{mean_sd(column(records, 'density_relative_density'), 3)}.",
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
        "| realised | " + " | ".join(mean_sd(column(records, k), 4) for k in keys) + " |",
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
