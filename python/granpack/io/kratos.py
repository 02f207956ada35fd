"""Kratos Multiphysics DEM: the model part file (``.mdpa``) of the spheres.

The layout is the one Kratos' ``ModelPartIO`` reads (``kratos/sources/model_part_io.cpp``)
and that the DEM application's own tools write (``DEMApplication/
mesh_to_mdpa_converter.py``, the GiD interface's ``DEM::write::WriteMDPAParts``) and DEMGen
writes: blocks ``Begin <kind> ... End <kind>``, comments after ``//``::

    // granpack: dim=3 container=box lo=0.0,0.0,0.0 hi=0.2,0.2,0.1
    Begin ModelPartData
    End ModelPartData
    Begin Properties 1
    End Properties
    Begin Nodes
    1 x y z                      (id, centre; 2D: z = 0)
    End Nodes
    Begin Elements SphericParticle3D      (2D: CylinderParticle2D)
    1 1 1                        (element id, property id, node id)
    End Elements
    Begin NodalData RADIUS
    1 0 r                        (node id, fixed flag, value)
    End NodalData
    Begin NodalData VELOCITY_X   (and _Y, _Z; ANGULAR_VELOCITY_X/_Y/_Z, 2D: _Z only)
    ...
    Begin SubModelPart DEMParts_Body
      Begin SubModelPartNodes ... Begin SubModelPartElements ...
    End SubModelPart

Node and element ids are 1..N in the pack's order. The material goes in Kratos'
``MaterialsDEM.json`` (assigned to the sub model part ``DEMParts_Body``), not the file: the
``Properties 1`` block is empty, and a comment line gives granpack's density, Young's
modulus, Poisson's ratio and friction. A material with the linear law or rolling
resistance adds two comment lines: its model keys, and the material relation's
``Variables`` for MaterialsDEM.json as JSON (`kratos_material_relation`). Numbers are
written at full precision (``repr``).

The container is a comment line, granpack's container tag (`granpack.analysis.container`): the
box or periodic cell (``lo``, ``hi``; the cell's horizontal axes are periodic) or the
cylinder and its radius. A periodic pack's centres are wrapped into [0, L).

`read_kratos` reads these files back, and the sphere model parts DEMGen and Kratos' tools
write: the particles are the nodes of the one-node elements (``SphericParticle3D``,
``SphericContinuumParticle3D``, ``CylinderParticle2D``, ...), their radii the ``NodalData
RADIUS`` block; other blocks are checked for their structure and skipped.
"""

from __future__ import annotations

import io
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._files import atomic_write
from .._validate import FileFormatError, InvalidParameterError
from ..analysis.container import Container
from ._text import _format_lines, _read_text, _state3
from .contact_model import is_default_model, linear_restitution, model_words

if TYPE_CHECKING:
    from ..pack import Pack
    from .particle_file import ParticleFile

__all__ = [
    "write_kratos",
    "read_kratos",
    "kratos_material_relation",
    "ELEMENT_3D",
    "ELEMENT_2D",
    "SUB_MODEL_PART",
]

#: The sphere element of a 3D pack, and the disc element of a 2D one.
ELEMENT_3D = "SphericParticle3D"
ELEMENT_2D = "CylinderParticle2D"
#: The sub model part that holds every sphere (MaterialsDEM.json assigns the material to it).
SUB_MODEL_PART = "DEMParts_Body"


def _rows(ids: np.ndarray, *columns) -> str:
    """Lines of the node id and the columns (arrays, or a number for every row)."""
    n = len(ids)
    cols = [c if isinstance(c, np.ndarray) else np.full(n, c) for c in columns]
    return _format_lines(" ".join(["{}"] * (1 + len(cols))), ids, *cols)


