"""Packs for four more DEM codes.

Kratos: the model part is read by Kratos itself (ModelPartIO, and a short DEM run from it)
where the KratosMultiphysics and KratosDEMApplication wheels are installed, and back by
granpack. MercuryDPM, PFC and DEM-Engine cannot run here: each file is parsed by the test
itself, following the layout of the code's source or manual, and every value is compared
with the pack's."""

from __future__ import annotations

import csv
import json
import math
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from scenes import small_scene

import granpack as gp
from granpack.analysis.container import Container
from granpack.cli import main
from granpack.errors import FileFormatError
from granpack.io import EXPORT_FORMATS, detect_format, export
from granpack.io.demengine import (
    COLUMNS,
    MAX_TEMPLATES,
    error_bound,
    sphere_templates,
    templates_path,
    write_demengine,
)
from granpack.io.kratos import read_kratos, write_kratos
from granpack.io.lammps import lammps_positions
from granpack.io.mercurydpm import write_mercurydpm
from granpack.io.pfc import DOMAIN_MARGIN, write_pfc

CASES = [(3, "box"), (3, "periodic"), (3, "cylinder"), (2, "box"), (2, "periodic")]


@pytest.fixture(scope="module", params=CASES, ids=[f"{d}d-{c}" for d, c in CASES])
def pack(request) -> gp.Pack:
    dim, container = request.param
    # sphere mass in 2D (LoadSphereType's templates); disc_pack has the disc convention
    return gp.generate(small_scene(dim, container=container, inertia_2d="sphere").fast())


@pytest.fixture(scope="module")
def disc_pack() -> gp.Pack:
    """A 2D pack with the disc mass convention (m = pi r^2 rho per metre)."""
    return gp.generate(small_scene(2, inertia_2d="disc").fast())


def _spins3(pack: gp.Pack) -> np.ndarray:
    w = np.asarray(pack.spins, dtype=np.float64)
    if w.ndim == 1:
        out = np.zeros((len(w), 3))
        out[:, 2] = w
        return out
    return w


def _vel3(pack: gp.Pack) -> np.ndarray:
    v = np.zeros((len(pack), 3))
    v[:, : pack.dim] = pack.velocities
    return v


def _check_tag(text: str, path: Path, line: int, pack: gp.Pack) -> None:
    """The container tag on `text` is the pack's container and box."""
    tag = Container.read_tag(text, path, line, pack.dim)
    assert tag is not None
    assert tag.kind == pack.scene.container
    lo, hi = pack.box
    np.testing.assert_array_equal(tag.lo, lo)
    np.testing.assert_array_equal(tag.hi, hi)
    if tag.kind == "cylinder":
        assert tag.cylinder_radius == pack.scene.base[0] / 2


# --------------------------------------------------------------------------------------
# Kratos, by the real program
# --------------------------------------------------------------------------------------
def _kratos_or_skip() -> None:
    import importlib.util

    # found without importing Kratos here (its banner, its threads): the runs are subprocesses
    spec = importlib.util.find_spec("KratosMultiphysics")
    folders = list(spec.submodule_search_locations or []) if spec is not None else []
    if any((Path(f) / "DEMApplication" / "__init__.py").exists() for f in folders):
        return
    why = "Kratos not installed (pip install KratosMultiphysics KratosDEMApplication)"
    if os.environ.get("GRANPACK_PEERS") == "required":
        pytest.fail(f"{why}, though GRANPACK_PEERS=required", pytrace=False)
    pytest.skip(why)


# Kratos prints its banner on stdout: the script's results are the line after RESULT
_KRATOS_READ = textwrap.dedent(
    """
    import json, sys
    import KratosMultiphysics as KM
    import KratosMultiphysics.DEMApplication  # registers SphericParticle3D, CylinderParticle2D
    model = KM.Model()
    mp = model.CreateModelPart("SpheresPart")
    for var in (KM.RADIUS, KM.VELOCITY, KM.ANGULAR_VELOCITY):
        mp.AddNodalSolutionStepVariable(var)
    KM.ModelPartIO(sys.argv[1]).ReadModelPart(mp)
    sub = mp.GetSubModelPart("DEMParts_Body") if mp.HasSubModelPart("DEMParts_Body") else None
    out = {
        "nodes": [[n.Id, n.X, n.Y, n.Z, n.GetSolutionStepValue(KM.RADIUS),
                   list(n.GetSolutionStepValue(KM.VELOCITY)),
                   list(n.GetSolutionStepValue(KM.ANGULAR_VELOCITY))] for n in mp.Nodes],
        "elements": [[e.Id, e.Properties.Id, e.GetGeometry()[0].Id, str(e).split()[0]]
                     for e in mp.Elements],
        "sub": None if sub is None else [sorted(n.Id for n in sub.Nodes),
                                         sorted(e.Id for e in sub.Elements)],
    }
    print("RESULT")
    print(json.dumps(out))
    """
)


