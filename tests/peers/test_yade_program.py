"""granpack's YADE export runs in YADE itself, and YADE's own collider finds granpack's
contacts.

The export (``granpack.export(pack, path, "yade")``) is read by ``ymport.text`` in
a YADE script run as ``yade -n -x script.py ...``; one ``O.step()`` with the
InsertionSortCollider and ``Ig2_Sphere_Sphere_ScGeom`` makes YADE's interactions, and
``O.interactions.countReal()`` counts them. A periodic pack runs in a periodic YADE cell
(``O.periodic``, ``O.cell.setBox``), so YADE counts the pairs across the seam too.

Pairs that just touch are counted alike on both sides: YADE's detection factor
(``aabbEnlargeFactor``, ``interactionDetectionFactor``) is 1 + `TOL`, and granpack's side
is its contacts plus the pairs its own search finds within the same (1 + TOL)(r_i + r_j).

The program is the Debian package ``yade`` (2023.02a); ``.ci/run`` installs it. The
packs: the paper's 4.3 with the fast settings (about 8 000 spheres in a box, particle-
particle contacts only), a periodic 4.3 of lower height, and a small periodic 2D pack
(discs as spheres at z = 0)."""

from __future__ import annotations

import json
import os
import subprocess

import numpy as np
import pytest
from scenes import small_scene

import granpack as gp
from granpack import _core
from granpack.io import export

#: Pairs within TOL (r_i + r_j) of touching count as touching, in YADE and in granpack.
TOL = 1e-9

SCRIPT = """\
import json
import sys

from yade import ymport

path, out, periodic, lx, ly, lz, factor = sys.argv[1:8]
factor = float(factor)
if periodic == "1":
    O.periodic = True
    O.cell.setBox(float(lx), float(ly), float(lz))
O.bodies.append(ymport.text(path))
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(aabbEnlargeFactor=factor)], verletDist=0),
    InteractionLoop(
        [Ig2_Sphere_Sphere_ScGeom(interactionDetectionFactor=factor)],
        [Ip2_FrictMat_FrictMat_FrictPhys()],
        [Law2_ScGeom_FrictPhys_CundallStrack()],
    ),
]
O.dt = 1e-12
O.step()
pairs = [[I.id1, I.id2, I.geom.penetrationDepth] for I in O.interactions if I.isReal]
count = O.interactions.countReal()
print("YADE real interactions:", count)
with open(out, "w") as f:
    json.dump(
        {
            "count": count,
            "pairs": pairs,
            "positions": [list(b.state.pos) for b in O.bodies],
            "radii": [b.shape.radius for b in O.bodies],
        },
        f,
    )
"""


def pack_43_periodic() -> gp.Pack:
    scene = gp.PackScene.preset("4.3").replace(container="periodic", height=0.2)
    return gp.generate(scene.fast())


def pack_2d_periodic() -> gp.Pack:
    return gp.generate(small_scene(2, container="periodic"))


# "4.3" is the session's example_4_3 (tests/conftest.py), shared with the other peer checks
PACKS = {"4.3": None, "4.3-periodic": pack_43_periodic, "2d-periodic": pack_2d_periodic}


def run_yade(yade: str, pack: gp.Pack, folder) -> dict:
    """YADE's interactions, positions and radii of granpack's YADE export of `pack`."""
    data = export(pack, folder / "pack.txt", "yade")[0]
    script = folder / "count.py"
    script.write_text(SCRIPT)
    out = folder / "yade.json"
    periodic = pack.scene.container == "periodic"
    r_max = float(np.max(pack.radii))
    lengths = [4.0 * (pack.height + 4.0 * r_max)] * 3  # no image along the other axes
    lengths[: pack.dim - 1] = pack.scene.base
    env = {k: v for k, v in os.environ.items() if k != "VIRTUAL_ENV"}
    env["OMP_NUM_THREADS"] = "1"
    cmd = [yade, "-n", "-x", str(script), str(data), str(out), "1" if periodic else "0"]
    cmd += [repr(float(v)) for v in lengths] + [repr(1.0 + TOL)]
    res = subprocess.run(cmd, cwd=folder, env=env, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0 and out.exists(), res.stdout[-3000:] + res.stderr[-3000:]
    assert "YADE real interactions:" in res.stdout
    return json.loads(out.read_text())


def granpack_pairs(pack: gp.Pack) -> tuple[set, set]:
    """The pack's particle-particle contacts, and those with the pairs within TOL of
    touching added (granpack's own search with the radii times 1 + TOL)."""
    pairs = pack.contacts.particle_pairs()
    listed = {(int(min(a, b)), int(max(a, b))) for a, b in zip(pairs.i, pairs.j, strict=True)}
    lo, hi = pack.box
    periodic = [pack.scene.container == "periodic"] * (pack.dim - 1)
    found = _core.find_contacts(
        pack.positions,
        pack.radii * (1.0 + TOL),
        walls=(lo.tolist(), hi.tolist()),
        periodic=periodic,
    )
    i, j = np.asarray(found["i"]), np.asarray(found["j"])
    near = {(int(min(a, b)), int(max(a, b))) for a, b in zip(i, j, strict=True) if b >= 0}
    return listed, listed | near


@pytest.fixture(scope="module", params=list(PACKS))
def case(request, yade, tmp_path_factory) -> tuple[gp.Pack, dict]:
    # (the yade fixture comes first: without YADE nothing is generated)
    make = PACKS[request.param]
    pack = request.getfixturevalue("example_4_3") if make is None else make()
    return pack, run_yade(yade, pack, tmp_path_factory.mktemp(request.param))


def test_yade_reads_the_same_positions_and_radii(case):
    pack, got = case
    x = np.zeros((len(pack), 3))
    x[:, : pack.dim] = pack.positions
    np.testing.assert_array_equal(np.array(got["positions"]), x)
    np.testing.assert_array_equal(np.array(got["radii"]), pack.radii)


def test_yade_counts_the_contacts_granpack_lists(case):
    pack, got = case
    listed, within_tol = granpack_pairs(pack)
    yade_pairs = {(min(a, b), max(a, b)) for a, b, _ in got["pairs"]}
    assert got["count"] == len(got["pairs"]) == len(yade_pairs)
    # the same pairs, with the same tolerance on both sides
    assert yade_pairs == within_tol
    assert got["count"] == len(within_tol)
    # every contact granpack lists is one of YADE's, at the same overlap
    assert listed <= yade_pairs
    depth = {(min(a, b), max(a, b)): d for a, b, d in got["pairs"]}
    overlap = {
        (int(min(a, b)), int(max(a, b))): o
        for a, b, o in zip(
            pack.contacts.particle_pairs().i,
            pack.contacts.particle_pairs().j,
            pack.contacts.particle_pairs().overlap,
            strict=True,
        )
    }
    r_min = float(np.min(pack.radii))
    for key, o in overlap.items():
        assert depth[key] == pytest.approx(o, abs=1e-12 * r_min)
    # what YADE adds to granpack's list only touches within the tolerance
    r = pack.radii
    for a, b in yade_pairs - listed:
        assert depth[(a, b)] > -TOL * (r[a] + r[b]) * (1 + 1e-6)
    if pack.scene.container == "periodic":  # YADE counts across the seam
        base = np.array(pack.scene.base)
        d = pack.dim
        dx = np.array([pack.positions[b, : d - 1] - pack.positions[a, : d - 1] for a, b in listed])
        assert np.any(np.abs(dx) > base / 2)