def kratos_material_relation(pack: Pack) -> dict[str, float | str]:
    """The ``Variables`` of MaterialsDEM.json's material relation that give Kratos
    granpack's contact model; empty for the default Hertz-Mindlin without rolling
    resistance (the file then says nothing of it, as before).

    - linear law: ``DEM_D_Linear_Custom_Constants`` with ``K_NORMAL`` = k_n,
      ``K_TANGENTIAL`` = k_t, and ``COEFFICIENT_OF_RESTITUTION`` = exp(-pi xi /
      sqrt(1 - xi^2)), the restitution of a linear contact of damping ratio xi;
    - Hertz-Mindlin: ``DEM_D_Hertz_viscous_Coulomb`` (its restitution for granpack's
      damping is not worked out: set ``COEFFICIENT_OF_RESTITUTION``);
    - both: ``STATIC_FRICTION`` = ``DYNAMIC_FRICTION`` = mu;
    - rolling ``epsd``: Kratos has no elastic-plastic spring model; the nearest is
      ``DEMRollingFrictionModelConstantTorque`` (a torque of fixed size against the
      rolling, type A of Ai et al. 2011) with ``ROLLING_FRICTION`` =
      ``ROLLING_FRICTION_WITH_WALLS`` = mu_r. It gives the same plastic torque in steady
      rolling but no spring, so a pack at rest feels no rolling torque.
    """
    m = pack.scene.material
    if is_default_model(m):
        return {}
    out: dict[str, float | str] = {}
    if m.contact_law == "linear":
        k_n = m.normal_stiffness
        k_t = m.tangential_stiffness_or_default
        assert k_n is not None and k_t is not None
        out["DEM_DISCONTINUUM_CONSTITUTIVE_LAW_NAME"] = "DEM_D_Linear_Custom_Constants"
        out["K_NORMAL"] = float(k_n)
        out["K_TANGENTIAL"] = float(k_t)
        out["COEFFICIENT_OF_RESTITUTION"] = linear_restitution(m.damping)
    else:
        out["DEM_DISCONTINUUM_CONSTITUTIVE_LAW_NAME"] = "DEM_D_Hertz_viscous_Coulomb"
    out["STATIC_FRICTION"] = float(m.friction)
    out["DYNAMIC_FRICTION"] = float(m.friction)
    if m.rolling != "none":
        assert m.rolling_friction is not None
        out["DEM_ROLLING_FRICTION_MODEL_NAME"] = "DEMRollingFrictionModelConstantTorque"
        out["ROLLING_FRICTION"] = float(m.rolling_friction)
        out["ROLLING_FRICTION_WITH_WALLS"] = float(m.rolling_friction)
    return out


def write_kratos(pack: Pack, path: str | Path) -> Path:
    """Writes the pack as a Kratos DEM model part (``.mdpa``; layout in the module
    docstring): nodes, one sphere element a node (``SphericParticle3D``, 2D
    ``CylinderParticle2D``), radii, velocities and spins as nodal data, the sub model part
    ``DEMParts_Body``, and the container on a comment line. Returns the path.

    Kratos reads it with ``ModelPartIO`` once the DEM application is imported and the
    model part has ``RADIUS``, ``VELOCITY`` and ``ANGULAR_VELOCITY`` as nodal solution step
    variables (the DEM solver adds them); name it ``<problem>DEM.mdpa`` for Kratos' DEM
    analysis stage.
    """

    s = pack.scene
    d = s.dim
    n = len(pack)
    x, r, v, w = _state3(pack)
    ids = np.arange(1, n + 1)
    container = Container.of_pack(pack)
    lo, hi = pack.box
    m = s.material
    element = ELEMENT_3D if d == 3 else ELEMENT_2D
    out = io.StringIO()
    vertical = "z" if d == 3 else "y"
    out.write(
        f"// Kratos DEM model part from granpack: dim={d} N={n} seed={s.seed} stream={s.stream} "
        f"(SI units, vertical {vertical}{', discs in the plane z = 0' if d == 2 else ''})\n"
    )
    out.write(f"// granpack: dim={d} {container.tag_words()}\n")
    mass = ""
    if d == 2:
        mass = (
            " mass=disc (m = pi r^2 rho per metre)"
            if s.inertia_2d == "disc"
            else " mass=sphere (m = 4/3 pi r^3 rho)"
        )
    out.write(
        f"// material (set it in MaterialsDEM.json): density={m.density!r} young={m.young!r} "
        f"poisson={m.poisson!r} friction={m.friction!r} damping_ratio={m.damping!r}{mass}\n"
    )
    relation = kratos_material_relation(pack)
    if relation:
        out.write(f"// contact model: {model_words(m)}\n")
        out.write(
            "// MaterialsDEM.json, the material relation's Variables: "
            + json.dumps(relation)
            + "\n"
        )
    out.write("Begin ModelPartData\nEnd ModelPartData\n\n")
    out.write("Begin Properties 1\nEnd Properties\n\n")
    out.write("Begin Nodes\n")
    out.write(_rows(ids, x[:, 0], x[:, 1], x[:, 2]))
    out.write("End Nodes\n\n")
    out.write(f"Begin Elements {element}\n")
    out.write(_format_lines("{} 1 {}", ids, ids))
    out.write("End Elements\n\n")
    nodal = [("RADIUS", r)]
    nodal += [(f"VELOCITY_{a}", v[:, k]) for k, a in enumerate("XYZ"[:d])]
    spin_axes = range(3) if d == 3 else (2,)
    nodal += [(f"ANGULAR_VELOCITY_{'XYZ'[k]}", w[:, k]) for k in spin_axes]
    for name, values in nodal:
        out.write(f"Begin NodalData {name}\n")
        out.write(_rows(ids, 0, values))
        out.write("End NodalData\n\n")
    out.write(f"Begin SubModelPart {SUB_MODEL_PART}\n")
    for block in ("SubModelPartNodes", "SubModelPartElements"):
        out.write(f"  Begin {block}\n")
        for i in ids.tolist():
            out.write(f"  {i}\n")
        out.write(f"  End {block}\n")
    out.write("  Begin SubModelPartConditions\n  End SubModelPartConditions\n")
    out.write("End SubModelPart\n")
    return atomic_write(Path(path), out.getvalue().encode())


