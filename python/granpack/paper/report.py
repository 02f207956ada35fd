"""The paper's ``report.md``: what was run, the summary of ours beside the paper, the 2D
mass conventions, and links to the tables and figures. Links are relative to the report,
so the output folder can be moved or published as it is."""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from .._files import atomic_write
from .._report_page import (
    column,
    dev_banner,
    duration,
    environment_line,
    grouped_links,
    mean_sd,
    rel_link,
)

__all__ = ["paper_report"]

_TABLE_TOPICS = {
    # table number -> (example, what)
    2: ("4.1", "packing densities phi, rotations ON and OFF"),
    3: ("4.1", "void ratio e and empirical Z(e), rotations ON"),
    4: ("4.1", "void ratio e and empirical Z(e), rotations OFF"),
    5: ("4.2", "packing densities phi, rotations ON and OFF"),
    6: ("4.2", "void ratio e and empirical Z(e), rotations ON"),
    7: ("4.2", "void ratio e and empirical Z(e), rotations OFF"),
    8: ("4.3", "packing densities phi, rotations ON and OFF"),
    9: ("4.3", "void ratio e and empirical Z(e), rotations ON"),
    10: ("4.3", "void ratio e and empirical Z(e), rotations OFF"),
    11: ("4.4", "packing densities phi, rotations ON and OFF"),
    12: ("4.4", "void ratio e and empirical Z(e), rotations ON"),
    13: ("4.4", "void ratio e and empirical Z(e), rotations OFF"),
}


def _default_2d_convention() -> str:
    from ..scene import PackScene

    return PackScene.preset("4.1").inertia_2d


def _table_sort_key(stem: str):
    m = re.fullmatch(r"table(\d+)", stem)
    return (0, int(m.group(1)), "") if m else (1, 0, stem)


def paper_report(
    out_dir: str | Path,
    *,
    examples: Sequence[str],
    n_packs: int,
    quick: bool,
    records: Mapping[tuple[str, bool], Sequence[Mapping]],
    paper_phi: Mapping[tuple[str, bool], Sequence[float]],
    table_files: Sequence[Path],
    figures: Mapping,
    wall_time: float,
    pack_time: float,
    dev_changes: Mapping | None = None,
    seed: int = 0,
    mass_2d=None,
) -> Path:
    """Writes ``out_dir/report.md`` for ``granpack paper`` and returns its path.

    Parameters
    ----------
    examples : the examples run ("4.1" ...).
    n_packs : packs per case.
    quick : True for ``--quick`` (the report says that fewer packs were run).
    records : per case (example, rotations), one dict per pack with at least ``phi``,
        ``n_particles`` and, when known, ``z``, ``z_mech``, ``wall_time``.
    paper_phi : the paper's per-pack phi per case (may be empty).
    table_files : files written by ``tables.write_tables`` (CSV and Markdown).
    figures : {(example, rotations): {"packs"|"normals"|"forces"|"view": path},
        (example, "phi"): path}.
    wall_time, pack_time : seconds for everything and for the packs.
    dev_changes : development options in force, {what: value text} (flagged loudly).
    mass_2d : the 2D cases' phi under both mass conventions
        (`granpack.paper.mass2d.convention_table`), or None.
    """
    out = Path(out_dir)
    lines = ["# granpack: the paper's section 4, reproduced", ""]
    cmd = f"granpack paper --out {out}" + (" --quick" if quick else "")
    if not quick and n_packs != 10:
        cmd += f" --packs {n_packs}"
    if quick:
        lines += [
            f"> **Quick run:** {n_packs} packs per case instead of the paper's 10. The "
            "scenes and physics constants are the paper's (dt = 1e-4 s, 1.0 s of jamming "
            "per layer, E = 1e8 Pa, nu = 0.25, xi = 0.1, mu = 0.2, g = 2 m/s², "
            "c_D = 0.005 N s/m); means are indicative and standard deviations from "
            f"{n_packs} packs are rough. `granpack paper --out {out}` runs the full "
            "reproduction and reuses the packs made here.",
            "",
        ]
    lines += dev_banner(dev_changes or {})
    lines += [
        f"`{cmd}`: examples {', '.join(examples)}, rotations ON and OFF, {n_packs} "
        f"pack(s) each, master seed {seed} (pack k uses random stream k). "
        f"{environment_line(wall_time)}; packs {duration(pack_time)}.",
        "",
        "## Summary: ours beside the paper",
        "",
        "| example | rotations | packs | N (mean) | phi, ours | phi, paper | Z = 2N_c/N_p "
        "| Z_m (no rattlers) | figures |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for ex in examples:
        for rot in (True, False):
            recs = records.get((ex, rot), [])
            figs = figures.get((ex, rot), {})
            links = " · ".join(f"[{name}]({rel_link(p, out)})" for name, p in figs.items())
            n_mean = np.mean(column(recs, "n_particles")) if recs else float("nan")
            paper = paper_phi.get((ex, rot))
            lines.append(
                f"| {ex} | {'ON' if rot else 'OFF'} | {len(recs)} | {n_mean:.0f} "
                f"| {mean_sd(column(recs, 'phi'))} | {mean_sd(paper) if paper else 'n/a'} "
                f"| {mean_sd(column(recs, 'z'), 2)} | {mean_sd(column(recs, 'z_mech'), 2)} "
                f"| {links} |"
            )
    lines += [
        "",
        "Mean ± sample standard deviation (ddof = 1, as the paper's tables) over the packs. "
        "phi = solid volume / (base × H_top), H_top = max(z + r). The paper gives no "
        "contact counts, only the empirical Z(e) of its eqs. 16-19 (in tables 3-13).",
        "",
    ]
    if mass_2d is not None and mass_2d.height:
        from .mass2d import report_lines

        csv = out / "tables" / "mass_2d.csv"
        lines += report_lines(mass_2d, _default_2d_convention(), rel_link(csv, out))
    lines += [
        "## Tables",
        "",
    ]
    groups = grouped_links(table_files, out)
    for stem in sorted(groups, key=_table_sort_key):
        m = re.fullmatch(r"table(\d+)", stem)
        if m and int(m.group(1)) in _TABLE_TOPICS:
            ex, what = _TABLE_TOPICS[int(m.group(1))]
            title = f"Table {m.group(1)} (example {ex}): {what}"
        else:
            title = stem.replace("_", " ")
        links = " · ".join(f"[{suffix}]({link})" for suffix, link in groups[stem])
        lines.append(f"- {title}: {links}")
    phi_figs = [(ex, figures[ex, "phi"]) for ex in examples if (ex, "phi") in figures]
    if phi_figs:
        lines += [
            "",
            "## Packing fraction over the ensembles",
            "",
            " · ".join(f"[example {ex}]({rel_link(p, out)})" for ex, p in phi_figs),
        ]
    lines += [
        "",
        "## Files",
        "",
        "- `packs/<example>-<on|off>/pack_k.npz`: every pack (`granpack.load_pack`; "
        "`granpack export PACK --format vtk|lammps-data|csv|parquet` for ParaView, "
        "LAMMPS/LIGGGHTS `read_data`, tables).",
        "- `micro/<example>-<on|off>/pack_k.json`: each pack's microstructure.",
        "- `tables/`, `figures/`: what is linked above. Figures are named after the "
        "paper's (fig2 = example 4.1, rotations ON, ... fig9 = 4.4, OFF).",
        "",
    ]
    return atomic_write(out / "report.md", "\n".join(lines).encode())
