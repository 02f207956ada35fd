"""Oedometric consolidation of one granpack pack in granpack, YADE and LIGGGHTS, side by side.

The same example-4.3 pack (a granpack deposit, exported) is loaded by a lid to a target
vertical stress (default 100 kPa) with the side walls and the floor fixed and gravity off,
until two conditions hold together for `--hold` consecutive checks (one check every
`--check-every` steps):

- the lid's stress (its force over the box's cross-section) is within `--stress-tol` of
  the target, relative;
- the unbalanced-force ratio is at most `--unbalanced-tol`: YADE's `unbalancedForce()`,
  the mean over particles of |net force| over the mean over contacts (walls included) of
  |contact force|.

Each code uses the material of the pack's scene (density, Young's modulus, Poisson's
ratio, friction, damping ratio 0.1), Hertz-Mindlin contacts, one thread, and the same dt:
`--dt-factor` (0.8) times YADE's P-wave step min(r / sqrt(E / rho)).

- **YADE** (``yade``, run as ``yade -n -j1 -x``): `TriaxialStressController` drives the lid
  alone (stressMask on the vertical axis, every other wall deactivated, hence fixed);
  planes (`Wall`) for the six sides; `Law2_ScGeom_MindlinPhys_Mindlin` with
  ``betan = betas = 0.1``; `NewtonIntegrator(damping=0.4)`, YADE's local non-viscous
  damping for quasi-static loading. YADE's servo is a stiffness-based one: each step the lid
  moves by (F - F*) / K, K the summed normal stiffness of its contacts, capped by `max_vel`
  and then low-pass filtered (`stressDamping`), which lets the lid run at up to 3.75 times
  the cap.
- **LIGGGHTS** (``liggghts``): `fix mesh/surface/stress/servo` on a lid mesh written here as
  an STL, a PID velocity law v = vel_max kp (F* - F) / F*; `fix wall/gran` planes for the
  floor and the side walls; contact damping only (LIGGGHTS has no local non-viscous damping),
  with the restitution that gives granpack's damping ratio (0.70735, what granpack's own
  `in.granpack` writes). LIGGGHTS computes no unbalanced ratio: it dumps every contact force
  at every check and this script computes the ratio from them afterwards, so that run goes to
  a fixed step budget and the wall time to the tolerances is the measured time per step
  times the steps taken.
- **granpack**: `gp.consolidate(pack, mode="oedometric", ...)` where this checkout has it.

Both peers start from rest with the lid on the highest sphere. Besides the checks, each
history gives the mean stress on the four side walls (their normal force over w h) and the
lid's height h over the floor; K0 is that lateral stress over the lid's, and phi the
spheres' volume over A h. A plane's contact takes R* = r in all three codes (YADE's
``Ig2_Wall_Sphere_ScGeom(hertzian=True)``).

Each code writes ``<code>_history.csv`` (step, time, lid stress, stress error, unbalanced
ratio, ...) and ``<code>_summary.json`` into ``--out``; ``summary.md`` holds the table of all
codes run and ``manifest.json`` says where the numbers came from.

    python studies/consolidation_vs_peers/consolidation_peers.py    # the pack made here, all codes
    python studies/consolidation_vs_peers/consolidation_peers.py --pack pack.npz --codes yade

YADE puts its vertical axis on y (`TriaxialStressController`'s height is y): granpack's
(x, y, z) becomes YADE's (x, z, y), a mirror that spheres and planes do not notice.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from itertools import pairwise
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "_common"))
from manifest import write_manifest  # noqa: E402

DEFAULT_OUT = HERE
CODES = ("granpack", "yade", "liggghts")
HISTORY_FIELDS = (
    "step",
    "time",
    "lid_stress",
    "stress_error",
    "unbalanced",
    "unbalanced_max",
    "lateral_stress",
    "lid_height",
    "phi",
    "contacts",
)


def liggghts_restitution(xi: float) -> float:
    """The restitution e that gives LIGGGHTS' `gran model hertz` granpack's damping ratio xi:
    LIGGGHTS damps with -sqrt(5/6) beta, beta = ln e / sqrt(ln^2 e + pi^2), so
    e = exp(pi b / sqrt(1 - b^2)) with b = -xi / sqrt(5/6) (0.70735 for xi = 0.1, what
    granpack's own in.granpack writes)."""
    b = -xi / math.sqrt(5.0 / 6.0)
    return math.exp(math.pi * b / math.sqrt(1.0 - b * b))


# The YADE side runs inside YADE's own Python; its settings come in a JSON file named by an
# environment variable (yade's command line keeps its own options), its results go out in
# another JSON file.
YADE_SCRIPT = r"""
import json, math, os, time
import numpy as np
from yade import utils

cfg = json.load(open(os.environ["GP_CONSOLIDATION_CONFIG"]))
xyzr = np.loadtxt(cfg["spheres"], comments="#", ndmin=2)
lx, ly = cfg["base"]
mat = O.materials.append(FrictMat(young=cfg["young"], poisson=cfg["poisson"],
                                  density=cfg["density"], frictionAngle=math.atan(cfg["friction"])))
# granpack's z (up) is YADE's y: TriaxialStressController's "height" is always y
O.bodies.append([utils.sphere((x, z, y), r, material=mat) for x, y, z, r in xyzr])
top = float(np.max(xyzr[:, 2] + xyzr[:, 3]))  # the lid starts on the highest sphere
walls = {
    "left": utils.wall(0.0, axis=0, sense=1, material=mat),
    "right": utils.wall(lx, axis=0, sense=-1, material=mat),
    "bottom": utils.wall(0.0, axis=1, sense=1, material=mat),
    "top": utils.wall(top, axis=1, sense=-1, material=mat),
    "back": utils.wall(0.0, axis=2, sense=1, material=mat),
    "front": utils.wall(ly, axis=2, sense=-1, material=mat),
}
ids = {k: O.bodies.append(b) for k, b in walls.items()}
n = len(xyzr)
area = lx * ly
target = cfg["stress"]
triax = TriaxialStressController(
    internalCompaction=False,
    thickness=0.0,  # planes: the walls' faces are their positions
    stressMask=2,  # the vertical (y) axis by stress; the others by strain, but deactivated
    goal2=-target,  # YADE's stresses are negative in compression
    max_vel=cfg["max_vel"],
    wall_bottom_id=ids["bottom"], wall_top_id=ids["top"], wall_left_id=ids["left"],
    wall_right_id=ids["right"], wall_back_id=ids["back"], wall_front_id=ids["front"],
    # a deactivated wall has its velocity set to zero: the floor and the side walls are fixed
    wall_bottom_activated=False, wall_left_activated=False, wall_right_activated=False,
    wall_back_activated=False, wall_front_activated=False, wall_top_activated=True,
)
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()]),
    InteractionLoop(
        # hertzian: a plane's contact takes R* = r (the sphere's own radius), as in granpack,
        # instead of YADE's default R* = r / 2
        [Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom(hertzian=True)],
        [Ip2_FrictMat_FrictMat_MindlinPhys(betan=cfg["damping_ratio"], betas=cfg["damping_ratio"])],
        [Law2_ScGeom_MindlinPhys_Mindlin()],
    ),
    triax,
    NewtonIntegrator(damping=cfg["newton_damping"], gravity=(0, 0, 0)),
    PyRunner(iterPeriod=cfg["check_every"], command="check()"),
]
O.dt = cfg["dt_factor"] * utils.PWaveTimeStep()
rows, state = [], {"held": 0, "first": None, "held_step": None}
vol = float(np.sum(4.0 / 3.0 * math.pi * xyzr[:, 3] ** 3))


def check():
    # forces of this step, read after NewtonIntegrator and before the next ForceResetter
    f_lid = O.forces.f(ids["top"])[1]  # the spheres push the lid up (+y)
    h = O.bodies[ids["top"]].state.pos[1] - O.bodies[ids["bottom"]].state.pos[1]
    sigma = f_lid / area
    err = abs(sigma - target) / target
    unb = utils.unbalancedForce()
    lateral = (abs(O.forces.f(ids["left"])[0]) + abs(O.forces.f(ids["right"])[0])) / (ly * h)
    lateral += (abs(O.forces.f(ids["back"])[2]) + abs(O.forces.f(ids["front"])[2])) / (lx * h)
    print(O.iter, sigma, err, unb, flush=True)  # progress, for the log
    # PyRunner runs inside a step, before O.iter counts it: the forces read are those of
    # step O.iter + 1
    rows.append({
        "step": O.iter + 1, "time": O.time + O.dt, "lid_stress": sigma, "stress_error": err,
        "unbalanced": unb, "unbalanced_max": utils.unbalancedForce(True),
        "lateral_stress": lateral / 4.0, "lid_height": h, "phi": vol / (area * h),
        "contacts": O.interactions.countReal(),
    })
    ok = err <= cfg["stress_tol"] and unb <= cfg["unbalanced_tol"]
    if ok and state["first"] is None:
        state["first"] = O.iter + 1
    state["held"] = state["held"] + 1 if ok else 0
    if state["held"] >= cfg["hold"]:
        state["held_step"] = O.iter + 1
        O.pause()  # takes effect at the end of this step


wall0 = time.perf_counter()
O.run(cfg["max_steps"], True)
wall = time.perf_counter() - wall0
json.dump({
    "particles": n, "dt": O.dt, "steps": O.iter, "wall_seconds": wall,
    "first_step": state["first"], "held_step": state["held_step"],
    "history": rows,
}, open(cfg["result"], "w"))
"""

LIGGGHTS_INPUT = """\
# oedometric consolidation of a granpack pack: servo lid, fixed floor and side walls, no gravity
units           si
atom_style      granular
atom_modify     map array
boundary        f f f
newton          off
communicate     single vel yes
read_data       {data}
neighbor        {skin} bin
neigh_modify    delay 0
fix             m1 all property/global youngsModulus peratomtype {young}
fix             m2 all property/global poissonsRatio peratomtype {poisson}
fix             m3 all property/global coefficientRestitution peratomtypepair 1 {restitution}
fix             m4 all property/global coefficientFriction peratomtypepair 1 {friction}
pair_style      gran model hertz tangential history limitForce on
pair_coeff      * *
timestep        {dt}
fix             lid all mesh/surface/stress/servo file {stl} type 1 com {cx} {cy} {top} &
                ctrlPV force axis 0.0 0.0 -1.0 target_val {force} vel_max {vel_max} kp {kp}
fix             lidwall all wall/gran model hertz tangential history mesh n_meshes 1 meshes lid
fix             floor all {prim} zplane 0.0 store_force yes
fix             wx0 all {prim} xplane 0.0 store_force yes
fix             wx1 all {prim} xplane {lx} store_force yes
fix             wy0 all {prim} yplane 0.0 store_force yes
fix             wy1 all {prim} yplane {ly} store_force yes
fix             integrate all nve/sphere
# |net force| of every particle, averaged; the wall forces on the particles, summed per wall
variable        fmag atom sqrt(fx*fx+fy*fy+fz*fz)
compute         fmean all reduce ave v_fmag
compute         wx0 all reduce sum f_force_wx0[1]
compute         wx1 all reduce sum f_force_wx1[1]
compute         wy0 all reduce sum f_force_wy0[2]
compute         wy1 all reduce sum f_force_wy1[2]
compute         floor all reduce sum f_force_floor[3]
# the unbalanced ratio's denominator, the mean |contact force| over all contacts: a plane
# touches a sphere once at most, so the stored force of each primitive wall on a particle is
# one contact's force (summed and counted here); the particle pairs and the lid's contacts
# are local data, dumped and summed afterwards (compute wall/gran/local sees mesh walls only)
{wall_variables}
compute         wsum all reduce sum v_wsum v_wnum
compute         pp all pair/gran/local force
compute         pw all wall/gran/local force
dump            pp all local {check} {dump_dir}/pp.*.txt c_pp[1] c_pp[2] c_pp[3]
dump            pw all local {check} {dump_dir}/pw.*.txt c_pw[1] c_pw[2] c_pw[3]
thermo_style    custom step time f_lid[3] f_lid[9] c_fmean c_wx0 c_wx1 c_wy0 c_wy1 c_floor &
                c_wsum[1] c_wsum[2] atoms
thermo_modify   norm no lost error
thermo          {check}
run             {steps}
"""


def scene_material(pack) -> dict:
    m = pack.scene.material
    return {
        "density": float(m.density),
        "young": float(m.young),
        "poisson": float(m.poisson),
        "friction": float(m.friction),
        "damping_ratio": float(m.damping),
    }


def pwave_dt(pack, factor: float) -> float:
    """YADE's `PWaveTimeStep()`: min over spheres of r / sqrt(E / rho), times `factor`."""
    m = pack.scene.material
    return factor * float(np.min(pack.radii)) / math.sqrt(m.young / m.density)


def load_or_make_pack(args, work: Path):
    import granpack as gp

    if args.pack:
        pack = gp.load_pack(args.pack)
        print(f"pack: {args.pack} ({len(pack.radii)} particles)", flush=True)
        return pack
    scene = gp.PackScene.preset("4.3").replace(seed=args.seed)
    # the fast settings where this checkout has them: the pack the other benchmarks use
    if hasattr(scene, "fast"):
        scene = scene.fast()
    t0 = time.perf_counter()
    pack = gp.generate(scene)
    path = pack.save(work / "pack.npz")
    print(
        f"pack: preset 4.3 seed {args.seed}, {len(pack.radii)} particles, "
        f"{time.perf_counter() - t0:.1f} s; saved to {path} (reuse with --pack)",
        flush=True,
    )
    return pack


def convergence(rows: list[dict], stress_tol: float, unb_tol: float, hold: int):
    """The first check at which both tolerances hold, and the check at which they have held
    for `hold` checks in a row (None where never)."""
    first = held_at = None
    run = 0
    for row in rows:
        ok = row["stress_error"] <= stress_tol and row["unbalanced"] <= unb_tol
        if ok and first is None:
            first = row["step"]
        run = run + 1 if ok else 0
        if run >= hold and held_at is None:
            held_at = row["step"]
    return first, held_at


def write_history(out: Path, code: str, rows: list[dict]) -> Path:
    path = out / f"{code}_history.csv"
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=HISTORY_FIELDS, extrasaction="ignore")
        w.writeheader()
        for row in rows:
            w.writerow({k: row.get(k) for k in HISTORY_FIELDS})
    return path


