"""Itasca PFC 7: a data file of commands (``program call 'pack.p3dat'``) that creates the
pack's balls.

The commands and their syntax are taken from Itasca's PFC 7.0 documentation: ``model
domain`` (``extent``, ``condition``), ``ball create`` (keywords ``id``, ``radius``,
``position``), ``ball attribute`` (``density``, ``velocity``, ``spin``, with a ``range``
phrase, element ``id``), and "Command Shaping" (``;`` starts a comment; a vector is
``(x,y,z)``, 2D ``(x,y)``). ``ball create`` takes no velocity, so each ball's density,
velocity and spin follow in a ``ball attribute ... range id i`` line::

    ; granpack: dim=3 container=periodic lo=0.0,0.0,0.0 hi=0.2,0.2,0.13
    model new
    model domain extent xmin xmax ymin ymax zmin zmax condition periodic periodic stop
    ball create id 1 radius r position (x,y,z)
    ...
    ball attribute density rho velocity (vx,vy,vz) spin (wx,wy,wz) range id 1
    ...

In 2D (PFC2D) the extent has four numbers and the conditions two, positions and
velocities are ``(x,y)`` and the spin is a number (about z). PFC2D's balls are discs of
unit thickness (m = rho pi r^2), as granpack's default 2D mass (``inertia_2d="disc"``):
their density is the material's. For sphere mass (``inertia_2d="sphere"``,
m = 4/3 pi r^3 rho) each ball gets the density 4/3 r rho, which gives the same mass (the
moment of inertia is then PFC2D's disc's, m r^2 / 2, not the sphere's 2/5 m r^2).

The domain: a periodic axis is the cell [0, L] exactly (``condition periodic``; centres
are wrapped into [0, L)); every other axis is the pack's box widened by 10 % of its
length on each side (``condition stop``), since PFC needs every ball and wall inside the
domain. The box itself (the walls granpack had: floor and sides, or the cylinder) is on
the container tag comment line; create the walls there (``wall generate ...``) before
cycling. The material is named on a comment line. The file sets the contact model only
where granpack's is not the default Hertz-Mindlin: the linear law as ``contact cmat
default model linear property kn ks fric dp_nratio dp_sratio``, with rolling resistance
``rrlinear`` and ``rr_fric`` (`pfc_contact_model`); for Hertz-Mindlin choose it
(``contact cmat default ...``) before cycling. Every number is written at full precision
(``repr``).
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._files import atomic_write
from ..analysis.container import Container
from ._text import _format_lines
from .contact_model import is_default_model, model_words, rolling_stiffness_at_mean

if TYPE_CHECKING:
    from ..pack import Pack

__all__ = ["write_pfc", "DOMAIN_MARGIN", "pfc_density", "pfc_contact_model"]

#: How far the domain reaches past the box on an axis that is not periodic, as a fraction
#: of the box's length on that axis (each side).
DOMAIN_MARGIN = 0.1


def pfc_density(pack: Pack) -> np.ndarray:
    """(N,) the ball densities (kg/m^3) that give PFC granpack's masses: the material's
    density in 3D and for 2D discs, 4/3 r rho for granpack's 2D sphere mass (PFC2D's balls
    are discs of unit thickness)."""
    s = pack.scene
    r = np.asarray(pack.radii, dtype=np.float64)
    rho = float(s.material.density)
    if s.dim == 2 and s.inertia_2d == "sphere":
        return 4.0 / 3.0 * r * rho
    return np.full(r.shape, rho)


def pfc_contact_model(pack: Pack) -> list[str]:
    """The lines that set the default contact model to granpack's (none for the default
    Hertz-Mindlin without rolling resistance): the linear law as ``linear`` (``kn``,
    ``ks``, ``fric``, critical damping ratios ``dp_nratio`` = ``dp_sratio`` = xi: PFC's
    dashpots are 2 beta sqrt(m_c k), granpack's), with rolling resistance as ``rrlinear``
    (``rr_fric`` = mu_r; PFC computes the rolling stiffness itself, read-only ``rr_kr``,
    and has no rolling dashpot). PFC has no Hertz model with rolling resistance: a Hertz
    pack with it gets a comment and no command."""
    m = pack.scene.material
    if is_default_model(m):
        return []
    lines = [f"; contact model: {model_words(m)}"]
    if m.contact_law != "linear":
        return lines + [
            "; PFC's hertz model has no rolling resistance and rrlinear is a linear law: no",
            "; contact model is set here (docs/export.md, PFC)",
        ]
    k_n = m.normal_stiffness
    k_t = m.tangential_stiffness_or_default
    assert k_n is not None and k_t is not None
    props = (
        f"kn {k_n!r} ks {k_t!r} fric {m.friction!r} dp_nratio {m.damping!r} dp_sratio {m.damping!r}"
    )
    if m.rolling == "none":
        return lines + [f"contact cmat default model linear property {props}"]
    return lines + [
        "; rrlinear: PFC sets the rolling stiffness itself (rr_kr, read-only) and has no",
        f"; rolling dashpot; granpack's k_r is {rolling_stiffness_at_mean(pack)!r} N/m, "
        f"gamma_r {m.rolling_damping or 0.0!r} N s/m",
        f"contact cmat default model rrlinear property {props} rr_fric {m.rolling_friction!r}",
    ]


def write_pfc(pack: Pack, path: str | Path) -> Path:
    """Writes a PFC 7 data file of commands that creates the pack's balls with their
    radii, velocities, spins and densities in its domain (layout in the module docstring;
    PFC3D for a 3D pack, PFC2D for a 2D one). Returns the path."""
    from ._text import lammps_positions

    s = pack.scene
    d = s.dim
    n = len(pack)
    x = lammps_positions(pack)[:, :d]
    r = np.asarray(pack.radii, dtype=np.float64)
    v = np.asarray(pack.velocities, dtype=np.float64)
    spins = np.asarray(pack.spins, dtype=np.float64)
    rho = pfc_density(pack)
    lo, hi = pack.box
    container = Container.of_pack(pack)
    kind = container.kind
    periodic = [kind == "periodic" and a < d - 1 for a in range(d)]
    m = s.material
    out = io.StringIO()
    program = "PFC3D" if d == 3 else "PFC2D"
    out.write(
        f"; {program} 7 commands from granpack: dim={d} N={n} seed={s.seed} stream={s.stream} "
        f"(SI units, vertical {'z' if d == 3 else 'y'})\n"
    )
    out.write(f"; granpack: dim={d} {container.tag_words()}\n")
    out.write(
        f"; material: density={m.density!r} young={m.young!r} poisson={m.poisson!r} "
        f"friction={m.friction!r} damping_ratio={m.damping!r}"
        + (f" mass={s.inertia_2d}" if d == 2 else "")
        + (
            "; walls and the contact model are not set here\n"
            if is_default_model(m)
            else "; walls are not set here, the contact model is (below)\n"
        )
    )
    out.write("model new\n")
    extent = []
    for a in range(d):
        if periodic[a]:
            extent += [lo[a], hi[a]]
        else:
            pad = DOMAIN_MARGIN * (hi[a] - lo[a])
            extent += [lo[a] - pad, hi[a] + pad]
    conditions = " ".join("periodic" if p else "stop" for p in periodic)
    out.write(
        "model domain extent "
        + " ".join(repr(float(e)) for e in extent)
        + f" condition {conditions}\n"
    )
    out.write("".join(f"{ln}\n" for ln in pfc_contact_model(pack)))
    ids = np.arange(1, n + 1)
    vec = "(" + ",".join(["{}"] * d) + ")"
    out.write(_format_lines(f"ball create id {{}} radius {{}} position {vec}", ids, r, *x.T))
    spin_cols = list(spins.T) if d == 3 else [spins]
    spin = vec if d == 3 else "{}"
    out.write(
        _format_lines(
            f"ball attribute density {{}} velocity {vec} spin {spin} range id {{}}",
            rho,
            *v.T,
            *spin_cols,
            ids,
        )
    )
    return atomic_write(Path(path), out.getvalue().encode())
