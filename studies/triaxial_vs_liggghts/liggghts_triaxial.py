"""A drained triaxial compression of a granpack consolidated pack in LIGGGHTS 3.8.0.

The sample is the pack `granpack.consolidate` left: its spheres (exported by
`granpack.io.export(..., "liggghts")`, without their velocities: the test starts from rest),
between the box walls where the consolidation left them (floor z = 0, side walls at x = 0,
bx and y = 0, by with (bx, by) = ``pack.scene.base``, lid at z = H0 = ``pack.height``).

- **Lid**: a square STL mesh under ``fix mesh/surface/stress`` (its total force is
  ``f_lid[1..3]``, its reference point, which moves with it, ``f_lid[7..9]``), driven by
  ``fix move/mesh mesh lid linear 0 0 -v``: granpack's constant lid speed v = eps_dot H0.
- **Side walls**: four vertical STL meshes, each under ``fix mesh/surface/stress/servo``
  (``ctrlPV force``, ``axis`` into the sample, ``vel_max``, ``kp``): a velocity law
  v = vel_max kp (F* - F) / F* every step. Each wall's target F* is an equal-style variable
  (``target_val v_name``, which LIGGGHTS 3.8.0 evaluates every step): sigma_3 times the
  wall's current area, its width between the other pair of walls (their ``f_ID[7]`` or
  ``f_ID[8]``) times the lid's height, so sigma_3 is held while the lid comes down and the
  sample bulges, with no loop in the input script.
- **Floor**: a fixed ``primitive zplane 0``.
- **Contacts**: `pair_style gran model hertz tangential history` with granpack's Young's
  modulus, Poisson's ratio and friction, and the restitution that gives granpack's damping
  ratio (`liggghts_restitution`); the walls are atom type 2, of the same elastic material
  (granpack's walls are), with friction 0 against the spheres (``coefficientFriction
  peratomtypepair 2 mu 0 0 0``): granpack's ``wall_friction=0``.
- **Damping**: contact damping only. LIGGGHTS has no local non-viscous damping (granpack's
  ``local_damping``, 0.4 by default): the like-for-like granpack run is
  ``gp.triaxial(..., local_damping=0.0)``.
- **Start**: the pack holds no tangential springs, so both codes first re-seat the sample:
  granpack servo-controls every wall to the consolidation's targets until equilibrium; here
  the lid stays where it is while the side walls hold sigma_3 for `reseat_steps` steps (the
  steps granpack's re-seat took). The test's table starts after that.

One thermo row every check (step, the lid's force and height, each side wall's force,
position and target): `triaxial_table` turns them into granpack's element table (eps_a,
eps_v, sigma_1, sigma_3, p, q, eta, e, phi; compression positive; element.md's
definitions), and `loop_seconds` gives LIGGGHTS' own "Loop time" of the loading run.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import polars as pl

#: The side walls: fix ID, the axis pointing into the sample, the coordinate they move on.
SIDES = (
    ("wx0", (1.0, 0.0, 0.0), 0),
    ("wx1", (-1.0, 0.0, 0.0), 0),
    ("wy0", (0.0, 1.0, 0.0), 1),
    ("wy1", (0.0, -1.0, 0.0), 1),
)

THERMO = (
    "step",
    "lid_force",
    "lid_z",
    "f_wx0",
    "f_wx1",
    "f_wy0",
    "f_wy1",
    "x_lo",
    "x_hi",
    "y_lo",
    "y_hi",
    "target_x",
    "target_y",
    "ke",
)


def liggghts_restitution(xi: float) -> float:
    """The restitution e that gives LIGGGHTS' `gran model hertz` granpack's damping ratio xi:
    LIGGGHTS damps with -sqrt(5/6) beta, beta = ln e / sqrt(ln^2 e + pi^2), so
    e = exp(pi b / sqrt(1 - b^2)) with b = -xi / sqrt(5/6) (0.70735 for xi = 0.1)."""
    b = -xi / math.sqrt(5.0 / 6.0)
    return math.exp(math.pi * b / math.sqrt(1.0 - b * b))


@dataclass
class Setup:
    """What the LIGGGHTS run takes from granpack's pack and triaxial settings (SI units)."""

    dt: float  # s, granpack's triaxial dt
    lid_speed: float  # m/s, granpack's v = eps_dot H0
    steps: int  # loading steps (granpack's)
    check_every: int  # steps between thermo rows
    confining: float  # Pa, sigma_3
    reseat_steps: int  # steps with the lid fixed before the loading
    wall_vel_max: float  # m/s, the side servos' cap (granpack's max_wall_speed)
    lid_stress: float  # Pa, the consolidation's lid target (the re-seat's)
    lid_vel_max: float  # m/s, the lid servo's cap in the re-seat (the consolidation's)
    gain: float = 0.5  # granpack's servo gain, turned into LIGGGHTS' kp (`servo_kp`)
    gravity: bool = False
    kp: float = field(default=math.nan)  # the side walls' kp, set by `write_input`
    lid_kp: float = field(default=math.nan)  # the re-seat lid's kp, set by `write_input`


