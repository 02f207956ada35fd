"""YADE's drained triaxial compression of a granpack consolidated pack.

`run_yade_triaxial` writes a YADE script and its settings, runs YADE (the Debian package
``yade``, 2023.02a, as ``yade -n -j1 -x``) in batch mode, and reads back one row per check
as a polars DataFrame with the columns of granpack's element table (eps_a, eps_v, sigma_1,
sigma_3, p, q, eta, e, phi, unbalanced, ...), plus the wall time of YADE's stepping loop.

The sample is the consolidated pack as granpack holds it: its spheres (positions and radii
exactly, velocities and spins zero: the pack is in static equilibrium), and six planes, the
box [0, base_x] x [0, base_y] x [0, H] of the consolidation's record (floor at z = 0, lid at
the record's height). The material is the scene's, under YADE's Hertz-Mindlin law
(``Ip2_FrictMat_FrictMat_MindlinPhys`` with ``betan = betas`` = granpack's damping ratio,
``Law2_ScGeom_MindlinPhys_Mindlin``); a plane's contact takes R* = r, as granpack's
(``Ig2_Wall_Sphere_ScGeom(hertzian=True)``). The walls are smooth by default, as
`granpack.triaxial`'s (``wall_friction``; None gives them the particles' mu).

Loading:

- re-seating first (``reseat``, as `granpack.triaxial`): the tangential springs start at
  zero, so the friction that held the consolidated sample is gone; the lid and the side
  walls go back to the consolidation's targets under YADE's servo (``stressMask = 7``, the
  floor fixed) until the consolidation's stress and unbalanced tolerances hold for its
  ``hold`` checks, and H0, V0, the step count and the clock start there;
- the lid moves down at the constant speed v = eps_dot H0 (H0 the lid's height at the start;
  engineering strain rate) by YADE's kinematic ``TranslationEngine``, which sets the lid's
  velocity every step, after the stress controller (which zeroes a deactivated wall's
  velocity) and before ``NewtonIntegrator`` moves it;
- the four side walls hold sigma_3 with YADE's ``TriaxialStressController``
  (``stressMask = 5``: YADE's axes 1 and 3, the horizontal ones, by stress; its target force
  is goal x the wall's current area, width x current height), the floor and the lid
  deactivated in it. YADE's servo is its own, stiffness-based one: each step a side wall
  moves by (F - F*) / K (K the summed normal stiffness of its contacts), capped by
  ``max_vel`` and low-pass filtered (``stressDamping``); granpack's walls follow its PFC
  servo (gain 0.5), so the two hold sigma_3 with different errors along the path.
- ``NewtonIntegrator(damping=local_damping)``, YADE's local non-viscous damping; gravity
  only where the consolidation ran with it (the scene's g, downwards).

YADE's vertical axis is y (``TriaxialStressController``'s "height" is y): granpack's
(x, y, z) becomes YADE's (x, z, y), a mirror that spheres and planes do not notice.

Each check reads the walls' forces and positions in the same state: the check runs after the
contact forces of the step and before ``NewtonIntegrator`` moves anything, so the row at
``step`` k is the state after k steps of the shear (row 0 is its start). YADE cannot take
granpack's contact history; the normal forces are those of the overlaps, the same in both
codes (without re-seating, row 0 gives the consolidated walls' stresses).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import time
from pathlib import Path

import numpy as np
import polars as pl

from granpack.errors import InvalidParameterError

#: The columns of the returned table, in order (SI units, compression positive).
COLUMNS = (
    "step",
    "time",
    "eps_a",
    "eps_v",
    "sigma_1",
    "sigma_3",
    "p",
    "q",
    "eta",
    "e",
    "phi",
    "unbalanced",
    "contacts",
    "lid_height",
    "width_x",
    "width_y",
    "sigma_x_lo",
    "sigma_x_hi",
    "sigma_y_lo",
    "sigma_y_hi",
    "sigma_floor",
)

# Runs inside YADE's own Python: settings in a JSON file named by an environment variable
# (yade's command line keeps its own options), results out in another JSON file.
YADE_SCRIPT = r"""
import json, math, os, time
import numpy as np
from yade import utils

cfg = json.load(open(os.environ["GP_TRIAXIAL_CONFIG"]))
xyzr = np.loadtxt(cfg["spheres"], comments="#", ndmin=2)
lx, ly = cfg["base"]
h0 = cfg["height"]
mat = O.materials.append(FrictMat(young=cfg["young"], poisson=cfg["poisson"],
                                  density=cfg["density"], frictionAngle=math.atan(cfg["friction"])))