def _run_kratos(script: str, *args: str, cwd: Path) -> dict:
    res = subprocess.run(
        [sys.executable, "-c", script, *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    lines = res.stdout.splitlines()
    return json.loads(lines[lines.index("RESULT") + 1])


@pytest.mark.peers
@pytest.mark.parametrize("case", [(3, "periodic"), (2, "box")], ids=["3d-periodic", "2d-box"])
def test_kratos_model_part_io_reads_the_spheres(case, tmp_path):
    _kratos_or_skip()
    dim, container = case
    pack = gp.generate(small_scene(dim, container=container).fast())
    write_kratos(pack, tmp_path / "pack.mdpa")
    got = _run_kratos(_KRATOS_READ, str(tmp_path / "pack"), cwd=tmp_path)
    n = len(pack)
    nodes = sorted(got["nodes"])
    assert [row[0] for row in nodes] == list(range(1, n + 1))
    x = np.array([row[1:4] for row in nodes])
    np.testing.assert_allclose(x, lammps_positions(pack), rtol=0, atol=1e-12)
    np.testing.assert_allclose([row[4] for row in nodes], pack.radii, rtol=0, atol=1e-12)
    # Kratos keeps 3 components; nodal data is read as written (full precision)
    np.testing.assert_allclose([row[5] for row in nodes], _vel3(pack), rtol=0, atol=1e-12)
    np.testing.assert_allclose([row[6] for row in nodes], _spins3(pack), rtol=0, atol=1e-12)
    elements = sorted(got["elements"])
    assert [e[:3] for e in elements] == [[i, 1, i] for i in range(1, n + 1)]
    assert {e[3] for e in elements} == {"SphericParticle" if dim == 3 else "CylinderParticle"}
    assert got["sub"] == [list(range(1, n + 1)), list(range(1, n + 1))]


_KRATOS_RUN = textwrap.dedent(
    """
    import json
    import KratosMultiphysics as KM
    from KratosMultiphysics.DEMApplication.DEM_analysis_stage import DEMAnalysisStage
    with open("ProjectParametersDEM.json") as f:
        stage = DEMAnalysisStage(KM.Model(), KM.Parameters(f.read()))
    stage.Initialize()
    mp = stage.spheres_model_part
    def state():
        return [[n.Id, n.X, n.Y, n.Z, n.GetSolutionStepValue(KM.RADIUS),
                 list(n.GetSolutionStepValue(KM.VELOCITY))] for n in mp.Nodes]
    before = state()
    stage.RunSolutionLoop()
    out = {"before": before, "after": state(), "time": mp.ProcessInfo[KM.TIME],
           "elements": mp.NumberOfElements(),
           "density": [e.Properties[KM.DEMApplication.PARTICLE_DENSITY] for e in mp.Elements]}
    stage.Finalize()
    print("RESULT")
    print(json.dumps(out))
    """
)


@pytest.mark.peers
def test_a_kratos_dem_run_starts_from_the_model_part(tmp_path):
    """Kratos' DEM analysis stage reads ``granpackDEM.mdpa``, assigns the material of
    MaterialsDEM.json to the sub model part DEMParts_Body, and runs 10 steps."""
    _kratos_or_skip()
    pack = gp.generate(small_scene(3).fast())
    m = pack.scene.material
    write_kratos(pack, tmp_path / "granpackDEM.mdpa")
    dt, steps, g = 1e-5, 10, pack.scene.gravity
    params = {
        "Dimension": 3,
        "BoundingBoxOption": False,
        "dem_inlet_option": False,
        "GravityX": 0.0,
        "GravityY": 0.0,
        "GravityZ": -g,
        "RotationOption": True,
        "CleanIndentationsOption": False,
        "solver_settings": {
            "strategy": "sphere_strategy",
            "RemoveBallsInitiallyTouchingWalls": False,
            "material_import_settings": {"materials_filename": "MaterialsDEM.json"},
        },
        "TranslationalIntegrationScheme": "Symplectic_Euler",
        "RotationalIntegrationScheme": "Direct_Integration",
        "AutomaticTimestep": False,
        "MaxTimeStep": dt,
        "FinalTime": dt * steps,
        "NeighbourSearchFrequency": 1,
        "OutputTimeStep": 1.0,
        "post_gid_option": False,
        "post_vtk_option": False,
        "problem_name": "granpack",
    }
    materials = {
        "materials": [
            {
                "material_name": "granpack",
                "material_id": 1,
                "Variables": {
                    "PARTICLE_DENSITY": m.density,
                    "YOUNG_MODULUS": m.young,
                    "POISSON_RATIO": m.poisson,
                },
            }
        ],
        "material_relations": [
            {
                "material_names_list": ["granpack", "granpack"],
                "material_ids_list": [1, 1],
                "Variables": {
                    "COEFFICIENT_OF_RESTITUTION": 0.7,
                    "STATIC_FRICTION": m.friction,
                    "DYNAMIC_FRICTION": m.friction,
                    "FRICTION_DECAY": 500,
                    "ROLLING_FRICTION": 0.0,
                    "ROLLING_FRICTION_WITH_WALLS": 0.0,
                    "DEM_DISCONTINUUM_CONSTITUTIVE_LAW_NAME": "DEM_D_Hertz_viscous_Coulomb",
                },
            }
        ],
        "material_assignation_table": [["SpheresPart.DEMParts_Body", "granpack"]],
    }
    (tmp_path / "ProjectParametersDEM.json").write_text(json.dumps(params))
    (tmp_path / "MaterialsDEM.json").write_text(json.dumps(materials))
    got = _run_kratos(_KRATOS_RUN, cwd=tmp_path)
    n = len(pack)
    assert got["time"] == pytest.approx(dt * steps, rel=1e-12)
    assert got["elements"] == n
    assert got["density"] == [m.density] * n
    before, after = sorted(got["before"]), sorted(got["after"])
    assert [b[0] for b in before] == [a[0] for a in after] == list(range(1, n + 1))
    x0 = np.array([b[1:4] for b in before])
    np.testing.assert_allclose(x0, lammps_positions(pack), rtol=0, atol=1e-12)
    np.testing.assert_allclose([b[5] for b in before], _vel3(pack), rtol=0, atol=1e-12)
    np.testing.assert_array_equal([a[4] for a in after], [b[4] for b in before])
    # every sphere moved, and by no more than its speed and the forces allow in 1e-4 s
    x1 = np.array([a[1:4] for a in after])
    moved = np.linalg.norm(x1 - x0, axis=1)
    assert np.all(moved > 0.0)
    speed = np.linalg.norm(_vel3(pack), axis=1)
    assert np.all(moved <= 2.0 * speed * dt * steps + 1e-6)


# --------------------------------------------------------------------------------------
# Kratos, written and read back by granpack
# --------------------------------------------------------------------------------------
def test_kratos_round_trip_keeps_positions_radii_and_container(pack, tmp_path):
    path = write_kratos(pack, tmp_path / "pack.mdpa")
    for p in (read_kratos(path), gp.read_particles(path)):
        assert p.format == "kratos" and p.dim == pack.dim
        np.testing.assert_array_equal(p.ids, np.arange(1, len(pack) + 1))
        np.testing.assert_allclose(
            p.positions, lammps_positions(pack)[:, : pack.dim], rtol=0, atol=1e-12
        )
        np.testing.assert_allclose(p.radii, pack.radii, rtol=0, atol=1e-12)
        lo, hi = pack.box
        np.testing.assert_array_equal(p.box[0], lo)
        np.testing.assert_array_equal(p.box[1], hi)
        assert p.container == pack.scene.container
        assert p.periodic == (pack.scene.container == "periodic",) * (pack.dim - 1)
        if pack.scene.container == "cylinder":
            assert p.cylinder_radius == pack.scene.base[0] / 2
    text = path.read_text()
    assert ("SphericParticle3D" if pack.dim == 3 else "CylinderParticle2D") in text
    assert "Begin SubModelPart DEMParts_Body" in text


# a sphere model part as Kratos' own DEM tools write one (DEMApplication's
# mesh_to_mdpa_converter.py: fixed-width numbers, a Properties block with variables,
# continuum elements, more nodal data; the GiD interface's comment after a block name)
_KRATOS_TOOLS_FILE = """\
Begin ModelPartData
//  VARIABLE_NAME value
End ModelPartData

Begin Properties 1
PARTICLE_DENSITY 2650.0
YOUNG_MODULUS 8.03e7
DEM_CONTINUUM_CONSTITUTIVE_LAW_NAME DEM_KDEM_with_damage_parallel_bond_Hertz //_Hertz
End Properties

Begin Nodes
7   0.10000000   0.20000000   0.30000000
3   0.00000000   0.00000000   0.05000000
5   1.00000000   1.00000000   1.00000000
End Nodes

Begin Elements SphericContinuumParticle3D// GUI group identifier: dem
1 1 7
2 1 3
End Elements

Begin NodalData RADIUS
7 0   0.05000000
3 0   0.04000000
End NodalData

Begin NodalData COHESIVE_GROUP
7 0 1
3 0 1
End NodalData

Begin SubModelPart PartsCont_dem // Group dem // Subtree PartsCont
    Begin SubModelPartNodes
7
3
End SubModelPartNodes
    Begin SubModelPartElements
1
2
End SubModelPartElements
    Begin SubModelPartConditions
    End SubModelPartConditions
End SubModelPart
"""


def test_a_model_part_from_kratos_dem_tools_reads(tmp_path):
    path = tmp_path / "toolsDEM.mdpa"
    path.write_text(_KRATOS_TOOLS_FILE)
    p = gp.read_particles(path)
    assert p.format == "kratos" and p.dim == 3
    # the spheres are the element nodes (5 is no sphere), sorted by id
    assert p.ids.tolist() == [3, 7]
    np.testing.assert_array_equal(p.positions, [[0.0, 0.0, 0.05], [0.1, 0.2, 0.3]])
    np.testing.assert_array_equal(p.radii, [0.04, 0.05])
    assert p.container is None and p.box is None


def test_mdpa_is_told_by_suffix_and_content(tmp_path):
    pack = gp.generate(small_scene(3).fast())
    path = export(pack, tmp_path / "pack.mdpa")[0]
    assert detect_format(path) == "kratos"
    renamed = tmp_path / "pack.txt"
    renamed.write_bytes(path.read_bytes())
    assert detect_format(renamed) == "kratos"
    assert gp.read_particles(renamed).format == "kratos"


@pytest.fixture(scope="module")
def mdpa_text() -> str:
    pack = gp.generate(small_scene(3).fast())
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        return write_kratos(pack, Path(d) / "p.mdpa").read_text()


def _line_of(lines: list[str], start: str, nth: int = 0) -> int:
    """1-based number of the nth line that starts with `start`."""
    hits = [k + 1 for k, ln in enumerate(lines) if ln.startswith(start)]
    return hits[nth]


def _bad(text: str, case: str) -> tuple[str, int, str]:
    """A damaged model part, the line the error must name, and words of its message."""
    lines = text.splitlines()
    if case == "truncated":
        k = _line_of(lines, "Begin Nodes") + 5
        return "\n".join(lines[:k]) + "\n", k, "ends inside 'Begin Nodes'"
    if case == "no-radius-block":
        a = _line_of(lines, "Begin NodalData RADIUS") - 1
        b = lines.index("End NodalData", a) + 1
        kept = lines[:a] + lines[b:]
        return "\n".join(kept) + "\n", len(kept), "no 'Begin NodalData RADIUS'"
    if case == "wrong-end":
        k = _line_of(lines, "End Elements")
        lines[k - 1] = "End Nodes"
        return "\n".join(lines) + "\n", k, "expected 'End Elements'"
    if case == "nan-coordinate":
        k = _line_of(lines, "Begin Nodes") + 3
        f = lines[k - 1].split()
        lines[k - 1] = " ".join([f[0], "nan", f[2], f[3]])
        return "\n".join(lines) + "\n", k, "non-finite coordinate"
    if case == "inf-radius":
        k = _line_of(lines, "Begin NodalData RADIUS") + 2
        f = lines[k - 1].split()
        lines[k - 1] = " ".join([f[0], f[1], "inf"])
        return "\n".join(lines) + "\n", k, "must be finite and > 0"
    if case == "missing-radius":
        k = _line_of(lines, "Begin NodalData RADIUS") + 4  # the row of node 4
        assert lines[k - 1].split()[0] == "4"
        del lines[k - 1]
        elem = _line_of(lines, "Begin Elements") + 4
        assert lines[elem - 1].split() == ["4", "1", "4"]
        return "\n".join(lines) + "\n", elem, "node 4 has no radius"
    if case == "short-row":
        k = _line_of(lines, "Begin Nodes") + 2
        lines[k - 1] = " ".join(lines[k - 1].split()[:3])
        return "\n".join(lines) + "\n", k, "expected 4 fields (id x y z)"
    if case == "not-a-number":
        k = _line_of(lines, "Begin Elements") + 1
        lines[k - 1] = "1 1 one"
        return "\n".join(lines) + "\n", k, "node id 'one' is not an integer"
    if case == "lammps-data":
        data = "LAMMPS data file\n\n2 atoms\n1 atom types\n\n0 1 xlo xhi\n"
        return data, 1, "expected 'Begin <block>'"
    if case == "yade-text":
        return "#format x_y_z_r\n0.1 0.1 0.1 0.05\n", 1, "expected 'Begin <block>'"
    raise AssertionError(case)


BAD = [
    "truncated",
    "no-radius-block",
    "wrong-end",
    "nan-coordinate",
    "inf-radius",
    "missing-radius",
    "short-row",
    "not-a-number",
    "lammps-data",
    "yade-text",
]


@pytest.mark.parametrize("case", BAD)
def test_a_bad_model_part_is_a_file_format_error_naming_the_line(mdpa_text, case, tmp_path):
    text, line, words = _bad(mdpa_text, case)
    path = tmp_path / "bad.mdpa"
    path.write_text(text)
    # another format's whole content is that format's by its content; read as Kratos,
    # it is refused
    for read in (read_kratos, lambda f: gp.read_particles(f, format="kratos")):
        with pytest.raises(FileFormatError) as exc:
            read(path)
        assert exc.value.path == path
        assert str(exc.value).startswith(f"{path}:{line}: "), str(exc.value)
        assert words in str(exc.value)


# --------------------------------------------------------------------------------------
# MercuryDPM: DPMBase::readNextDataFile's reading, field by field
# --------------------------------------------------------------------------------------
def test_mercurydpm_data_file_has_the_layout_mercurydpm_reads(pack, tmp_path):
    path = write_mercurydpm(pack, tmp_path / "pack.data")
    lines = path.read_text().splitlines()
    d, n = pack.dim, len(pack)
    # readNextDataFile: N with >>, then the rest of the header line into a string stream,
    # from which it takes time and the box (format 14: 6 numbers, format 8: 4) only
    head = lines[0].split()
    assert int(head[0]) == n and head[0] == str(n)
    assert float(head[1]) == 0.0
    nbox = 6 if d == 3 else 4
    box = np.array([float(w) for w in head[2 : 2 + nbox]])
    lo, hi = pack.box
    np.testing.assert_array_equal(box, np.concatenate([lo, hi]))
    # what follows the box is granpack's container tag, which MercuryDPM does not read
    _check_tag(" ".join(head[2 + nbox :]), path, 1, pack)
    assert len(lines) == n + 1
    rows = [ln.split() for ln in lines[1:]]
    ncol = 14 if d == 3 else 8
    assert all(len(r) == ncol for r in rows)
    a = np.array([[float(w) for w in r] for r in rows])
    x = lammps_positions(pack)
    v = np.asarray(pack.velocities)
    if d == 3:
        # x y z vx vy vz r alpha beta gamma wx wy wz info
        np.testing.assert_array_equal(a[:, 0:3], x)
        np.testing.assert_array_equal(a[:, 3:6], v)
        np.testing.assert_array_equal(a[:, 6], pack.radii)
        np.testing.assert_array_equal(a[:, 7:10], 0.0)
        np.testing.assert_array_equal(a[:, 10:13], pack.spins)
    else:
        # x y vx vy r alpha -wz info (MercuryDPM writes -w_z and reads it back negated)
        np.testing.assert_array_equal(a[:, 0:2], x[:, :2])
        np.testing.assert_array_equal(a[:, 2:4], v)
        np.testing.assert_array_equal(a[:, 4], pack.radii)
        np.testing.assert_array_equal(a[:, 5], 0.0)
        np.testing.assert_array_equal(-a[:, 6], pack.spins)
    # the species index, read as size_t
    assert all(r[-1] == "0" for r in rows)


# --------------------------------------------------------------------------------------
# PFC 7: the commands of Itasca's manual, field by field
# --------------------------------------------------------------------------------------
_VECTOR = r"\(([^()]*)\)"
_CREATE = re.compile(rf"^ball create id (\d+) radius (\S+) position {_VECTOR}$")
_ATTRIBUTE = re.compile(
    rf"^ball attribute density (\S+) velocity {_VECTOR} spin ({_VECTOR}|\S+) range id (\d+)$"
)


def _vector(text: str, d: int) -> np.ndarray:
    v = np.array([float(w) for w in text.split(",")])
    assert v.shape == (d,)
    return v


def _pfc_commands(path: Path) -> tuple[list[str], list[str]]:
    """(commands, comments): ';' starts a comment (Itasca's Command Shaping)."""
    commands, comments = [], []
    for ln in path.read_text().splitlines():
        body, _, comment = ln.partition(";")
        if body.strip():
            commands.append(" ".join(body.split()))
        if comment.strip():
            comments.append(comment)
    return commands, comments


def test_pfc_commands_create_the_pack(pack, tmp_path):
    _check_pfc(pack, tmp_path)


def test_pfc_commands_keep_the_2d_disc_mass(disc_pack, tmp_path):
    _check_pfc(disc_pack, tmp_path)


def _check_pfc(pack: gp.Pack, tmp_path: Path) -> None:
    path = write_pfc(pack, tmp_path / "pack.p3dat")
    commands, comments = _pfc_commands(path)
    d, n = pack.dim, len(pack)
    _check_tag(next(c for c in comments if "container=" in c), path, 2, pack)
    assert commands[0] == "model new"
    dom = commands[1].split()
    assert dom[:3] == ["model", "domain", "extent"]
    extent = np.array([float(w) for w in dom[3 : 3 + 2 * d]]).reshape(d, 2)
    assert dom[3 + 2 * d] == "condition"
    conditions = dom[4 + 2 * d :]
    assert len(conditions) == d
    lo, hi = pack.box
    periodic = pack.scene.container == "periodic"
    for a in range(d):
        if periodic and a < d - 1:
            assert conditions[a] == "periodic"
            assert extent[a].tolist() == [lo[a], hi[a]]
        else:
            assert conditions[a] == "stop"
            pad = DOMAIN_MARGIN * (hi[a] - lo[a])
            assert extent[a].tolist() == [lo[a] - pad, hi[a] + pad]
    creates = [_CREATE.match(c) for c in commands[2 : 2 + n]]
    attributes = [_ATTRIBUTE.match(c) for c in commands[2 + n :]]
    assert len(commands) == 2 + 2 * n
    assert all(creates) and all(attributes)
    ids = [int(c.group(1)) for c in creates]
    assert ids == list(range(1, n + 1)) == [int(a.group(5)) for a in attributes]
    r = np.array([float(c.group(2)) for c in creates])
    x = np.array([_vector(c.group(3), d) for c in creates])
    np.testing.assert_array_equal(r, pack.radii)
    np.testing.assert_array_equal(x, lammps_positions(pack)[:, :d])
    # the manual's limits: a centroid inside the domain, a radius below 1/4 of its
    # smallest extent
    assert np.all((x >= extent[:, 0]) & (x < extent[:, 1]))
    assert np.all(r < np.min(extent[:, 1] - extent[:, 0]) / 4.0)
    rho = np.array([float(a.group(1)) for a in attributes])
    v = np.array([_vector(a.group(2), d) for a in attributes])
    np.testing.assert_array_equal(v, pack.velocities)
    if d == 3:
        w = np.array([_vector(a.group(4), 3) for a in attributes])
        np.testing.assert_array_equal(w, pack.spins)
    else:
        assert all(a.group(4) == a.group(3) or "(" not in a.group(3) for a in attributes)
        w = np.array([float(a.group(3)) for a in attributes])
        np.testing.assert_array_equal(w, pack.spins)
    # PFC's mass: rho 4/3 pi r^3 (3D), rho pi r^2 for a 2D ball (a disc of unit thickness)
    pfc_mass = rho * (4.0 / 3.0 * math.pi * r**3 if d == 3 else math.pi * r**2)
    rho0 = pack.scene.material.density
    if d == 2 and pack.scene.inertia_2d == "disc":
        want = rho0 * math.pi * r**2
    else:
        want = rho0 * 4.0 / 3.0 * math.pi * r**3
    np.testing.assert_allclose(pfc_mass, want, rtol=1e-14, atol=0)


# --------------------------------------------------------------------------------------
# DEM-Engine: its CSV reader's columns, and the templates
# --------------------------------------------------------------------------------------
def _read_templates(path: Path) -> tuple[list[str], list[dict]]:
    lines = path.read_text().splitlines()
    comments = [ln for ln in lines if ln.startswith("#")]
    rows = list(csv.DictReader([ln for ln in lines if not ln.startswith("#")]))
    return comments, rows


@pytest.mark.parametrize("max_templates", [MAX_TEMPLATES, 8])
def test_demengine_clump_csv_and_templates(pack, max_templates, tmp_path):
    files = write_demengine(pack, tmp_path / "pack.csv", max_templates=max_templates)
    assert files == [tmp_path / "pack.csv", tmp_path / "pack.templates.csv"]
    n = len(pack)
    text = files[0].read_text()
    # DEM-Engine's CSV reader (io::CSVReader, empty_line_comment) skips empty lines only:
    # the first line is the header, every other line a row
    lines = text.splitlines()
    assert all(ln.strip() and not ln.startswith("#") for ln in lines)
    header = lines[0].split(",")
    assert tuple(header) == COLUMNS
    # the columns ReadClumpXyzFromCsv, ReadClumpQuatFromCsv, ReadClumpVelFromCsv and
    # ReadClumpAngVelFromCsv look up by name (Structs.h)
    for name in ("X", "Y", "Z", "clump_type", "Qw", "Qx", "Qy", "Qz", "v_x", "v_y", "v_z"):
        assert name in header
    assert {"w_x", "w_y", "w_z"} <= set(header)
    rows = list(csv.DictReader(lines))
    assert len(rows) == n
    x = np.array([[float(r[c]) for c in ("X", "Y", "Z")] for r in rows])
    np.testing.assert_array_equal(x, lammps_positions(pack))
    q = np.array([[float(r[c]) for c in ("Qw", "Qx", "Qy", "Qz")] for r in rows])
    np.testing.assert_array_equal(q, np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)))
    v = np.array([[float(r[c]) for c in ("v_x", "v_y", "v_z")] for r in rows])
    np.testing.assert_array_equal(v, _vel3(pack))
    w = np.array([[float(r[c]) for c in ("w_x", "w_y", "w_z")] for r in rows])
    np.testing.assert_array_equal(w, _spins3(pack))

    comments, templates = _read_templates(files[1])
    _check_tag(next(c for c in comments if "container=" in c), files[1], 2, pack)
    # LoadClumpType names templates "%04d" of their load order
    names = [t["name"] for t in templates]
    assert names == [f"{k:04d}" for k in range(len(templates))]
    assert 1 <= len(templates) <= max_templates
    radius = {t["name"]: float(t["radius"]) for t in templates}
    assert list(radius.values()) == sorted(radius.values())
    rho = pack.scene.material.density
    for t in templates:
        rt, mass = float(t["radius"]), float(t["mass"])
        assert mass == pytest.approx(rho * 4.0 / 3.0 * math.pi * rt**3, rel=1e-14)
        # LoadSphereType's moment of inertia
        assert float(t["moi"]) == pytest.approx(0.4 * mass * rt**2, rel=1e-14)
    # ReadClumpXyzFromCsv groups the rows by clump_type
    by_type: dict[str, list[int]] = {}
    for k, r in enumerate(rows):
        by_type.setdefault(r["clump_type"], []).append(k)
    assert set(by_type) <= set(names)
    counts = {t["name"]: int(t["count"]) for t in templates}
    assert {k: len(v) for k, v in by_type.items()} == {k: c for k, c in counts.items() if c}
    radii = np.asarray(pack.radii)
    err = np.array([abs(radius[r["clump_type"]] - radii[k]) / radii[k] for k, r in enumerate(rows)])
    for t in templates:
        members = radii[by_type[t["name"]]]
        assert float(t["r_min"]) == members.min() and float(t["r_max"]) == members.max()
    reported = float(re.search(r"max_relative_radius_error=(\S+)", "\n".join(comments)).group(1))
    assert reported == pytest.approx(float(err.max()), rel=1e-12, abs=1e-300)
    assert reported <= error_bound(radii.min(), radii.max(), max_templates) * (1 + 1e-9)
    if len(np.unique(radii)) <= max_templates:
        assert reported == 0.0