def hertz_wall_stiffness(pack, force: float, contacts: int) -> float:
    """The summed normal stiffness (N/m) of `contacts` sphere-wall Hertz contacts sharing
    `force` (N): each contact's F = 4/3 E* sqrt(r) d^1.5, k = 2 E* sqrt(r d), with
    E* = E / (2 (1 - nu^2)) (the wall of the spheres' material) and r the mean radius."""
    m = pack.scene.material
    e_star = m.young / (2.0 * (1.0 - m.poisson**2))
    r = float(np.mean(pack.radii))
    f = force / max(contacts, 1)
    d = (3.0 * f / (4.0 * e_star * math.sqrt(r))) ** (2.0 / 3.0)
    return contacts * 2.0 * e_star * math.sqrt(r * d)


def servo_kp(pack, setup: Setup, wall: str) -> float:
    """LIGGGHTS' kp that gives `wall` ("side" or "lid") granpack's servo response: granpack
    moves a wall by gain (F - F*) / K per step (K its contacts' summed stiffness),
    LIGGGHTS by dt vel_max kp (F - F*) / F*, so kp = gain F* / (K vel_max dt), with F* and
    K those of the consolidated sample (a side wall's mean force and contact count, or the
    lid's)."""
    rep = pack.record("consolidate").report
    bx, by = (float(b) for b in pack.scene.base)
    h0 = float(pack.height)
    if wall == "lid":
        force = setup.lid_stress * bx * by
        contacts = int(rep["wall_contacts"]["lid"])
        v_max = setup.lid_vel_max
    else:
        force = setup.confining * 0.5 * (bx + by) * h0
        names = [n for n in rep["wall_contacts"] if n not in ("floor", "lid")]
        contacts = round(float(np.mean([rep["wall_contacts"][n] for n in names])))
        v_max = setup.wall_vel_max
    k = hertz_wall_stiffness(pack, force, contacts)
    return setup.gain * force / (k * v_max * setup.dt)


def rectangle_stl(path: Path, corners) -> None:
    """An STL of the rectangle with corners a, b, c, d (in order), two triangles."""
    a, b, c, d = corners
    lines = ["solid wall"]
    for tri in ((a, b, c), (a, c, d)):
        u = np.subtract(tri[1], tri[0])
        v = np.subtract(tri[2], tri[0])
        n = np.cross(u, v)
        n = n / np.linalg.norm(n)
        lines += [f"  facet normal {n[0]!r} {n[1]!r} {n[2]!r}", "    outer loop"]
        lines += [f"      vertex {p[0]!r} {p[1]!r} {p[2]!r}" for p in tri]
        lines += ["    endloop", "  endfacet"]
    lines.append("endsolid wall")
    path.write_text("\n".join(lines) + "\n")