# a contact takes the smaller friction angle of its two materials: the walls' own material
# sets the wall contacts' friction (the particles' mu by default, as granpack's walls)
wall_mat = O.materials.append(FrictMat(young=cfg["young"], poisson=cfg["poisson"],
                                       density=cfg["density"],
                                       frictionAngle=math.atan(cfg["wall_friction"])))
# granpack's z (up) is YADE's y
O.bodies.append([utils.sphere((x, z, y), r, material=mat) for x, y, z, r in xyzr])
walls = {
    "left": utils.wall(0.0, axis=0, sense=1, material=wall_mat),
    "right": utils.wall(lx, axis=0, sense=-1, material=wall_mat),
    "bottom": utils.wall(0.0, axis=1, sense=1, material=wall_mat),
    "top": utils.wall(h0, axis=1, sense=-1, material=wall_mat),
    "back": utils.wall(0.0, axis=2, sense=1, material=wall_mat),
    "front": utils.wall(ly, axis=2, sense=-1, material=wall_mat),
}
ids = {k: O.bodies.append(b) for k, b in walls.items()}
sigma3 = cfg["confining"]
reseat = cfg["reseat"]  # None, or the consolidation's targets and tolerances
triax = TriaxialStressController(
    internalCompaction=False,
    thickness=0.0,  # planes: a wall's face is its position
    stressMask=5,  # YADE's axes 1 (x) and 3 (z), granpack's x and y, by stress
    goal1=-sigma3, goal3=-sigma3, goal2=0.0,  # YADE's stresses are negative in compression
    max_vel=cfg["max_vel"],
    wall_bottom_id=ids["bottom"], wall_top_id=ids["top"], wall_left_id=ids["left"],
    wall_right_id=ids["right"], wall_back_id=ids["back"], wall_front_id=ids["front"],
    # deactivated: the controller zeroes their velocity; the lid's is set after it
    wall_bottom_activated=False, wall_top_activated=False,
)
lid = TranslationEngine(ids=[ids["top"]], translationAxis=(0, -1, 0), velocity=0.0)
if reseat:
    # back to equilibrium at the consolidation's targets first: the lid by stress too
    triax.stressMask = 7
    triax.wall_top_activated = True
    triax.goal1, triax.goal2, triax.goal3 = (-reseat["x"], -reseat["lid"], -reseat["y"])
    lid.dead = True
g = cfg["gravity"]
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()]),
    InteractionLoop(
        # hertzian: a plane's contact takes R* = r, as granpack's
        [Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom(hertzian=True)],
        [Ip2_FrictMat_FrictMat_MindlinPhys(betan=cfg["damping_ratio"], betas=cfg["damping_ratio"])],
        [Law2_ScGeom_MindlinPhys_Mindlin()],
    ),
    triax,
    lid,
    # every step, after this step's forces and before NewtonIntegrator moves anything
    PyRunner(iterPeriod=1, initRun=True, command="tick()"),
    NewtonIntegrator(damping=cfg["newton_damping"], gravity=(0, -g, 0)),
]
O.dt = cfg["dt"]
n = len(xyzr)
solid = float(np.sum(4.0 / 3.0 * math.pi * xyzr[:, 3] ** 3))
rows = []
spent = [0.0]
state = {"phase": "reseat" if reseat else "shear", "held": 0, "start": 0, "t0": 0.0,
         "h0": h0, "reseat_steps": 0, "reseat_converged": None, "reseat_seconds": 0.0}
wall_ids = set(ids.values())


def wall_state():
    f = {k: O.forces.f(i) for k, i in ids.items()}
    pos = {k: O.bodies[i].state.pos for k, i in ids.items()}
    h = pos["top"][1] - pos["bottom"][1]
    wx = pos["right"][0] - pos["left"][0]
    wy = pos["front"][2] - pos["back"][2]  # granpack's y
    # the spheres push each wall outwards: compression positive
    return {
        "lid_height": h, "width_x": wx, "width_y": wy,
        "sigma_1": f["top"][1] / (wx * wy), "sigma_floor": -f["bottom"][1] / (wx * wy),
        "sigma_x_lo": -f["left"][0] / (wy * h), "sigma_x_hi": f["right"][0] / (wy * h),
        "sigma_y_lo": -f["back"][2] / (wx * h), "sigma_y_hi": f["front"][2] / (wx * h),
        "volume": wx * wy * h,
    }


