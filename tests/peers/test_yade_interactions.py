"""YADE's own list of interactions reads in granpack as YADE counts it.

A small layer of spheres falls onto YADE's floor (Hertz-Mindlin, as the paper's 4.3) and
the script stops mid-run: YADE's list then holds interactions whose spheres have parted
in the last step, at zero force, until its collider's next pass. granpack reads the
spheres (``export.textExt``'s ``id_x_y_z_r_matId``, at %g and at full precision) and the
interactions (a plain table), and counts what YADE counts: N_c and Z.

The program is the Debian package ``yade`` (2023.02a); ``.ci/run`` installs it."""

from __future__ import annotations

import json
import os
import subprocess

import numpy as np
import pytest

import granpack as gp

SCRIPT = """\
import json, math
from yade import export, pack, utils

r = 0.02
mat = O.materials.append(
    FrictMat(young=1e8, poisson=0.25, frictionAngle=math.atan(0.2), density=1000)
)
for pos, ax in ((0, 0), (0.3, 0), (0, 1), (0.3, 1), (0, 2)):
    O.bodies.append(utils.wall(pos, axis=ax, material=mat))
sp = pack.SpherePack()
sp.makeCloud((0, 0, 0), (0.3, 0.3, 0.25), rMean=r, rRelFuzz=0, num=300, seed=7)
sp.toSimulation(material=mat)
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()]),
    InteractionLoop(
        [Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()],
        [Ip2_FrictMat_FrictMat_MindlinPhys(betan=0.1, betas=0.1)],
        [Law2_ScGeom_MindlinPhys_Mindlin()],
    ),
    NewtonIntegrator(gravity=(0, 0, -2.0), damping=0.0),
]
O.dt = 1e-4
O.run(3000, True)
spheres = [b for b in O.bodies if isinstance(b.shape, Sphere)]
ids = set(b.id for b in spheres)
export.textExt("spheres_g.txt", "id_x_y_z_r_matId")
with open("spheres_p.txt", "w") as f:
    f.write("#format id_x_y_z_r_matId\\n")
    for b in spheres:
        p = b.state.pos
        f.write("%d %.17g %.17g %.17g %.17g 0\\n" % (b.id, p[0], p[1], p[2], b.shape.radius))
n_c = idle = 0
with open("interactions.txt", "w") as f:
    f.write("# id1 id2 normalForce shearForce (on id2)\\n")
    for I in O.interactions:
        if I.isReal and I.id1 in ids and I.id2 in ids:
            fn, fs = I.phys.normalForce, I.phys.shearForce
            n_c += 1
            idle += int(fn.norm() == 0 and fs.norm() == 0)
            f.write("%d %d %.17g %.17g %.17g %.17g %.17g %.17g\\n" % (I.id1, I.id2, *fn, *fs))
json.dump({"N_p": len(spheres), "N_c": n_c, "idle": idle}, open("yade.json", "w"))
"""

COLUMNS = "id2 id1 fnx fny fnz ftx fty ftz"  # YADE's forces act on id2


@pytest.fixture(scope="module")
def yade_run(yade, tmp_path_factory):
    folder = tmp_path_factory.mktemp("yade")
    (folder / "layer.py").write_text(SCRIPT)
    env = {k: v for k, v in os.environ.items() if k != "VIRTUAL_ENV"}
    env["OMP_NUM_THREADS"] = "1"
    res = subprocess.run(
        [yade, "-n", "-j1", "-x", "layer.py"],
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    out = folder / "yade.json"
    assert res.returncode == 0 and out.exists(), res.stdout[-3000:] + res.stderr[-3000:]
    return folder, json.loads(out.read_text())


@pytest.mark.parametrize("precision", ["p", "g"])
def test_yade_s_interactions_read_with_yade_s_n_c_and_z(yade_run, precision):
    folder, got = yade_run
    p = gp.read_particles(folder / f"spheres_{precision}.txt")
    assert len(p) == got["N_p"] and p.digits == (17 if precision == "p" else 6)
    c = gp.read_contacts(folder / "interactions.txt", p, columns=COLUMNS)
    assert len(c) == got["N_c"] > 0
    q = p.with_contacts(c)
    assert 2 * len(q.contacts.particle_pairs()) / len(q) == 2 * got["N_c"] / got["N_p"]
    # YADE's forces taken on the right body: repulsive, but for damping's few
    fn = c.contacts.force_normal
    assert np.sum(fn > 0) >= 0.95 * (got["N_c"] - got["idle"])
    # the pairs at zero force are YADE's, and counted
    assert int(np.sum(~c.carries_force)) == got["idle"]


def test_yade_s_list_with_a_pair_moved_apart_is_refused(yade_run, tmp_path):
    folder, _ = yade_run
    rows = (folder / "interactions.txt").read_text().splitlines()
    first = rows[1].split()
    # the first interaction's ids swapped for a pair of spheres far apart
    p = gp.read_particles(folder / "spheres_p.txt")
    far = int(np.argmax(np.linalg.norm(p.positions - p.positions[0], axis=1)))
    first[0], first[1] = str(int(p.ids[0])), str(int(p.ids[far]))
    (tmp_path / "moved.txt").write_text("\n".join([rows[0], " ".join(first), *rows[2:]]) + "\n")
    with pytest.raises(gp.FileFormatError, match=r"moved.txt:2: .*do not touch"):
        gp.read_contacts(tmp_path / "moved.txt", p, columns=COLUMNS)


def test_the_command_line_analyses_yade_s_spheres_with_its_interactions(yade_run, capsys):
    from granpack.cli import main

    folder, got = yade_run
    code = main(
        [
            "analyze",
            str(folder / "spheres_p.txt"),
            "--contacts",
            str(folder / "interactions.txt"),
            "--contact-columns",
            COLUMNS,
            "--json",
        ]
    )
    out = capsys.readouterr().out
    assert code == 0, out
    z = json.loads(out[out.index("{") :])["z"]
    assert z == pytest.approx(2 * got["N_c"] / got["N_p"], rel=1e-12)