def summarise(code: str, res: dict, args, extra: dict) -> dict:
    rows = res["history"]
    first, held = convergence(rows, args.stress_tol, args.unbalanced_tol, args.hold)
    steps = res["steps"]
    n = res["particles"]
    per_step = res["wall_seconds"] / steps if steps else float("nan")
    # the sample's state where the tolerances had held (the last check where they never did)
    at = next((r for r in rows if r["step"] == held), rows[-1] if rows else {})
    last = rows[-1] if rows else {}
    lid = at.get("lid_stress")
    lateral = at.get("lateral_stress")
    # the lid's fastest descent between two checks: its loading rate, which the sample's K0
    # and phi depend on
    speeds = [
        (a["lid_height"] - b["lid_height"]) / (b["time"] - a["time"])
        for a, b in pairwise(rows)
        if b["time"] > a["time"]
    ]
    summary = {
        "code": code,
        "particles": n,
        "dt": res["dt"],
        "check_every": args.check_every,
        "stress_target": args.stress,
        "stress_tol": args.stress_tol,
        "unbalanced_tol": args.unbalanced_tol,
        "hold": args.hold,
        "steps_to_tolerance": first,
        "time_to_tolerance": first * res["dt"] if first is not None else None,
        "steps_held": held,
        "time_held": held * res["dt"] if held is not None else None,
        "steps_run": steps,
        "wall_seconds_run": res["wall_seconds"],
        # the time to the held state: the run's own wall time where it stopped there, the
        # measured cost per step times the steps otherwise
        "wall_seconds_to_held": (
            None if held is None else (res["wall_seconds"] if held == steps else per_step * held)
        ),
        "ns_per_particle_step": per_step / n * 1e9 if n else None,
        "state_at_step": at.get("step"),
        "phi": at.get("phi"),
        "lid_stress": lid,
        "stress_error": at.get("stress_error"),
        "unbalanced": at.get("unbalanced"),
        "unbalanced_max": at.get("unbalanced_max"),
        "lateral_stress": lateral,
        "K0": lateral / lid if lateral is not None and lid else None,
        "contacts": at.get("contacts"),
        "lid_speed_max": max(speeds) if speeds else None,
        "unbalanced_last_check": last.get("unbalanced"),
        **extra,
        "history": rows,
    }
    return summary