def check():
    t0 = time.perf_counter()
    row = wall_state()
    contacts = sum(
        1 for I in O.interactions
        if I.isReal and I.id1 not in wall_ids and I.id2 not in wall_ids
    )
    row.update({
        "step": O.iter - state["start"], "time": O.time - state["t0"],
        "phi": solid / row["volume"], "unbalanced": utils.unbalancedForce(),
        "contacts": contacts,
    })
    rows.append(row)
    s3 = 0.25 * (row["sigma_x_lo"] + row["sigma_x_hi"] + row["sigma_y_lo"] + row["sigma_y_hi"])
    print(row["step"], (state["h0"] - row["lid_height"]) / state["h0"], row["sigma_1"], s3,
          flush=True)
    spent[0] += time.perf_counter() - t0


def start_shear(inside_step=True):
    # the lid by speed from this step on; H0 and the clock taken here
    state["phase"] = "shear"
    state["start"], state["t0"] = O.iter, O.time
    state["h0"] = O.bodies[ids["top"]].state.pos[1] - O.bodies[ids["bottom"]].state.pos[1]
    v = cfg["strain_rate"] * state["h0"]
    triax.stressMask = 5
    triax.goal1, triax.goal2, triax.goal3 = -sigma3, 0.0, -sigma3
    triax.wall_top_activated = False
    lid.velocity = v
    lid.dead = False
    if inside_step:
        # this step's motion too: NewtonIntegrator moves the lid next, by this velocity
        # (before the first step the lid is at rest: TranslationEngine sets its velocity
        # after the first contact forces, which see no lid motion)
        O.bodies[ids["top"]].state.vel = (0.0, -v, 0.0)


def tick():
    if state["phase"] == "reseat":
        k = O.iter
        if k % reseat["check_every"] == 0:
            w = wall_state()
            err = max(
                abs(w["sigma_1"] - reseat["lid"]) / reseat["lid"],
                *(abs(w[c] - reseat["x"]) / reseat["x"] for c in ("sigma_x_lo", "sigma_x_hi")),
                *(abs(w[c] - reseat["y"]) / reseat["y"] for c in ("sigma_y_lo", "sigma_y_hi")),
            )
            ok = err <= reseat["stress_tol"] and utils.unbalancedForce() <= reseat["unbalanced_tol"]
            state["held"] = state["held"] + 1 if ok else 0
            done = state["held"] >= reseat["hold"]
            if done or k >= reseat["max_steps"]:
                state["reseat_steps"], state["reseat_converged"] = k, done
                state["reseat_seconds"] = time.perf_counter() - wall0
                print("reseated" if done else "reseat budget spent", k, err, flush=True)
                start_shear()
    if state["phase"] == "shear":
        k = O.iter - state["start"]
        if k % cfg["check_every"] == 0:
            check()
        if k >= cfg["steps"]:
            O.pause()  # at the end of this step: the state after `steps` steps was the last row


if not reseat:
    start_shear(inside_step=False)