def test_demengine_disc_mass_templates(disc_pack, tmp_path):
    _, path = write_demengine(disc_pack, tmp_path / "pack.csv")
    _, templates = _read_templates(path)
    rho = disc_pack.scene.material.density
    for t in templates:
        rt, mass = float(t["radius"]), float(t["mass"])
        assert mass == pytest.approx(rho * math.pi * rt**2, rel=1e-14)
        assert float(t["moi"]) == pytest.approx(0.5 * mass * rt**2, rel=1e-14)


def test_sphere_templates_bound_the_radius_error():
    rng = np.random.default_rng(3)
    radii = np.exp(rng.normal(np.log(0.01), 0.4, 20000))
    templates, index, err = sphere_templates(radii)
    assert len(templates) <= MAX_TEMPLATES
    got = np.abs(templates[index] - radii) / radii
    assert err == pytest.approx(float(got.max()), rel=1e-12)
    assert err <= error_bound(radii.min(), radii.max())
    # fewer templates cannot do as well: the greedy cover with the same tolerance needs
    # them all
    assert sphere_templates(radii, len(templates) - 1)[2] > err
    # a discrete mixture keeps its radii
    mix = np.repeat([0.01, 0.02, 0.03], 5)
    t, i, e = sphere_templates(mix)
    assert t.tolist() == [0.01, 0.02, 0.03] and e == 0.0
    np.testing.assert_array_equal(t[i], mix)


