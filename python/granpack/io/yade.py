"""YADE's text format (``#format x_y_z_r``): ``export.text`` / ``ymport.text``."""

from __future__ import annotations

import io
import math
import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._files import atomic_write
from .._validate import (
    FileFormatError,
    is_number,
)

if TYPE_CHECKING:
    from ..pack import Pack

from .._numbers import _number_table
from ._text import (
    _check_values,
    _choose_dim,
    _comment_tag,
    _integer_ids,
    _pad3,
    _read_text,
    _rows_text,
    _sorted_by_id,
    _tag,
    _tag_fields,
    _text_digits,
)
from .contact_model import (
    is_default_model,
    mean_contact,
    model_words,
    rolling_stiffness_at_mean,
    rolling_stiffness_words,
)
from .particle_file import ParticleFile

# YADE's text export: "#format x_y_z_r" (export.text), or another textExt layout
_YADE_HEADER = re.compile(r"^#\s*format\s+(\S+)\s*$")


#: The YADE layouts read, as their header names them; columns other than x y z r id are
#: skipped (matId, the material).
YADE_LAYOUTS = ("x_y_z_r", "x_y_z_r_matId", "id_x_y_z_r_matId")


def read_yade(path: Path, dim: int | None) -> ParticleFile:
    """YADE's text export: the ``#format`` header names the columns."""
    lines = _read_text(path).splitlines()
    k0 = next((k for k, ln in enumerate(lines) if ln.strip()), None)
    head = _YADE_HEADER.match(lines[k0].strip()) if k0 is not None else None
    if head is None or head.group(1) not in YADE_LAYOUTS:
        found = repr(lines[k0].strip()[:60]) if k0 is not None else "an empty file"
        raise FileFormatError(
            f"{path}:{(k0 or 0) + 1}: expected a YADE header '#format <layout>' with a layout "
            f"of {', '.join(YADE_LAYOUTS)}, found {found}",
            path=path,
        )
    assert k0 is not None  # a header was matched
    layout = head.group(1)
    names = layout.split("_")
    ncol = len(names)
    fast = _number_table(lines, k0 + 1, (ncol,), commas=False)
    if fast is not None:
        return _yade_particles(path, lines, k0, names, fast, dim)
    rows: list[list[float]] = []
    row_line: list[int] = []
    for k in range(k0 + 1, len(lines)):
        body = lines[k].split("#", 1)[0].split()
        if not body:
            continue
        if len(body) != ncol:
            raise FileFormatError(
                f"{path}:{k + 1}: expected {ncol} numbers ({' '.join(names)}, as the header "
                f"'#format {layout}' says), found {len(body)} fields",
                path=path,
            )
        bad = next((v for v in body if not is_number(v)), None)
        if bad is not None:
            raise FileFormatError(f"{path}:{k + 1}: {bad!r} is not a number", path=path)
        rows.append([float(v) for v in body])
        row_line.append(k + 1)
    if not rows:
        raise FileFormatError(f"{path}: no spheres after the header '#format {layout}'", path=path)
    return _yade_particles(path, lines, k0, names, np.array(rows, dtype=np.float64), dim, row_line)


def _yade_particles(
    path: Path,
    lines: list[str],
    k0: int,
    names: list[str],
    a: np.ndarray,
    dim: int | None,
    row_line: list[int] | None = None,
) -> ParticleFile:
    """The ParticleFile of YADE's rows `a` (columns `names`); `row_line` the line of each
    row, found from `lines` only where an error needs it."""
    found: list[list[int]] = [] if row_line is None else [row_line]

    def line_of(k: int) -> int:
        if not found:  # the rows' lines, counted only when a message needs one
            found.append(
                [j + 1 for j in range(k0 + 1, len(lines)) if lines[j].split("#", 1)[0].strip()]
            )
        return found[0][k]

    x3 = a[:, [names.index(c) for c in ("x", "y", "z")]]
    r = a[:, names.index("r")]
    ids = None
    order = np.arange(a.shape[0])
    if "id" in names:
        at = names.index("id")
        ids = _integer_ids(
            path,
            a[:, at],
            line_of,
            lambda: [lines[line_of(k) - 1].split("#", 1)[0].split()[at] for k in range(len(a))],
        )
        order = _sorted_by_id(path, ids, line_of)
        ids, x3, r = ids[order], x3[order], r[order]
    _check_values(path, x3, r, lambda k: line_of(int(order[k])))
    d = _choose_dim(path, x3, True, dim)
    tag = _comment_tag(path, lines, d)
    cols = [names.index(c) for c in ("x", "y", "z", "r")]
    digits = _text_digits(lines[k0 + 1 :], cols, comment="#")
    return ParticleFile(
        path=path,
        format="yade",
        positions=x3[:, :d],
        radii=r,
        ids=ids,
        digits=digits,
        **_tag_fields(tag, d),
    )


#: The prefix of the comment lines that hold YADE commands (`yade_contact_model`).
YADE_PREFIX = "yade: "