def run_yade(pack, args, work: Path) -> dict:
    import granpack.io as gio

    if shutil.which("yade") is None:
        raise RuntimeError("yade is not installed")
    spheres = gio.export(pack, work / "spheres.txt", "yade")[0]
    ydir = work / "yade"
    ydir.mkdir(exist_ok=True)
    script = ydir / "consolidate.py"
    script.write_text(YADE_SCRIPT)
    cfg = {
        **scene_material(pack),
        "spheres": str(spheres),
        "base": [float(b) for b in pack.scene.base],
        "stress": args.stress,
        "stress_tol": args.stress_tol,
        "unbalanced_tol": args.unbalanced_tol,
        "hold": args.hold,
        "check_every": args.check_every,
        "max_steps": args.max_steps,
        "dt_factor": args.dt_factor,
        "newton_damping": args.yade_damping,
        "max_vel": args.yade_max_vel,
        "result": str(ydir / "result.json"),
    }
    (ydir / "config.json").write_text(json.dumps(cfg, indent=1))
    (ydir / "result.json").unlink(missing_ok=True)  # a result left by an earlier run
    env = {**os.environ, "GP_CONSOLIDATION_CONFIG": str(ydir / "config.json")}
    env["OMP_NUM_THREADS"] = "1"
    cmd = ["yade", "-n", "-j1", "-x", str(script)]
    print("yade:", " ".join(cmd), flush=True)
    t0 = time.perf_counter()
    with (ydir / "yade.log").open("w") as log:
        proc = subprocess.run(cmd, cwd=ydir, env=env, stdout=log, stderr=subprocess.STDOUT)
    if proc.returncode != 0 or not (ydir / "result.json").exists():
        tail = (ydir / "yade.log").read_text()[-2000:]
        raise RuntimeError(f"yade failed (exit {proc.returncode}):\n{tail}")
    res = json.loads((ydir / "result.json").read_text())
    return summarise(
        "yade",
        res,
        args,
        {
            "version": yade_version(),
            "newton_damping": args.yade_damping,
            "max_vel": args.yade_max_vel,
            "process_seconds": time.perf_counter() - t0,
        },
    )