INPUT = """\
# drained triaxial compression of a granpack consolidated pack: the lid at constant speed,
# the four side walls servo-held at sigma_3, the floor fixed, frictionless walls
units           si
atom_style      granular
atom_modify     map array
boundary        f f f
newton          off
communicate     single vel yes
read_data       {data}
neighbor        {skin} bin
neigh_modify    delay 0
# type 1 the spheres, type 2 the walls (the same elastic material, no friction with spheres)
fix             m1 all property/global youngsModulus peratomtype {young} {young}
fix             m2 all property/global poissonsRatio peratomtype {poisson} {poisson}
fix             m3 all property/global coefficientRestitution peratomtypepair 2 &
                {restitution} {restitution} {restitution} {restitution}
fix             m4 all property/global coefficientFriction peratomtypepair 2 &
                {friction} 0.0 0.0 0.0
pair_style      gran model hertz tangential history limitForce on
pair_coeff      * *
timestep        {dt}
{gravity}
fix             floor all wall/gran model hertz tangential history primitive type 2 zplane 0.0
# the re-seat: the lid servo-held at the consolidation's lid stress, as every wall is in
# granpack's re-seat (its target the stress times the current cross-section)
fix             lid all mesh/surface/stress/servo file lid.stl type 2 com {cx} {cy} {h0} &
                ctrlPV force axis 0.0 0.0 -1.0 target_val v_target_z vel_max {lid_vmax} &
                kp {lid_kp}
# each side wall's target force: sigma_3 times its current area (width between the other
# pair of walls, height the lid's); LIGGGHTS evaluates target_val v_... every step
variable        lidz equal f_lid[9]
variable        target_x equal {sigma3}*(f_wy1[8]-f_wy0[8])*v_lidz
variable        target_y equal {sigma3}*(f_wx1[7]-f_wx0[7])*v_lidz
variable        target_z equal {sigma_lid}*(f_wx1[7]-f_wx0[7])*(f_wy1[8]-f_wy0[8])
{sides}
fix             walls all wall/gran model hertz tangential history mesh n_meshes 5 &
                meshes lid wx0 wx1 wy0 wy1
fix             integrate all nve/sphere
thermo_style    custom step f_lid[3] v_lidz f_wx0[1] f_wx1[1] f_wy0[2] f_wy1[2] &
                f_wx0[7] f_wx1[7] f_wy0[8] f_wy1[8] v_target_x v_target_y ke
thermo_modify   norm no lost error
thermo          {reseat_thermo}
run             {reseat_steps}
# the loading: the lid, where the re-seat left it, down at constant speed (a servo mesh
# cannot be moved by fix move/mesh: the lid is made again as a plain stress mesh; the
# walls are frictionless, so no tangential history is lost with the wall fix)
variable        h1 equal $(f_lid[9])
variable        dz equal $(f_lid[9]-{h0})
unfix           walls
unfix           lid
fix             lid all mesh/surface/stress file lid.stl type 2 move 0.0 0.0 ${{dz}} &
                reference_point {cx} {cy} ${{h1}}
fix             walls all wall/gran model hertz tangential history mesh n_meshes 5 &
                meshes lid wx0 wx1 wy0 wy1
fix             drive all move/mesh mesh lid linear 0.0 0.0 {minus_v}
thermo          {check}
run             {steps}
"""

SIDE = (
    "fix             {name} all mesh/surface/stress/servo file {name}.stl type 2 "
    "com {com} ctrlPV force axis {axis} target_val v_target_{xy} vel_max {vmax} kp {kp}"
)