wall0 = time.perf_counter()
O.run()
O.wait()
loop = time.perf_counter() - wall0
json.dump({
    "particles": n, "dt": O.dt, "steps": cfg["steps"], "loop_seconds": loop,
    "check_seconds": spent[0], "rows": rows, "H0": state["h0"],
    "reseat_steps": state["reseat_steps"], "reseat_converged": state["reseat_converged"],
    "reseat_seconds": state["reseat_seconds"],
}, open(cfg["result"], "w"))
"""


def yade_executable() -> str | None:
    """The YADE program on PATH (``yade``, as the Debian package installs it, or a
    ``yadedaily``), or None."""
    for name in ("yade", "yadedaily"):
        path = shutil.which(name)
        if path is not None:
            return path
    return None


def _consolidation(pack) -> tuple[dict, dict]:
    rec = pack.record("consolidate")
    if rec is None:
        raise InvalidParameterError(
            "invalid pack: not consolidated (no 'consolidate' record); consolidate it first "
            "(granpack.consolidate)",
            parameter="pack",
        )
    return dict(rec.settings), dict(rec.report)


def strain_rate(pack, confining: float, inertial_number: float) -> float:
    """eps_dot (1/s) = I / (d_mean sqrt(rho / sigma_3)), d_mean = 2 r_mean."""
    d_mean = 2.0 * float(np.mean(pack.radii))
    return inertial_number / (d_mean * math.sqrt(pack.scene.material.density / confining))


def run_yade_triaxial(
    pack,
    confining: float | None = None,
    axial_strain: float = 0.25,
    strain_rate_or_lid_speed: tuple[str, float] = ("inertial_number", 1e-3),
    dt: float | None = None,
    local_damping: float = 0.4,
    check_every_strain: float = 0.0025,
    workdir: str | Path = "yade_triaxial",
    *,
    max_vel: float = 1.0,
    wall_friction: float | None = 0.0,
    reseat: bool = True,
    reseat_max_steps: int = 200_000,
    cpu: int | None = None,
    yade: str | None = None,
    timeout: float | None = None,
) -> pl.DataFrame:
    """YADE's drained triaxial compression of the consolidated `pack`, one row per check.

    Parameters
    ----------
    pack : granpack.Pack
        A pack consolidated in a box (`granpack.consolidate`, isotropic or anisotropic).
    confining : float, optional
        sigma_3 (Pa) the side walls hold. Default: the consolidation's mean side-wall
        target.
    axial_strain : float
        The axial strain (H0 - H) / H0 at which the test ends, in (0, 1). Default 0.25.
    strain_rate_or_lid_speed : (str, float)
        The loading rate: ("inertial_number", I) for eps_dot = I / (d_mean sqrt(rho /
        sigma_3)), ("strain_rate", eps_dot) in 1/s, or ("lid_speed", v) in m/s. The lid
        moves at v = eps_dot H0 throughout. Default ("inertial_number", 1e-3).
    dt : float, optional
        Time step (s). Default: the consolidation's.
    local_damping : float
        NewtonIntegrator's damping (YADE's local non-viscous damping). Default 0.4.
    check_every_strain : float
        Axial strain between checks (rounded to whole steps). Default 0.0025.
    workdir : str or Path
        Folder for YADE's script, settings, sphere file, log and result (created).
    max_vel : float
        TriaxialStressController.max_vel (m/s), the side walls' speed cap. Default 1 (YADE's).
    wall_friction : float, optional
        The walls' friction coefficient (-), in [0, mu]. Default 0, smooth walls, as
        `granpack.triaxial`'s default; None gives them the particles' mu.
    reseat : bool
        First bring the sample back to equilibrium at the consolidation's targets (the lid
        and the side walls by YADE's servo, the consolidation's stress and unbalanced
        tolerances held for its `hold` checks every `check_every` steps), as
        `granpack.triaxial` does, and take H0 and V0 there. Default True.
    reseat_max_steps : int
        The most steps the re-seating may take before the test starts anyway (the summary
        says whether it converged). Default 200 000.
    cpu : int, optional
        Pins YADE to this CPU with ``taskset`` where available.
    yade : str, optional
        The YADE program. Default: ``yade`` (or ``yadedaily``) on PATH.
    timeout : float, optional
        Seconds YADE may run before it is stopped.

    Returns
    -------
    polars.DataFrame
        The columns of `COLUMNS` (strains and stresses compression-positive, Pa), one row
        per check from step 0. Its ``attrs``-like metadata is in ``workdir/summary.json``:
        dt, steps, the lid speed, the stepping loop's wall time (``loop_seconds``, the
        checks' own time taken out as ``stepping_seconds``) and ns per particle-step.
    """
    settings, report = _consolidation(pack)
    if pack.scene.container != "box" or pack.dim != 3:
        raise InvalidParameterError(
            f"invalid pack: a {pack.dim}D {pack.scene.container}; YADE's triaxial here takes "
            "a 3D box",
            parameter="pack",
        )
    if confining is None:
        targets = settings.get("targets") or {}
        sides = [v for k, v in targets.items() if k not in ("lid", "floor")]
        if not sides:
            raise InvalidParameterError(
                "invalid confining = None: the consolidation had no side-wall target; give one",
                parameter="confining",
            )
        confining = float(np.mean(sides))
    if not 0.0 < axial_strain < 1.0:
        raise InvalidParameterError(
            f"invalid axial_strain = {axial_strain}: must lie in (0, 1)",
            parameter="axial_strain",
            value=axial_strain,
            expected="(0, 1)",
        )
    kind, value = strain_rate_or_lid_speed
    rate_ok = isinstance(value, int | float) and math.isfinite(value) and value > 0.0
    walls = report["walls"]
    h0 = float(walls["lid"] - walls["floor"])
    if not rate_ok:
        kind = ""  # refused below with an unknown kind
    if kind == "inertial_number":
        eps_dot = strain_rate(pack, confining, value)
    elif kind == "strain_rate":
        eps_dot = float(value)
    elif kind == "lid_speed":
        eps_dot = float(value) / h0
    else:
        raise InvalidParameterError(
            f"invalid strain_rate_or_lid_speed = {strain_rate_or_lid_speed!r}: its kind must be "
            "'inertial_number', 'strain_rate' or 'lid_speed', its value above 0",
            parameter="strain_rate_or_lid_speed",
        )
    step = float(settings["dt"]) if dt is None else float(dt)
    per_step = eps_dot * step  # axial strain per step
    check_every = max(1, round(check_every_strain / per_step))
    steps = check_every * math.ceil(axial_strain / (check_every * per_step) - 1e-9)
    if wall_friction is not None and not 0.0 <= wall_friction <= float(
        pack.scene.material.friction
    ):
        raise InvalidParameterError(
            f"invalid wall_friction = {wall_friction}: must lie in [0, "
            f"{pack.scene.material.friction}] (a contact takes the smaller friction)",
            parameter="wall_friction",
            value=wall_friction,
        )
    prog = yade or yade_executable()
    if prog is None:
        raise RuntimeError("yade is not installed (apt-get install yade)")

    work = Path(workdir)
    work.mkdir(parents=True, exist_ok=True)
    base = (float(walls["x_hi"] - walls["x_lo"]), float(walls["y_hi"] - walls["y_lo"]))
    # every digit: the overlaps at 100 kPa lie far below the positions' sixth digit
    spheres = work / "spheres.txt"
    xyzr = np.column_stack([pack.positions, pack.radii])
    np.savetxt(spheres, xyzr, fmt="%.17g", header="x y z r")
    m = pack.scene.material
    gravity = float(pack.scene.gravity) if settings.get("gravity") else 0.0
    cfg = {
        "spheres": str(spheres.resolve()),
        "base": list(base),
        "height": h0,
        "density": float(m.density),
        "young": float(m.young),
        "poisson": float(m.poisson),
        "friction": float(m.friction),
        "wall_friction": float(m.friction) if wall_friction is None else float(wall_friction),
        "reseat": _reseat_settings(settings, reseat_max_steps) if reseat else None,
        "damping_ratio": float(m.damping),
        "confining": confining,
        "lid_speed": eps_dot * h0,
        "strain_rate": eps_dot,
        "dt": step,
        "steps": steps,
        "check_every": check_every,
        "newton_damping": local_damping,
        "gravity": gravity,
        "max_vel": max_vel,
        "result": str((work / "result.json").resolve()),
    }
    (work / "config.json").write_text(json.dumps(cfg, indent=1) + "\n")
    script = work / "triaxial.py"
    script.write_text(YADE_SCRIPT)
    (work / "result.json").unlink(missing_ok=True)
    env = {k: v for k, v in os.environ.items() if k != "VIRTUAL_ENV"}
    env["GP_TRIAXIAL_CONFIG"] = str((work / "config.json").resolve())
    env["OMP_NUM_THREADS"] = "1"
    cmd = [prog, "-n", "-j1", "-x", str(script.resolve())]
    if cpu is not None and shutil.which("taskset"):
        cmd = ["taskset", "-c", str(cpu), *cmd]
    t0 = time.perf_counter()
    with (work / "yade.log").open("w") as log:
        proc = subprocess.run(
            cmd, cwd=work, env=env, stdout=log, stderr=subprocess.STDOUT, timeout=timeout
        )
    process_seconds = time.perf_counter() - t0
    if proc.returncode != 0 or not (work / "result.json").exists():
        tail = (work / "yade.log").read_text()[-3000:]
        raise RuntimeError(f"yade failed (exit {proc.returncode}):\n{tail}")
    res = json.loads((work / "result.json").read_text())
    h0 = float(res["H0"])  # the lid's height where the shear began (after re-seating)
    table = element_table(res["rows"], h0, solid_volume(pack))
    n = int(res["particles"])
    stepping = (
        float(res["loop_seconds"]) - float(res["check_seconds"]) - float(res["reseat_seconds"])
    )
    summary = {
        "particles": n,
        "dt": float(res["dt"]),
        "steps": int(res["steps"]),
        "check_every": check_every,
        "confining": confining,
        "strain_rate": eps_dot,
        "lid_speed": eps_dot * h0,
        "H0": h0,
        "base": list(base),
        "gravity": gravity,
        "local_damping": local_damping,
        "max_vel": max_vel,
        "wall_friction": cfg["wall_friction"],
        "reseat_steps": int(res["reseat_steps"]),
        "reseat_converged": res["reseat_converged"],
        "reseat_seconds": float(res["reseat_seconds"]),
        "loop_seconds": float(res["loop_seconds"]),
        "check_seconds": float(res["check_seconds"]),
        "stepping_seconds": stepping,
        # the loop ran steps + 1 steps (the last check lies inside the last one)
        "ns_per_particle_step": stepping / (int(res["steps"]) + 1) / n * 1e9,
        "process_seconds": process_seconds,
        "command": cmd,
    }
    (work / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    return table


def _reseat_settings(settings: dict, max_steps: int) -> dict:
    """The re-seating's targets (Pa; the x and y pairs' means) and the consolidation's
    tolerances, for the YADE script."""
    t = settings["targets"]
    if not all(k in t for k in ("lid", "x_lo", "x_hi", "y_lo", "y_hi")):
        raise InvalidParameterError(
            "invalid reseat = True: the consolidation held no side-wall targets (an "
            "oedometric one) to re-seat the sample at; give reseat=False",
            parameter="reseat",
        )
    return {
        "lid": float(t["lid"]),
        "x": 0.5 * (float(t["x_lo"]) + float(t["x_hi"])),
        "y": 0.5 * (float(t["y_lo"]) + float(t["y_hi"])),
        "stress_tol": float(settings["stress_tol"]),
        "unbalanced_tol": float(settings["unbalanced_tol"]),
        "hold": int(settings["hold"]),
        "check_every": int(settings["check_every"]),
        "max_steps": min(int(settings["max_steps"]), int(max_steps)),
    }


def solid_volume(pack) -> float:
    """The spheres' volume (m^3)."""
    return float(np.sum(4.0 / 3.0 * np.pi * pack.radii**3))