# --------------------------------------------------------------------------------------
# export and the command line
# --------------------------------------------------------------------------------------
def test_export_names_the_dem_codes(tmp_path):
    pack = gp.generate(small_scene(3).fast())
    assert {"kratos", "mercurydpm", "pfc", "demengine"} <= set(EXPORT_FORMATS)
    assert export(pack, tmp_path / "a.mdpa") == [tmp_path / "a.mdpa"]
    assert export(pack, tmp_path / "a.p3dat") == [tmp_path / "a.p3dat"]
    # .data stays LAMMPS' and .csv granpack's tables: MercuryDPM and DEM-Engine are named
    assert export(pack, tmp_path / "b.data", "mercurydpm") == [tmp_path / "b.data"]
    assert export(pack, tmp_path / "c.csv", "demengine") == [
        tmp_path / "c.csv",
        templates_path(tmp_path / "c.csv"),
    ]
    assert (tmp_path / "c.templates.csv").exists()
    assert export(pack, tmp_path / "l.data")[0].read_text().startswith("LAMMPS data file")


def test_command_line_exports_and_analyses_a_model_part(tmp_path, capsys):
    pack = gp.generate(small_scene(3).fast())
    src = pack.save(tmp_path / "pack.npz")
    for fmt in ("kratos", "mercurydpm", "pfc", "demengine"):
        assert main(["export", str(src), "--format", fmt, "-q"]) == 0
    suffix = {k: EXPORT_FORMATS[k] for k in ("kratos", "mercurydpm", "pfc", "demengine")}
    for s in suffix.values():
        assert (tmp_path / f"pack{s}").exists()
    capsys.readouterr()
    assert main(["analyze", str(tmp_path / "pack.mdpa"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["format"] == "kratos"
    assert out["container_source"] == "file"