def write_input(pack, folder: Path, setup: Setup) -> Path:
    """Writes ``pack.data``, the five wall meshes and ``in.triaxial`` into `folder` (made
    afresh); returns the input's path. Sets `setup.kp`."""
    import granpack.io as gio

    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    bx, by = (float(b) for b in pack.scene.base)
    h0 = float(pack.height)
    r_max = float(np.max(pack.radii))
    r_min = float(np.min(pack.radii))
    # the meshes reach a margin past the sample: the side walls move out as the sample
    # bulges (by 9 % of the width for eps_a = 0.25 at eps_v = -0.05), and a side wall must
    # still span the gap between the other pair; the domain reaches past the meshes, as a
    # fixed boundary deletes no mesh element
    m = 0.2 * max(bx, by) + 2.0 * r_max
    box = m + 2.0 * r_max
    data = gio.export(pack, folder / "pack.data", "liggghts")[0]
    (folder / "in.granpack").unlink(missing_ok=True)
    text = data.read_text()
    cut = text.find("\nVelocities")  # the test starts from rest
    if cut >= 0:
        text = text[: cut + 1]
    text = text.replace("1 atom types", "2 atom types")
    lines = text.splitlines()
    for k, line in enumerate(lines):
        parts = line.split()
        if parts[2:] in (["xlo", "xhi"], ["ylo", "yhi"], ["zlo", "zhi"]):
            hi = {"x": bx, "y": by, "z": h0}[parts[2][0]]
            lines[k] = f"{-box!r} {hi + box!r} {parts[2]} {parts[3]}"
    data.write_text("\n".join(lines) + "\n")
    # the lid faces down, each side wall into the sample (LIGGGHTS' meshes are two-sided:
    # the normals only orient the files)
    rectangle_stl(
        folder / "lid.stl", [(-m, -m, h0), (-m, by + m, h0), (bx + m, by + m, h0), (bx + m, -m, h0)]
    )
    z0, z1 = -m, h0 + m
    walls = {
        "wx0": [(0.0, -m, z0), (0.0, by + m, z0), (0.0, by + m, z1), (0.0, -m, z1)],
        "wx1": [(bx, -m, z0), (bx, -m, z1), (bx, by + m, z1), (bx, by + m, z0)],
        "wy0": [(-m, 0.0, z0), (-m, 0.0, z1), (bx + m, 0.0, z1), (bx + m, 0.0, z0)],
        "wy1": [(-m, by, z0), (bx + m, by, z0), (bx + m, by, z1), (-m, by, z1)],
    }
    for name, corners in walls.items():
        rectangle_stl(folder / f"{name}.stl", corners)
    setup.kp = servo_kp(pack, setup, "side")
    setup.lid_kp = servo_kp(pack, setup, "lid")
    coms = {
        "wx0": (0.0, by / 2, h0 / 2),
        "wx1": (bx, by / 2, h0 / 2),
        "wy0": (bx / 2, 0.0, h0 / 2),
        "wy1": (bx / 2, by, h0 / 2),
    }
    sides = "\n".join(
        SIDE.format(
            name=name,
            com=" ".join(repr(c) for c in coms[name]),
            axis=" ".join(repr(a) for a in axis),
            xy="xy"[coord],
            vmax=repr(setup.wall_vel_max),
            kp=repr(setup.kp),
        )
        for name, axis, coord in SIDES
    )
    mat = pack.scene.material
    grav = (
        f"fix             gravi all gravity {float(pack.scene.gravity)!r} vector 0.0 0.0 -1.0"
        if setup.gravity
        else "# no gravity (as in the consolidation)"
    )
    text = INPUT.format(
        data=data.name,
        skin=0.2 * r_min,
        young=float(mat.young),
        poisson=float(mat.poisson),
        restitution=liggghts_restitution(float(mat.damping)),
        friction=float(mat.friction),
        dt=repr(setup.dt),
        gravity=grav,
        cx=bx / 2,
        cy=by / 2,
        h0=repr(h0),
        sigma3=repr(setup.confining),
        sigma_lid=repr(setup.lid_stress),
        lid_vmax=repr(setup.lid_vel_max),
        lid_kp=repr(setup.lid_kp),
        sides=sides,
        reseat_thermo=max(setup.reseat_steps, 1),
        reseat_steps=setup.reseat_steps,
        minus_v=repr(-setup.lid_speed),
        check=setup.check_every,
        steps=setup.steps,
    )
    path = folder / "in.triaxial"
    path.write_text(text)
    return path


def parse_log(path: Path) -> tuple[list[list[list[float]]], list[float], list[float]]:
    """Per run of the log: its thermo rows, its loop time (s) and its output time (s)."""
    runs: list[list[list[float]]] = []
    loops: list[float] = []
    outputs: list[float] = []
    header = None
    for line in path.read_text().splitlines():
        parts = line.split()
        if parts[:1] == ["Step"]:
            header = parts
            runs.append([])
            continue
        if line.startswith("Loop time of"):
            loops.append(float(parts[3]))
            header = None
            continue
        if line.startswith("Outpt time") or line.startswith("Output"):
            outputs.append(float(parts[-4]) if "|" in line else float(parts[4]))
            continue
        if header and len(parts) == len(header):
            try:
                runs[-1].append([float(p) for p in parts])
            except ValueError:
                header = None
    return runs, loops, outputs