def yade_contact_model(pack: Pack) -> list[str]:
    """The comment lines (without ``#``) that give YADE granpack's contact model, none for
    the default Hertz-Mindlin without rolling resistance. Each ``yade: `` line is Python
    for a YADE script: the material to append before ``ymport.text`` (the spheres take
    the last one), and ``ig2``, ``ip2``, ``law2``, the functors of the InteractionLoop.

    - linear law: FrictMat, Ip2_FrictMat_FrictMat_FrictPhys with ``kn`` and ``ks`` given
      (MatchMaker ``val``), Law2_ScGeom_FrictPhys_CundallStrack;
    - linear law with rolling ``epsd``: CohFrictMat (``isCohesive=False``,
      ``momentRotationLaw=True``), whose k_n is 2 E R*: ``young`` = k_n / (2 R*), ``poisson``
      (YADE's k_s / k_n) = k_t / k_n, ``alphaKr`` = k_r / (4 k_t) (YADE's torque stiffness
      alphaKr k_s r_1 r_2) and ``etaRoll`` = mu_r / 2 (YADE's moment cap etaRoll min(r_1,
      r_2) F_n), all exact for two spheres of the mean contact's R* (radius 2 R*);
      Law2_ScGeom6D_CohFrictPhys_CohesionMoment with the incremental form;
    - Hertz-Mindlin with rolling ``epsd``: Ip2_FrictMat_FrictMat_MindlinPhys with the
      damping ratios ``betan`` = ``betas`` = xi, the torque stiffness ``krot`` = k_r R*^2
      and ``eta`` = mu_r / 2 (YADE's cap eta (r_1 + r_2) / 2 F_n), at the mean contact;
      Law2_ScGeom_MindlinPhys_Mindlin with ``includeMoment=True``.

    What differs is on the lines and in docs/export.md (YADE).
    """
    m = pack.scene.material
    if is_default_model(m):
        return []
    lines = [f"contact model: {model_words(m)}"]
    friction = f"frictionAngle={math.atan(m.friction)!r}"  # atan(mu)
    r_star = mean_contact(pack).r_star
    y = YADE_PREFIX
    if m.contact_law == "linear":
        k_n = m.normal_stiffness
        k_t = m.tangential_stiffness_or_default
        assert k_n is not None and k_t is not None
        if m.rolling == "none":
            return lines + [
                f"{y}O.materials.append(FrictMat(density={m.density!r}, young={m.young!r}, "
                f"poisson={m.poisson!r}, {friction}))",
                f"{y}ig2 = Ig2_Sphere_Sphere_ScGeom()",
                f"{y}ip2 = Ip2_FrictMat_FrictMat_FrictPhys(kn=MatchMaker(algo='val', "
                f"val={k_n!r}), ks=MatchMaker(algo='val', val={k_t!r}))",
                f"{y}law2 = Law2_ScGeom_FrictPhys_CundallStrack()",
                "YADE's Cundall-Strack law has no dashpot: granpack's damping ratio "
                f"{m.damping!r} is not in it",
            ]
        k_r = rolling_stiffness_at_mean(pack)
        assert m.rolling_friction is not None
        return lines + [
            f"{y}O.materials.append(CohFrictMat(density={m.density!r}, "
            f"young={k_n / (2.0 * r_star)!r}, poisson={k_t / k_n!r}, {friction}, "
            f"isCohesive=False, momentRotationLaw=True, alphaKr={k_r / (4.0 * k_t)!r}, "
            f"etaRoll={m.rolling_friction / 2.0!r}))",
            f"{y}ig2 = Ig2_Sphere_Sphere_ScGeom6D()",
            f"{y}ip2 = Ip2_CohFrictMat_CohFrictMat_CohFrictPhys()",
            f"{y}law2 = Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=True, "
            "always_use_moment_law=True)",
            f"YADE's k_n = 2 E R*, k_r and moment cap are granpack's for two spheres of R* = "
            f"{r_star!r} m (the mean contact); no dashpots (damping ratio {m.damping!r}, "
            f"gamma_r {m.rolling_damping or 0.0!r})",
        ]
    k_r = rolling_stiffness_at_mean(pack)
    assert m.rolling_friction is not None
    return lines + [
        f"{y}O.materials.append(FrictMat(density={m.density!r}, young={m.young!r}, "
        f"poisson={m.poisson!r}, {friction}))",
        f"{y}ig2 = Ig2_Sphere_Sphere_ScGeom()",
        f"{y}ip2 = Ip2_FrictMat_FrictMat_MindlinPhys(betan={m.damping!r}, "
        f"betas={m.damping!r}, krot={k_r * r_star**2!r}, eta={m.rolling_friction / 2.0!r})",
        f"{y}law2 = Law2_ScGeom_MindlinPhys_Mindlin(includeMoment=True)",
        f"krot = k_r R*^2 with k_r = {k_r!r} N/m ({rolling_stiffness_words(pack)}) and R* = "
        f"{r_star!r} m, the mean contact's; eta gives the cap mu_r R* F_n for equal "
        f"radii; no rolling dashpot (gamma_r {m.rolling_damping or 0.0!r})",
    ]


def write_yade(pack: Pack, path: str | Path) -> Path:
    """Writes YADE's text format (``#format x_y_z_r``, then ``x y z r`` a line at full
    precision), which ``yade.ymport.text`` reads. Returns the path. A material other than
    the default adds comment lines with the YADE material and functors of its contact
    model (`yade_contact_model`)."""
    x = _pad3(pack.positions)
    r = np.asarray(pack.radii, dtype=np.float64)
    out = io.StringIO()
    out.write("#format x_y_z_r\n")
    # ymport.text skips comment lines; read_particles takes the container from this one
    out.write(f"# granpack: dim={pack.dim} {_tag(pack)}\n")
    out.write("".join(f"# {ln}\n" for ln in yade_contact_model(pack)))
    out.write(_rows_text(x[:, 0], x[:, 1], x[:, 2], r))
    return atomic_write(Path(path), out.getvalue().encode())
