"""Chrono DEM-Engine: the clump CSV its solver writes and reads back, and a table of the
sphere templates the clumps name.

The layout is taken from DEM-Engine's source (``src/DEM/Structs.h``: the column names
``X Y Z``, ``Qw Qx Qy Qz``, ``clump_type``, ``v_x v_y v_z``, ``w_x w_y w_z``;
``src/DEM/dT.cpp``: ``DEMDynamicThread::writeClumpsAsCsv``, the order of the columns;
``src/DEM/API.h``: ``DEMSolver::ReadClumpXyzFromCsv``, ``ReadClumpQuatFromCsv``,
``ReadClumpVelFromCsv``, ``ReadClumpAngVelFromCsv``, which find the columns by name and
group the rows by ``clump_type``; ``src/DEM/APIPublic.cpp``: ``LoadClumpType`` names a
template ``"%04d"`` of its load order, ``LoadSphereType`` gives a sphere I = 2/5 m r^2),
as of DEM-Engine's main of March 2026 (commit a1dc231)::

    X,Y,Z,Qw,Qx,Qy,Qz,clump_type,v_x,v_y,v_z,w_x,w_y,w_z
    x,y,z,1.0,0.0,0.0,0.0,0003,vx,vy,vz,wx,wy,wz

DEM-Engine's CSV reader skips only empty lines, so the file has no comment. A clump type
names a sphere template: DEM-Engine cannot give each sphere its own radius, so the pack's
radii are binned into at most `MAX_TEMPLATES` (64) templates, named ``0000``, ``0001``, ...
in order of radius: the names DEM-Engine gives templates loaded in that order
(``LoadSphereType(mass, radius, material)`` for each row of the table, before any other
template). The binning gives the fewest templates whose largest relative radius error
|r_template - r| / r is smallest: each template covers radii [a, b] and has the radius
2ab / (a + b), which makes the error at both ends equal, (b - a) / (a + b). A pack with
at most 64 distinct radii (one radius, a discrete mixture) keeps them exactly (error 0);
otherwise the error is at most (q - 1) / (q + 1) with q = (r_max / r_min)^(1/64): 0.54 %
for r_max / r_min = 2, 1.3 % for 5. The table's header gives the largest error of the
pack.

Beside the CSV, ``<stem>.templates.csv``: comment lines (``#``) with granpack's container
tag (the box or periodic cell, or the cylinder; DEM-Engine's CSV has no place for it) and
the binning's largest error, then ``name,radius,mass,moi,count,r_min,r_max``: each
template's radius, mass and moment of inertia (the material's density; 3D and 2D
spheres: m = 4/3 pi r^3 rho, I = 2/5 m r^2; 2D discs, ``inertia_2d="disc"``: m = pi r^2
rho per metre, I = m r^2 / 2), the number of particles and the range of their radii.
Read it with ``pandas.read_csv(path, comment="#", dtype={"name": str})``. A material with
the linear law or rolling resistance adds a comment line with its model keys
(``# contact model: contact_law=linear normal_stiffness=...``).

2D packs lie in the plane z = 0 (DEM-Engine is 3D). A periodic pack's centres are
wrapped into [0, L). Numbers are written at full precision (``repr``); DEM-Engine reads
them as single-precision floats (its CSV parser, ``src/core/utils/csv.hpp``, sums the
digits in single precision: within a few units in the last place).
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._files import atomic_write
from .._validate import InvalidParameterError
from ..analysis.container import Container
from ._text import _format_lines, _state3
from .contact_model import is_default_model, model_words

if TYPE_CHECKING:
    from ..pack import Pack

__all__ = [
    "write_demengine",
    "sphere_templates",
    "templates_path",
    "error_bound",
    "MAX_TEMPLATES",
    "COLUMNS",
    "TEMPLATE_COLUMNS",
]

#: The most sphere templates a pack is binned into.
MAX_TEMPLATES = 64
#: The clump CSV's columns, in the order DEM-Engine's ``writeClumpsAsCsv`` writes them.
COLUMNS = (
    "X",
    "Y",
    "Z",
    "Qw",
    "Qx",
    "Qy",
    "Qz",
    "clump_type",
    "v_x",
    "v_y",
    "v_z",
    "w_x",
    "w_y",
    "w_z",
)
#: The columns of the templates table.
TEMPLATE_COLUMNS = ("name", "radius", "mass", "moi", "count", "r_min", "r_max")


def templates_path(path: str | Path) -> Path:
    """``<stem>.templates.csv`` beside the clump CSV `path`."""
    path = Path(path)
    stem = path.name[: -len(path.suffix)] if path.suffix else path.name
    return path.with_name(f"{stem}.templates.csv")


def error_bound(r_min: float, r_max: float, max_templates: int = MAX_TEMPLATES) -> float:
    """The largest relative radius error the binning can give for radii in
    [r_min, r_max]: (q - 1) / (q + 1), q = (r_max / r_min)^(1 / max_templates)."""
    q = (r_max / r_min) ** (1.0 / max_templates)
    return (q - 1.0) / (q + 1.0)


def _cover(u: np.ndarray, tol: float) -> list[int]:
    """The first index (into the sorted distinct radii u) of each bin of the greedy cover
    whose bins [a, b] keep (b - a) / (a + b) <= tol: the fewest bins for tol."""
    starts = []
    i = 0
    grow = (1.0 + tol) / (1.0 - tol)
    while i < len(u):
        starts.append(i)
        j = int(np.searchsorted(u, u[i] * grow, side="right"))
        # the bound itself, rounded, must never leave a bin empty
        i = max(j, i + 1)
    return starts


def sphere_templates(
    radii, max_templates: int = MAX_TEMPLATES
) -> tuple[np.ndarray, np.ndarray, float]:
    """Bins radii into at most `max_templates` sphere templates (the binning of the module
    docstring).

    Returns
    -------
    (template radii (T,) increasing, the template of each radius (N,) int64, the largest
    relative error |r_template - r| / r)
    """
    if isinstance(max_templates, bool) or not isinstance(max_templates, int) or max_templates < 1:
        raise InvalidParameterError(
            f"invalid max_templates = {max_templates!r}: must be an integer >= 1",
            parameter="max_templates",
            value=max_templates,
        )
    r = np.asarray(radii, dtype=np.float64)
    u = np.unique(r)
    if len(u) <= max_templates:
        return u, np.searchsorted(u, r).astype(np.int64), 0.0
    lo, hi = 0.0, float((u[-1] - u[0]) / (u[-1] + u[0]))  # hi: one bin
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if len(_cover(u, mid)) <= max_templates:
            hi = mid
        else:
            lo = mid
        if hi - lo <= 1e-15 * max(hi, 1e-300):
            break
    starts = _cover(u, hi)
    ends = [*starts[1:], len(u)]
    a = u[starts]
    b = u[np.array(ends) - 1]
    templates = 2.0 * a * b / (a + b)
    edges = np.append(a, np.inf)
    index = (np.searchsorted(edges, r, side="right") - 1).astype(np.int64)
    err = float(np.max(np.abs(templates[index] - r) / r))
    return templates, index, err


def write_demengine(
    pack: Pack, path: str | Path, *, max_templates: int = MAX_TEMPLATES
) -> list[Path]:
    """Writes the pack as DEM-Engine's clump CSV (`path`) and the table of its sphere
    templates (``<stem>.templates.csv``), layout and binning in the module docstring.
    Returns both paths.

    In DEM-Engine (C++)::

        // for each row of the templates table, in order:
        templates.push_back(DEMSim.LoadSphereType(mass, radius, material));   // "0000", ...
        auto xyz = DEMSim.ReadClumpXyzFromCsv("pack.csv");
        auto vel = DEMSim.ReadClumpVelFromCsv("pack.csv");
        for (unsigned i = 0; i < templates.size(); i++) {
            char name[8]; sprintf(name, "%04d", i);
            auto batch = DEMSim.AddClumps(templates[i], xyz[name]);
            batch->SetVel(vel[name]);
        }
    """

    path = Path(path)
    s = pack.scene
    d = s.dim
    n = len(pack)
    x, r, v, w = _state3(pack)
    templates, index, err = sphere_templates(r, max_templates)
    names = [f"{k:04d}" for k in range(len(templates))]
    rho = float(s.material.density)
    if d == 2 and s.inertia_2d == "disc":
        mass = rho * math.pi * templates**2
        moi = 0.5 * mass * templates**2
        convention = "disc: m = pi r^2 rho per metre, I = m r^2 / 2"
    else:
        mass = rho * 4.0 / 3.0 * math.pi * templates**3
        moi = 0.4 * mass * templates**2
        convention = "sphere: m = 4/3 pi r^3 rho, I = 2/5 m r^2"

    out = io.StringIO()
    out.write(",".join(COLUMNS) + "\n")
    out.write(
        _format_lines(
            "{},{},{},1.0,0.0,0.0,0.0,{},{},{},{},{},{},{}",
            *x.T,
            np.array(names, dtype=object)[index] if n else np.array([], dtype=str),
            *v.T,
            *w.T,
        )
    )

    lo, hi = pack.box
    container = Container.of_pack(pack)
    tab = io.StringIO()
    tab.write(
        f"# DEM-Engine sphere templates from granpack: dim={d} N={n} seed={s.seed} "
        f"stream={s.stream} (SI units, vertical {'z' if d == 3 else 'y'}"
        f"{', 2D in the plane z = 0' if d == 2 else ''}), for {path.name}\n"
    )
    tab.write(f"# granpack: dim={d} {container.tag_words()}\n")
    bound = error_bound(float(r.min()), float(r.max()), max_templates) if n else 0.0
    tab.write(
        f"# templates={len(templates)} (at most {max_templates}) "
        f"max_relative_radius_error={err!r} (bound {bound!r})\n"
    )
    tab.write(f"# density={rho!r} ({convention})\n")
    if not is_default_model(s.material):
        # DEM-Engine's material (LoadMaterial) has no place for it: the record, for the
        # force model the user writes (docs/export.md, DEM-Engine)
        tab.write(f"# contact model: {model_words(s.material)}\n")
    tab.write(",".join(TEMPLATE_COLUMNS) + "\n")
    for k, name in enumerate(names):
        members = r[index == k]
        tab.write(
            f"{name},{float(templates[k])!r},{float(mass[k])!r},{float(moi[k])!r},"
            f"{len(members)},{float(members.min())!r},{float(members.max())!r}\n"
        )
    tpath = templates_path(path)
    return [
        atomic_write(path, out.getvalue().encode()),
        atomic_write(tpath, tab.getvalue().encode()),
    ]