def triaxial_table(rows: list[list[float]], pack, dt: float) -> pl.DataFrame:
    """The loading run's thermo rows as granpack's element table (SI, compression
    positive): step and time since the loading began, eps_a = (H0 - H) / H0, eps_v =
    (V0 - V) / V0 with V the box between the walls, sigma_1 the lid's force over the
    current cross-section, sigma_3 the mean of the side walls' force over their current
    areas, p = (s1 + 2 s3) / 3, q = s1 - s3, eta, e and phi; fabric_dev NaN (not
    measured here). Also the lateral targets' stresses (target_sigma_3)."""
    a = np.asarray(rows, dtype=np.float64)
    col = {name: a[:, k] for k, name in enumerate(THERMO)}
    solid = float(np.sum(4.0 / 3.0 * np.pi * pack.radii**3))
    h = col["lid_z"]
    wx = col["x_hi"] - col["x_lo"]
    wy = col["y_hi"] - col["y_lo"]
    vol = wx * wy * h
    s1 = col["lid_force"] / (wx * wy)
    s_x = (np.abs(col["f_wx0"]) + np.abs(col["f_wx1"])) / 2.0 / (wy * h)
    s_y = (np.abs(col["f_wy0"]) + np.abs(col["f_wy1"])) / 2.0 / (wx * h)
    s3 = (s_x + s_y) / 2.0
    p = (s1 + 2.0 * s3) / 3.0
    q = s1 - s3
    phi = solid / vol
    step = (col["step"] - col["step"][0]).astype(np.int64)
    return pl.DataFrame(
        {
            "step": step,
            "time": step * dt,
            "eps_a": (h[0] - h) / h[0],
            "eps_v": (vol[0] - vol) / vol[0],
            "sigma_1": s1,
            "sigma_3": s3,
            "p": p,
            "q": q,
            # a run's first row, from its setup, may have no wall force yet
            "eta": np.divide(q, p, out=np.full_like(q, np.nan), where=p > 0),
            "e": 1.0 / phi - 1.0,
            "phi": phi,
            "sigma_x": s_x,
            "sigma_y": s_y,
            "target_sigma_3": col["target_x"] / (wy * h),
            "fabric_dev": np.full(len(step), np.nan),
            "kinetic_energy": col["ke"],
        }
    )


def run(pack, folder: Path, setup: Setup, program: str = "liggghts") -> dict:
    """Writes the input into `folder`, runs LIGGGHTS on one process (serial, one OpenMP
    thread), and returns the loading run's table (`triaxial_table`), the re-seat's last
    table row, LIGGGHTS' loop times (re-seat, loading) and output time of the loading,
    and the process's own wall time."""
    if shutil.which(program) is None:
        raise RuntimeError(f"{program} is not installed")
    write_input(pack, folder, setup)
    cmd = [program, "-in", "in.triaxial", "-log", "log.liggghts"]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    t0 = time.perf_counter()
    with (folder / "screen.txt").open("w") as screen:
        proc = subprocess.run(cmd, cwd=folder, env=env, stdout=screen, stderr=subprocess.STDOUT)
    process_seconds = time.perf_counter() - t0
    if proc.returncode != 0:
        tail = (folder / "screen.txt").read_text()[-3000:]
        raise RuntimeError(f"{program} failed (exit {proc.returncode}):\n{tail}")
    runs, loops, outputs = parse_log(folder / "log.liggghts")
    if len(runs) != 2 or len(loops) != 2:
        raise RuntimeError(f"expected two runs in {folder / 'log.liggghts'}, found {len(runs)}")
    reseat = triaxial_table(runs[0], pack, setup.dt)
    # a run's first thermo row comes from its setup, in which a mesh's force is counted
    # twice: the loading starts from the re-seat's last row (the same state)
    loading = [runs[0][-1], *runs[1][1:]]
    return {
        "table": triaxial_table(loading, pack, setup.dt),
        "reseat": reseat,
        "reseat_loop_seconds": loops[0],
        "loop_seconds": loops[1],
        "output_seconds": outputs[1] if len(outputs) > 1 else None,
        "process_seconds": process_seconds,
        "kp": setup.kp,
        "lid_kp": setup.lid_kp,
    }