def element_table(rows: list[dict], h0: float, solid: float) -> pl.DataFrame:
    """granpack's element-table columns from YADE's rows (walls' forces and positions)."""
    df = pl.DataFrame(rows)
    v0 = float(df["volume"][0])
    df = df.with_columns(
        eps_a=(h0 - pl.col("lid_height")) / h0,
        eps_v=(v0 - pl.col("volume")) / v0,
        sigma_3=(
            pl.col("sigma_x_lo")
            + pl.col("sigma_x_hi")
            + pl.col("sigma_y_lo")
            + pl.col("sigma_y_hi")
        )
        / 4.0,
        e=pl.col("volume") / solid - 1.0,
    )
    df = df.with_columns(
        p=(pl.col("sigma_1") + 2.0 * pl.col("sigma_3")) / 3.0,
        q=pl.col("sigma_1") - pl.col("sigma_3"),
    )
    df = df.with_columns(eta=pl.col("q") / pl.col("p"))
    return df.select(COLUMNS)


def summary_figures(table: pl.DataFrame) -> dict:
    """The figures a triaxial test is compared by: eta and q at the peak of eta, the peak
    friction angle phi_p (degrees) = asin((s1 - s3) / (s1 + s3)) there, eps_a at the peak,
    eps_v at 10 % axial strain (interpolated) and at the end."""
    k = int(np.argmax(table["eta"].to_numpy()))
    s1, s3 = float(table["sigma_1"][k]), float(table["sigma_3"][k])
    eps_a = table["eps_a"].to_numpy()
    eps_v = table["eps_v"].to_numpy()
    at10 = float(np.interp(0.10, eps_a, eps_v)) if eps_a[-1] >= 0.10 - 1e-9 else None
    return {
        "eta_peak": float(table["eta"][k]),
        "q_peak": float(table["q"][k]),
        "eps_a_peak": float(eps_a[k]),
        "phi_p_deg": math.degrees(math.asin((s1 - s3) / (s1 + s3))),
        "eps_v_at_10pct": at10,
        "eps_v_end": float(eps_v[-1]),
        "eta_end": float(table["eta"][-1]),
    }