# --------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------
# blocks whose rows the reader takes; the rows of every other block are skipped
_DATA_BLOCKS = ("Nodes", "Elements", "NodalData")


def _fail(path: Path, line: int, what: str) -> FileFormatError:
    return FileFormatError(f"{path}:{line}: {what}", path=path, reason=what)


def _numbers(path: Path, line: int, fields: list[str], names: str) -> list[float]:
    out = []
    for f in fields:
        try:
            out.append(float(f))
        except ValueError:
            raise _fail(path, line, f"{f!r} is not a number (expected {names})") from None
    return out


def _integer(path: Path, line: int, field: str, name: str) -> int:
    try:
        return int(field)
    except ValueError:
        raise _fail(path, line, f"{name} {field!r} is not an integer") from None


def read_kratos(path: str | Path, dim: int | None = None) -> ParticleFile:
    """Reads the spheres of a Kratos DEM model part (``.mdpa``): granpack's export, and the
    files DEMGen and Kratos' DEM tools write (layout in the module docstring).

    Parameters
    ----------
    path : path
    dim : {None, 2, 3}
        None: 2 for ``...2D`` elements (``CylinderParticle2D``), 3 for ``...3D`` ones, else
        2 where every z is 0. 2 needs the same z for every sphere.

    Returns
    -------
    granpack.particles.ParticleFile
        Format ``"kratos"``: the node ids and centres of the spheres (sorted by id), their
        radii, and the container of granpack's comment line where there is one.

    Raises
    ------
    FileFormatError
        Naming the file and the line: a block left open at the end of the file (a
        truncated file), an ``End`` that closes no block or another one, a line outside
        any block, a row with the wrong number of fields, a value that is not a number, a
        coordinate or radius that is not finite (or a radius <= 0), a repeated node id, an
        element whose node is not in ``Nodes`` or has no radius, no ``NodalData RADIUS``
        block.
    """
    from .particle_file import ParticleFile

    path = Path(path)
    if dim is not None and (isinstance(dim, bool) or dim not in (2, 3)):
        raise InvalidParameterError(
            f"invalid dim = {dim!r}: must be None, 2 or 3", parameter="dim", value=dim
        )
    lines = _read_text(path).splitlines()
    nodes: dict[int, tuple[list[float], int]] = {}  # id -> (x y z, line)
    elements: list[tuple[int, int, str]] = []  # (node id, line, element name)
    element_of: dict[int, int] = {}  # node id -> the line of its element
    radius: dict[int, tuple[float, int]] = {}
    has_radius_block = False
    tag_lines: list[tuple[int, str]] = []
    stack: list[tuple[str, list[str], int]] = []  # (kind, arguments, line)
    for k, raw in enumerate(lines, start=1):
        body, _, comment = raw.partition("//")
        if "granpack" in comment and "container=" in comment:
            tag_lines.append((k, comment))
        words = body.split()
        if not words:
            continue
        if words[0] == "Begin":
            if len(words) < 2:
                raise _fail(path, k, "'Begin' names no block")
            if stack and stack[-1][0] in _DATA_BLOCKS:
                top = stack[-1]
                raise _fail(
                    path,
                    k,
                    f"expected a row or 'End {top[0]}' (block opened at line {top[2]}), "
                    f"found {body.strip()[:60]!r}",
                )
            stack.append((words[1], words[2:], k))
            if words[1] == "NodalData" and words[2:3] == ["RADIUS"]:
                has_radius_block = True
            continue
        if words[0] == "End":
            closes = words[1] if len(words) > 1 else ""
            if not stack:
                raise _fail(path, k, f"'End {closes}' closes no block")
            top = stack[-1]
            if closes != top[0]:
                raise _fail(
                    path,
                    k,
                    f"expected 'End {top[0]}' (block opened at line {top[2]}), found "
                    f"{body.strip()[:60]!r}",
                )
            stack.pop()
            continue
        if not stack:
            raise _fail(
                path,
                k,
                "expected 'Begin <block>' (a Kratos model part file: Begin Nodes, Begin "
                f"Elements, ...), found {body.strip()[:60]!r}",
            )
        block, args, _ = stack[-1]
        if block == "Nodes" and len(stack) == 1:
            if len(words) != 4:
                raise _fail(path, k, f"expected 4 fields (id x y z) in Nodes, found {len(words)}")
            i = _integer(path, k, words[0], "node id")
            xyz = _numbers(path, k, words[1:], "id x y z")
            if not all(math.isfinite(c) for c in xyz):
                raise _fail(path, k, f"node {i}: non-finite coordinate")
            if i in nodes:
                raise _fail(path, k, f"node id {i} repeated (first at line {nodes[i][1]})")
            nodes[i] = (xyz, k)
        elif block == "Elements" and len(stack) == 1:
            name = args[0] if args else ""
            if len(words) != 3:
                raise _fail(
                    path,
                    k,
                    f"expected 3 fields (element id, property id, node id) in Elements {name}: "
                    f"a sphere element has one node; found {len(words)}",
                )
            _integer(path, k, words[0], "element id")
            _integer(path, k, words[1], "property id")
            node = _integer(path, k, words[2], "node id")
            if node in element_of:
                raise _fail(
                    path,
                    k,
                    f"node {node} has two sphere elements (the other at line {element_of[node]})",
                )
            element_of[node] = k
            elements.append((node, k, name))
        elif block == "NodalData" and args[:1] == ["RADIUS"] and len(stack) == 1:
            if len(words) != 3:
                raise _fail(
                    path,
                    k,
                    "expected 3 fields (node id, fixed, radius) in NodalData RADIUS, found "
                    f"{len(words)}",
                )
            node = _integer(path, k, words[0], "node id")
            (value,) = _numbers(path, k, words[2:], "node id, fixed, radius")
            if not (math.isfinite(value) and value > 0.0):
                raise _fail(path, k, f"radius {value!r} of node {node} must be finite and > 0 (m)")
            if node in radius:
                raise _fail(
                    path, k, f"radius of node {node} repeated (first at line {radius[node][1]})"
                )
            radius[node] = (value, k)
    if stack:
        kind, args, k0 = stack[-1]
        opened = " ".join([kind, *args])
        raise _fail(
            path,
            len(lines),
            f"the file ends inside 'Begin {opened}' (line {k0}): expected 'End {kind}' (a "
            "truncated file?)",
        )
    if not nodes:
        raise _fail(path, max(len(lines), 1), "no 'Begin Nodes' block with nodes")
    if not elements:
        raise _fail(path, max(len(lines), 1), "no 'Begin Elements' block of sphere elements")
    if not has_radius_block:
        raise _fail(
            path,
            max(len(lines), 1),
            "no 'Begin NodalData RADIUS' block: the spheres' radii are missing",
        )
    for node, k, _ in elements:
        if node not in nodes:
            raise _fail(path, k, f"the element's node {node} is not in the Nodes block")
        if node not in radius:
            raise _fail(path, k, f"the element's node {node} has no radius in 'NodalData RADIUS'")
    names = sorted({name for _, _, name in elements})
    ids = np.array(sorted(element_of), dtype=np.int64)
    x3 = np.array([nodes[int(i)][0] for i in ids], dtype=np.float64)
    r = np.array([radius[int(i)][0] for i in ids], dtype=np.float64)
    kinds = {2 if nm.endswith("2D") else 3 if nm.endswith("3D") else 0 for nm in names}
    if len(kinds - {0}) > 1:
        raise _fail(path, elements[0][1], f"2D and 3D elements in one file: {', '.join(names)}")
    z_const = bool(np.all(x3[:, 2] == x3[0, 2]))
    file_dim = max(kinds)
    if dim is None:
        d = file_dim or (2 if z_const and x3[0, 2] == 0.0 else 3)
    else:
        d = dim
    if d == 2 and not z_const:
        raise _fail(
            path,
            nodes[int(ids[int(np.argmax(x3[:, 2] != x3[0, 2]))])][1],
            f"a 2D file needs the same z for every sphere; z runs from "
            f"{float(np.min(x3[:, 2]))} to {float(np.max(x3[:, 2]))}",
        )
    fields: dict = {}
    for k, comment in tag_lines:
        tag = Container.read_tag(comment, path, k, d)
        if tag is not None:
            fields = {
                "container": tag.kind,
                "cylinder_radius": tag.cylinder_radius,
                "periodic": (tag.kind == "periodic",) * (d - 1),
                "lid": tag.lid,
            }
            if tag.lo is not None and tag.hi is not None:
                fields["box"] = (tag.lo, tag.hi)
            break
    return ParticleFile(path=path, format="kratos", positions=x3[:, :d], radii=r, ids=ids, **fields)