def yade_version() -> str | None:
    try:
        out = subprocess.run(["yade", "--version"], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return None
    lines = [ln for ln in out.stdout.splitlines() if "version" in ln.lower()]
    return lines[-1].strip() if lines else None


def write_lid_stl(path: Path, lx: float, ly: float, z: float, inset: float) -> None:
    """A square lid of two triangles at height z, facing down. It is inset from the side walls
    by `inset` so that no node lies on the domain's boundary; a sphere touches the lid at
    least r from a side wall, so the inset (below r) loses no contact."""
    a, b = inset, lx - inset
    c, d = inset, ly - inset
    tris = [((a, c, z), (b, d, z), (b, c, z)), ((a, c, z), (a, d, z), (b, d, z))]
    lines = ["solid lid"]
    for tri in tris:
        lines += ["  facet normal 0 0 -1", "    outer loop"]
        lines += [f"      vertex {x!r} {y!r} {zz!r}" for x, y, zz in tri]
        lines += ["    endloop", "  endfacet"]
    lines.append("endsolid lid")
    path.write_text("\n".join(lines) + "\n")


def parse_liggghts_log(path: Path) -> tuple[list[list[float]], float | None, float | None]:
    """The thermo rows, the loop time and the part of it spent writing output."""
    rows, loop, output = [], None, None
    header = None
    for line in path.read_text().splitlines():
        parts = line.split()
        if line.startswith("Outpt time"):
            output = float(parts[4])
            continue
        if parts[:2] == ["Step", "Time"]:
            header = parts
            continue
        if line.startswith("Loop time of"):
            loop = float(parts[3])
            header = None
            continue
        if header and len(parts) == len(header):
            try:
                rows.append([float(p) for p in parts])
            except ValueError:
                header = None
    return rows, loop, output


def mean_force(path: Path) -> tuple[float, int]:
    """The sum of |f| over the contacts of a local dump, and their count."""
    data = np.loadtxt(path, skiprows=9, ndmin=2)
    if data.size == 0:
        return 0.0, 0
    return float(np.sum(np.linalg.norm(data[:, :3], axis=1))), len(data)


#: The fixed walls of the LIGGGHTS input, by fix ID.
PRIMITIVE_WALLS = ("floor", "wx0", "wx1", "wy0", "wy1")


def wall_variables(walls) -> str:
    """LIGGGHTS atom-style variables: each particle's |force| from each primitive wall, their
    sum (v_wsum) and the number of walls it touches (v_wnum)."""
    lines = []
    for w in walls:
        comps = "+".join(f"f_force_{w}[{k}]*f_force_{w}[{k}]" for k in (1, 2, 3))
        lines.append(f"variable        f{w} atom sqrt({comps})")
    lines.append("variable        wsum atom " + "+".join(f"v_f{w}" for w in walls))
    lines.append("variable        wnum atom " + "+".join(f"(v_f{w}>0)" for w in walls))
    return "\n".join(lines)


def run_liggghts(pack, args, work: Path) -> dict:
    import granpack.io as gio

    if shutil.which("liggghts") is None:
        raise RuntimeError("liggghts is not installed")
    mat = scene_material(pack)
    restitution = liggghts_restitution(mat["damping_ratio"])
    ldir = work / "liggghts"
    if ldir.exists():
        shutil.rmtree(ldir)
    dumps = ldir / "dumps"
    dumps.mkdir(parents=True)
    data = gio.export(pack, ldir / "pack.data", "liggghts")[0]
    # the peers start from rest: without its Velocities section the data file gives every
    # particle zero velocity and spin
    text = data.read_text()
    cut = text.find("\nVelocities")
    if cut >= 0:
        data.write_text(text[: cut + 1])
    lx, ly = (float(b) for b in pack.scene.base)
    top = float(np.max(pack.positions[:, 2] + pack.radii))
    r_min = float(np.min(pack.radii))
    write_lid_stl(ldir / "lid.stl", lx, ly, top, inset=0.1 * r_min)
    dt = pwave_dt(pack, args.dt_factor)
    text = LIGGGHTS_INPUT.format(
        data=data.name,
        skin=0.2 * r_min,
        young=mat["young"],
        poisson=mat["poisson"],
        restitution=restitution,
        friction=mat["friction"],
        dt=dt,
        stl="lid.stl",
        cx=lx / 2,
        cy=ly / 2,
        top=top,
        force=args.stress * lx * ly,
        vel_max=args.liggghts_vel_max,
        kp=args.liggghts_kp,
        lx=lx,
        ly=ly,
        check=args.check_every,
        dump_dir="dumps",
        wall_variables=wall_variables(PRIMITIVE_WALLS),
        prim="wall/gran model hertz tangential history primitive type 1",
        steps=args.liggghts_steps,
    )
    (ldir / "in.consolidate").write_text(text)
    # no -screen none: LIGGGHTS' output to the screen is what the log also gets, and some
    # of its fixes misbehave without a screen
    cmd = ["liggghts", "-in", "in.consolidate", "-log", "log.liggghts"]
    print("liggghts:", " ".join(cmd), "in", ldir, flush=True)
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    t0 = time.perf_counter()
    with (ldir / "screen.txt").open("w") as screen:
        proc = subprocess.run(cmd, cwd=ldir, env=env, stdout=screen, stderr=subprocess.STDOUT)
    process_seconds = time.perf_counter() - t0
    if proc.returncode != 0:
        tail = (ldir / "screen.txt").read_text()[-2000:]
        raise RuntimeError(f"liggghts failed (exit {proc.returncode}):\n{tail}")
    thermo, loop, output = parse_liggghts_log(ldir / "log.liggghts")
    n = len(pack.radii)
    vol = float(np.sum(4.0 / 3.0 * np.pi * pack.radii**3))
    hist = []
    for step, t, f_lid, z_lid, fmean, wx0, wx1, wy0, wy1, _floor, s_w, n_w, _atoms in thermo:
        step = int(step)
        s_pp, n_pp = mean_force(dumps / f"pp.{step}.txt")
        s_pw, n_pw = mean_force(dumps / f"pw.{step}.txt")
        contacts = n_pp + n_pw + int(n_w)
        mean_contact = (s_pp + s_pw + s_w) / contacts if contacts else float("nan")
        h = z_lid  # the floor is at z = 0
        sigma = f_lid / (lx * ly)
        lateral = (abs(wx0) + abs(wx1)) / (ly * h) + (abs(wy0) + abs(wy1)) / (lx * h)
        hist.append(
            {
                "step": step,
                "time": t,
                "lid_stress": sigma,
                "stress_error": abs(sigma - args.stress) / args.stress,
                "unbalanced": fmean / mean_contact if contacts else float("inf"),
                "unbalanced_max": None,
                "lateral_stress": lateral / 4.0,
                "lid_height": h,
                "phi": vol / (lx * ly * h),
                "contacts": contacts,
            }
        )
    # the dumps are this script's instrumentation, not LIGGGHTS' work: read, then dropped
    shutil.rmtree(dumps)
    steps = int(thermo[-1][0]) if thermo else 0
    if loop is None:
        raise RuntimeError(f"no loop time in {ldir / 'log.liggghts'}")
    res = {
        "particles": n,
        "dt": dt,
        "steps": steps,
        # the cost per step leaves out the output (the contact dumps and the thermo rows the
        # check needs), which LIGGGHTS' own timer reports apart
        "wall_seconds": loop - (output or 0.0),
        "history": hist,
    }
    return summarise(
        "liggghts",
        res,
        args,
        {
            "version": "LIGGGHTS-PUBLIC 3.8.0 (Debian package)",
            "restitution": restitution,
            "servo": {"vel_max": args.liggghts_vel_max, "kp": args.liggghts_kp},
            "process_seconds": process_seconds,
            "loop_seconds": loop,
            "output_seconds": output,
            "note": "fixed step budget; the ratio is computed from dumped contact forces",
        },
    )


def as_record(obj) -> dict:
    """The consolidation record as a dict, whether a mapping, a dataclass or an object with
    attributes (its exact type is not settled yet)."""
    import dataclasses

    if isinstance(obj, dict):
        return dict(obj)
    if dataclasses.is_dataclass(obj):
        return dataclasses.asdict(obj)
    if hasattr(obj, "keys"):
        return {k: obj[k] for k in obj.keys()}
    return {k: v for k, v in vars(obj).items() if not k.startswith("_")}


def run_granpack(pack, args) -> list[dict] | None:
    """granpack twice: at its own defaults (the stage's step from the contact stiffness
    at the target, the wall speed that keeps the inertial number at 1e-3), and at the
    peers' dt with the lid capped at 0.5 m/s, LIGGGHTS' vel_max, for the same loading."""
    import granpack as gp

    if not hasattr(gp, "consolidate"):
        print("granpack: this checkout has no gp.consolidate yet; skipped", flush=True)
        return None
    rows = []
    for label, extra in (
        ("granpack (defaults)", {}),
        (
            "granpack (peers' dt, lid <= 0.5 m/s)",
            {"dt": pwave_dt(pack, args.dt_factor), "max_wall_speed": 0.5},
        ),
    ):
        t0 = time.perf_counter()
        out = gp.consolidate(
            pack,
            stress=args.stress,
            mode="oedometric",
            gravity=False,
            stress_tol=args.stress_tol,
            unbalanced_tol=args.unbalanced_tol,
            hold=args.hold,
            check_every=args.check_every,
            **extra,
        )
        wall = time.perf_counter() - t0
        rec = as_record(out.record("consolidate").table())
        n = len(out.radii)
        steps = int(rec["steps"])
        seconds = float(rec.get("seconds", wall))
        hist = rec["history"]
        ok = [
            s
            for s, e, u in zip(hist["step"], hist["stress_error"], hist["unbalanced"], strict=True)
            if e <= args.stress_tol and u <= args.unbalanced_tol
        ]
        rows.append(
            {
                "code": label,
                "particles": n,
                "dt": float(rec["dt"]),
                "steps_to_tolerance": int(ok[0]) if ok else None,
                "steps_held": steps,
                "time_held": steps * float(rec["dt"]),
                "wall_seconds_to_held": seconds,
                "ns_per_particle_step": seconds / steps / n * 1e9 if steps else None,
                "phi": rec.get("phi"),
                "K0": rec.get("k0"),
                "unbalanced_final": rec.get("unbalanced"),
                "max_wall_speed": rec.get("max_wall_speed"),
                "python_seconds": wall,
                "history": hist,
            }
        )
    return rows


def fmt(v, spec: str) -> str:
    return "—" if v is None else format(v, spec)


def table(summaries: list[dict]) -> str:
    head = (
        "| code | particles | dt (s) | steps to tolerance | steps held | wall s to held "
        "| ns per particle-step | phi | K0 |\n|---|---|---|---|---|---|---|---|---|\n"
    )
    rows = []
    for s in summaries:
        rows.append(
            f"| {s['code']} | {s['particles']} | {fmt(s['dt'], '.3g')} "
            f"| {fmt(s.get('steps_to_tolerance'), 'd')} | {fmt(s.get('steps_held'), 'd')} "
            f"| {fmt(s.get('wall_seconds_to_held'), '.1f')} "
            f"| {fmt(s.get('ns_per_particle_step'), '.0f')} | {fmt(s.get('phi'), '.4f')} "
            f"| {fmt(s.get('K0'), '.3f')} |"
        )
    return head + "\n".join(rows) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--pack", help="a pack saved by Pack.save (default: make preset 4.3 here)")
    p.add_argument("--seed", type=int, default=1, help="seed of the pack made here")
    p.add_argument("--out", default=str(DEFAULT_OUT), help="results folder")
    p.add_argument("--work", help="folder for the peers' inputs, logs and dumps (default: temp)")
    p.add_argument("--codes", default="granpack,yade,liggghts", help="comma-separated")
    p.add_argument("--stress", type=float, default=1e5, help="target lid stress, Pa")
    p.add_argument("--stress-tol", type=float, default=1e-3)
    p.add_argument("--unbalanced-tol", type=float, default=1e-4)
    p.add_argument("--hold", type=int, default=5, help="checks in a row both must hold")
    p.add_argument("--check-every", type=int, default=100, help="steps between checks")
    p.add_argument("--dt-factor", type=float, default=0.8, help="of the P-wave step")
    p.add_argument("--max-steps", type=int, default=50000, help="YADE's step budget")
    p.add_argument("--yade-damping", type=float, default=0.4, help="NewtonIntegrator damping")
    # YADE caps the lid's step at max_vel 3 h / (h + w + d) dt before a filter that adds 0.8
    # of the last step's motion, so the lid can run at 0.75 / 0.2 = 3.75 times that cap: 2.2
    # m/s at YADE's default max_vel = 1 here; 0.226 holds it to LIGGGHTS' 0.5 m/s
    p.add_argument(
        "--yade-max-vel",
        type=float,
        default=1.0,
        help="TriaxialStressController.max_vel (default: YADE's)",
    )
    p.add_argument("--liggghts-steps", type=int, default=10000, help="LIGGGHTS' step budget")
    # about the cap YADE puts on the lid's step (max_vel 3 h / (h + w + d) = 0.55-0.6 m/s
    # here), though its filter lets the lid itself run faster (see --yade-max-vel)
    p.add_argument("--liggghts-vel-max", type=float, default=0.5, help="servo vel_max, m/s")
    # kp = 3 was the fastest of 1, 3 and 6 on the 4.3 pack at vel_max 0.5 m/s (held after
    # 5 800, 4 900 and more than 5 000 steps: at 6 the lid overshoots and the pack rings)
    p.add_argument("--liggghts-kp", type=float, default=3.0, help="servo kp")
    args = p.parse_args(argv)

    codes = [c.strip() for c in args.codes.split(",") if c.strip()]
    bad = [c for c in codes if c not in CODES]
    if bad:
        p.error(f"--codes: unknown {bad}; known: {', '.join(CODES)}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="consolidation_"))
    work.mkdir(parents=True, exist_ok=True)
    print(f"work folder: {work}", flush=True)

    pack = load_or_make_pack(args, work)
    mat = scene_material(pack)
    print("material:", json.dumps(mat), flush=True)
    print(
        f"box {tuple(pack.scene.base)} m, top of the highest sphere "
        f"{float(np.max(pack.positions[:, 2] + pack.radii)):.6f} m, dt = "
        f"{pwave_dt(pack, args.dt_factor):.4g} s ({args.dt_factor} of the P-wave step)",
        flush=True,
    )

    summaries, failures = [], {}
    for code in codes:
        try:
            if code == "granpack":
                s = run_granpack(pack, args)
            elif code == "yade":
                s = run_yade(pack, args, work)
            else:
                s = run_liggghts(pack, args, work)
        except RuntimeError as exc:
            print(f"{code}: {exc}", flush=True)
            failures[code] = str(exc)
            continue
        if s is None:
            failures[code] = "skipped"
            continue
        # granpack gives one row per configuration, the peers one
        for k, row in enumerate(s if isinstance(s, list) else [s]):
            name = code if k == 0 else f"{code}_{k}"
            hist = row.pop("history", None)
            if isinstance(hist, dict):  # granpack's record: columns
                hist = [
                    {
                        "step": st,
                        "time": st * row["dt"],
                        "lid_stress": sl,
                        "stress_error": e,
                        "unbalanced": u,
                        "unbalanced_max": mr,
                    }
                    for st, sl, e, u, mr in zip(
                        hist["step"],
                        hist["stress"]["lid"],
                        hist["stress_error"],
                        hist["unbalanced"],
                        hist["max_ratio"],
                        strict=True,
                    )
                ]
            if hist:
                write_history(out, name, hist)
            (out / f"{name}_summary.json").write_text(json.dumps(row, indent=2) + "\n")
            print(json.dumps(row, indent=1), flush=True)
            summaries.append(row)
    (out / "summary.md").write_text(table(summaries))
    print(table(summaries), flush=True)
    write_manifest(
        out,
        seeds=[args.seed] if not args.pack else None,
        extra={
            "codes": codes,
            "pack": args.pack,
            "particles": len(pack.radii),
            "material": mat,
            "settings": {
                k: getattr(args, k)
                for k in (
                    "stress",
                    "stress_tol",
                    "unbalanced_tol",
                    "hold",
                    "check_every",
                    "dt_factor",
                    "max_steps",
                    "yade_damping",
                    "yade_max_vel",
                    "liggghts_steps",
                    "liggghts_vel_max",
                    "liggghts_kp",
                )
            },
            "not_run": failures,
        },
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
