"""The element tests on a consolidated pack: drained triaxial compression, oedometric
loading and unloading, and isotropic compression.

Each starts from a pack that `granpack.consolidate` brought to rest under its lid, rebuilds
the engine with the walls where the consolidation left them, and records the sample at
every check in a table (`granpack.element.element_table`; the columns are in
docs/element_tests.md). The returned Pack is the sample at the end of the test; its
history gains the test's record, whose report holds the table (``table``) and what a lab
report derives from it (``lab``, `granpack.element.lab`).

- **Triaxial** (`triaxial`): the lid moves in at a constant speed v = eps_dot H0, the
  loading rate given as an inertial number I = eps_dot d_mean sqrt(rho / sigma_3), while
  the side walls (the box's four, or the cylinder's radius) hold sigma_3 with the
  consolidation's servo, or the sigma_3 that keeps p constant (``constant_p``). Its drive
  is the engine's (``granpack._core.Simulation.shear``, src/pipeline/shear.rs).
- **Oedometer** (`oedometer`): the lid's servo steps through a list of stresses, each
  held to equilibrium as the consolidation holds its target; the side walls stay, and a
  periodic cell keeps its periods.
- **Isotropic compression** (`isotropic_compression`): every wall's servo steps through
  a list of mean stresses.
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from .. import _core
from ..analysis.coordination import degrees
from ..analysis.stress import contact_forces, love_weber
from ..analysis.tensors import fabric_tensor
from ..consolidation import (
    INERTIAL_NUMBER,
    OVERRUN_FRACTION,
    _check_converged,
    _sample_volume,
    _simulation,
    _volumes,
    _wall_shift,
    stage_time_step,
)
from ..contacts import LID_ID, Contacts
from ..element_settings import (
    DEFAULT_INERTIAL_NUMBER,
    MAX_INERTIAL_NUMBER,
    _fail,
    _path_values,
    _real,
    _triaxial_values,
)
from ..errors import InvalidParameterError
from ..history import StageRecord
from ..pack import Pack
from . import lab

__all__ = [
    "triaxial",
    "oedometer",
    "isotropic_compression",
    "element_table",
    "MAX_INERTIAL_NUMBER",
    "StartMovedWarning",
]


class StartMovedWarning(UserWarning):
    """The sample's void ratio moved by more than the density tolerance (0.002) when the
    test brought it back to rest at its start stresses, and the test's walls have another
    friction than the consolidation's: the walls held the sample, and the test took that
    away (a loose sample of example 4.3 consolidated with the grains' friction on its
    walls compacts by 0.014 in e when the test's walls are smooth). The test runs on the
    moved sample; its settings record by how much (``reseat_void_ratio_change``)."""


_C = _core.DEFAULT_CONSOLIDATE

#: The triaxial's time step is `stage_time_step` at this many times sigma_3: the axial
#: stress of a dense sample peaks at 3 to 5 sigma_3 (phi_p of 30 to 45 degrees), and the
#: stiffest contacts must stay resolved there.
PEAK_STRESS_RATIO = 5.0

#: The side walls' servo may move them this many times faster than the axial strain rate
#: would move a wall across the sample's width: room for the dilatancy of a dense sample.
LATERAL_SPEED_FACTOR = 2.0


def _consolidated(pack: Any, test: str) -> StageRecord:
    """The pack's consolidation record, or a typed error for anything else."""
    if not isinstance(pack, Pack):
        raise _fail("pack", pack, "a granpack.Pack")
    rec = pack.record("consolidate")
    if rec is None:
        raise InvalidParameterError(
            f"invalid pack: the {test} starts from a consolidated sample at rest under its lid; "
            "run granpack.consolidate on it first",
            parameter="pack",
        )
    return rec


class _Rig:
    """The engine rebuilt from a consolidated pack, its walls where the consolidation (or
    the last test) left them, and the measures of one row."""

    def __init__(
        self, pack: Pack, rec: StageRecord, dt: float, gravity: bool, wall_friction: float | None
    ):
        self.pack = pack
        self.scene = sc = pack.scene
        self.dim = pack.dim
        self.names = list(rec.report["walls"])
        self.sim = _simulation(pack, dt, gravity, drag=0.0)
        self.lid = self.sim._sim.add_lid(float(pack.height))
        self.sim._sim.set_wall_friction(wall_friction)
        self.wall_friction = wall_friction
        assert self.lid == len(self.names) - 1
        self.sides = [k for k, n in enumerate(self.names) if n not in ("floor", "lid")]
        self.solid = float(np.sum(_volumes(pack.radii, self.dim)))
        self.d_mean = 2.0 * float(np.mean(pack.radii))
        self.rho = float(sc.material.density)
        self.gravity = gravity
        pos = self.positions()
        self.h0 = pos["lid"] - pos["floor"]
        self.v0 = _sample_volume(pos, sc)

    def reseat(self, rec: StageRecord, stacklevel: int) -> int:
        """Brings the sample back to equilibrium at the consolidation's targets; returns
        the steps it took. A Pack keeps no tangential springs: the rebuilt engine starts
        every contact's spring from zero, the friction that held the sample is gone, and
        the sample must find its balance again (it moves by a fraction of the overlaps)
        before a test can start from rest."""
        s = rec.settings
        targets = _start_targets(self.pack, rec, self.names)
        out: dict[str, Any] = dict(
            self.sim._sim.consolidate(
                [(self.names.index(n), float(v)) for n, v in targets.items()],
                stress_tol=float(s.get("stress_tol", _C["stress_tol"])),
                unbalanced_tol=float(s.get("unbalanced_tol", _C["unbalanced_tol"])),
                hold=int(s.get("hold", _C["hold"])),
                check_every=int(s.get("check_every", _C["check_every"])),
                max_steps=int(s.get("max_steps", _C["max_steps"])),
                max_wall_speed=float(s["max_wall_speed"]),
                gain=float(s.get("gain", _C["gain"])),
                local_damping=float(s.get("local_damping", _C["local_damping"])),
            )
        )
        _check_converged(out, list(targets), {**_C, **s})
        before = self.v0
        pos = self.positions()
        self.h0 = pos["lid"] - pos["floor"]
        self.v0 = _sample_volume(pos, self.scene)
        # the void ratio's change, (V - V_before) / V_solid
        self.reseat_de = (self.v0 - before) / self.solid
        # The springs a pack does not keep move it by about the density tolerance (e by
        # 0.002 in example 4.3, recorded); walls that lost their friction can move it by
        # ten times that, and the user can avoid it: a warning says how.
        mu_c = s.get("wall_friction")
        mu_c = self.scene.material.friction if mu_c is None else float(mu_c)
        mu_t = self.wall_friction
        mu_t = self.scene.material.friction if mu_t is None else mu_t
        if mu_c != mu_t and abs(self.reseat_de) > _core.DEFAULT_DENSITY_TOL:
            warnings.warn(
                f"the sample's void ratio moved by {self.reseat_de:+.4f} when it came back "
                f"to rest at its start stresses, more than {_core.DEFAULT_DENSITY_TOL:g}: "
                f"the test starts from e = {self.v0 / self.solid - 1.0:.4f}. The "
                f"consolidation's walls had friction {mu_c:g}, the test's have {mu_t:g}: "
                f"consolidate with wall_friction={mu_t:g} to make the sample as it will be "
                "tested",
                StartMovedWarning,
                stacklevel=stacklevel,
            )
        return int(out["steps"])

    def positions(self) -> dict[str, float]:
        walls = self.sim._sim.walls()
        return {n: float(walls["position"][k]) for k, n in enumerate(self.names)}

    def row(self, step: int, seconds: float, eps_dot: float) -> dict[str, float]:
        """The sample now: strains, stresses, density, contacts, balance."""
        walls = self.sim._sim.walls()
        pos = {n: float(walls["position"][k]) for k, n in enumerate(self.names)}
        stress = walls["force"] / walls["area"]
        volume = _sample_volume(pos, self.scene)
        c = self.sim.contacts()
        forces = contact_forces(c.normal, c.force_normal, c.force_tangential)
        lw = love_weber(forces, c.branch, volume)
        s1 = float(stress[self.lid])
        if self.sides:
            s3 = float(np.mean(stress[self.sides]))
        else:  # a periodic cell: its lateral stress passes through the seams
            s3 = float(np.trace(lw[:-1, :-1]) / (self.dim - 1))
        p, q = _p_q(s1, s3, self.dim)
        lw1 = float(lw[-1, -1])
        lw3 = float(np.trace(lw[:-1, :-1]) / (self.dim - 1))
        lw_p, lw_q = _p_q(lw1, lw3, self.dim)
        pp = c.particle_pairs()
        n = len(self.pack)
        degree = degrees(pp.i, pp.j, n)
        n1 = int(np.sum(degree == 1))
        active = n - int(np.sum(degree == 0)) - n1
        if len(pp) > 0:
            fabric = fabric_tensor(pp.normal)
            f_zz = float(fabric[-1, -1])
            f_dev = f_zz - float(np.trace(fabric[:-1, :-1]) / (self.dim - 1))
        else:
            f_zz = f_dev = math.nan
        phi = self.solid / volume
        return {
            "step": step,
            "time": seconds,
            "eps_a": (self.h0 - (pos["lid"] - pos["floor"])) / self.h0,
            "eps_v": (self.v0 - volume) / self.v0,
            "sigma_1": s1,
            "sigma_3": s3,
            "p": p,
            "q": q,
            "eta": q / p if p > 0 else math.nan,
            "lw_p": lw_p,
            "lw_q": lw_q,
            "e": 1.0 / phi - 1.0,
            "phi": phi,
            "z": 2.0 * len(pp) / n,
            "z_m": (2.0 * len(pp) - n1) / active if active > 0 else math.nan,
            "fabric_zz": f_zz,
            "fabric_dev": f_dev,
            "unbalanced": float(self.sim._sim.force_balance()["unbalanced"]),
            "inertial": eps_dot * self.d_mean * math.sqrt(self.rho / p) if p > 0 else math.nan,
        }

    def final_pack(self, stage: str, settings: dict, report: dict, seconds: float, steps: int):
        """The sample now as a Pack, the test's record appended to its history. Side
        walls that moved make the box (or cylinder) the pack's container, its corner at
        the origin, as the consolidation's pack does."""
        sc, dim = self.scene, self.dim
        pos = self.positions()
        x = np.array(self.sim.positions, dtype=np.float64)
        contacts = self.sim.contacts()
        j = contacts.j.copy()
        j[j == -len(self.names)] = LID_ID
        shift = np.zeros(dim)
        scene = sc
        if sc.container == "box":
            axes = ["x", "y"][: dim - 1]
            shift[: dim - 1] = [-pos[f"{a}_lo"] for a in axes]
            base = tuple(pos[f"{a}_hi"] - pos[f"{a}_lo"] for a in axes)
            scene = sc.replace(base=base)
        elif sc.container == "cylinder":
            radius = pos["cylinder"]
            shift[:2] = radius - sc.base[0] / 2.0
            scene = sc.replace(base=(2.0 * radius, 2.0 * radius), cylinder_radius=radius)
        walls = self.sim._sim.walls()
        stress = {n: float(walls["force"][k] / walls["area"][k]) for k, n in enumerate(self.names)}
        held = {"lid": stress["lid"]}
        if stage != "oedometer":
            held.update({n: stress[n] for n in self.names if n not in ("floor", "lid")})
        report = {
            **report,
            # what the consolidation's record gives the exports and the analysis: where
            # the sample ends (its lid height, its walls), the walls' stresses, and the
            # stresses a continuation holds (the lid's, and the side walls' where the test
            # controlled them)
            "mode": stage,
            "height": pos["lid"] - pos["floor"],
            "wall_stress": stress,
            "targets": held,
            "walls": {n: v + _wall_shift(n, shift) for n, v in pos.items()},
        }
        record = StageRecord(
            stage=stage, settings=settings, report=report, seconds=seconds, steps=steps
        )
        return dataclasses.replace(
            self.pack,
            scene=scene,
            positions=x + shift,
            velocities=np.array(self.sim.velocities),
            spins=np.array(self.sim.spins),
            contacts=Contacts.from_dict({**contacts.to_dict(), "j": j}),
            height=pos["lid"] - pos["floor"],
            history=(*self.pack.history, record),
        )


def _start_targets(pack: Pack, rec: StageRecord, names: list[str]) -> dict[str, float]:
    """The walls' stresses a test starts from: where the pack's last element test left
    them (the lid's sigma_1, and the side walls' sigma_3 where that test controlled
    them), or the consolidation's targets."""
    last = pack.history[-1]
    if last.stage not in _TESTS:
        return dict(rec.settings.get("targets", {"lid": rec.report["wall_stress"]["lid"]}))
    row = {k: v[-1] for k, v in last.report["table"].items()}
    out = {"lid": float(row["sigma_1"])}
    if last.stage != "oedometer":
        out.update({n: float(row["sigma_3"]) for n in names if n not in ("floor", "lid")})
    return out


def _p_q(s1: float, s3: float, dim: int) -> tuple[float, float]:
    """Mean stress p and deviator q of an axisymmetric state (s2 = s3 in 3D)."""
    p = (s1 + 2.0 * s3) / 3.0 if dim == 3 else 0.5 * (s1 + s3)
    return p, s1 - s3


def _table(rows: list[dict]) -> dict[str, list]:
    """Rows as columns (JSON lists), NaN as None."""
    cols: dict[str, list] = {k: [] for k in rows[0]}
    for r in rows:
        for k, v in r.items():
            cols[k].append(None if isinstance(v, float) and not math.isfinite(v) else v)
    return cols


def _gravity(gravity: Any, rec: StageRecord) -> bool:
    if gravity is None:
        return bool(rec.settings.get("gravity", False))
    if not isinstance(gravity, bool):
        raise _fail("gravity", gravity, "True, False or None (the consolidation's)")
    return gravity


def triaxial(
    pack: Pack,
    confining: float | None = None,
    *,
    axial_strain: float = 0.25,
    inertial_number: float = DEFAULT_INERTIAL_NUMBER,
    constant_p: bool = False,
    checks: int = 100,
    gravity: bool | None = None,
    local_damping: float = _C["local_damping"],
    gain: float = _C["gain"],
    wall_friction: float | None = 0.0,
    dt: float | None = None,
) -> Pack:
    """A drained triaxial compression (a biaxial one in 2D) of a consolidated pack;
    returns the sample at the end (the input is not changed), its history holding the
    "triaxial" record: the settings, the table (`element_table`) and the lab report
    (`granpack.element.lab.triaxial_report`).

    Parameters
    ----------
    pack : Pack
        A pack consolidated by `granpack.consolidate`, in a box or a cylinder.
    confining : float, optional
        The lateral stress sigma_3 (Pa; N/m in 2D) the side walls hold, in (0, 1e12].
        Default: the consolidation's lateral target (isotropic or anisotropic; the mean of
        an anisotropic pair). An oedometric sample has none: give it.
    axial_strain : float
        The final axial strain (H0 - H) / H0, in (0, 1). Default 0.25.
    inertial_number : float
        The loading rate as I = eps_dot d_mean sqrt(rho / sigma_3), in (0, 0.1]. Default
        1e-3 (quasi-static; docs/element_tests.md measures 1e-4 beside it).
    constant_p : bool
        Hold the mean stress p of the walls at its start value (the first row's)
        instead of sigma_3: the side walls follow sigma_3 = (3 p - sigma_1) / 2
        (2 p - sigma_1 in 2D). Default False.
    checks : int
        Rows of the table along the path (the start included), in [2, 100000]. Default
        100.
    gravity : bool, optional
        Gravity (the scene's) during the test. Default: as in the consolidation.
    local_damping : float
        Local non-viscous damping, in [0, 1). Default 0.4, the consolidation's.
    gain : float
        The side walls' servo gain, in (0, 1]. Default 0.5.
    wall_friction : float or None
        The walls' Coulomb friction during the test, >= 0, or None for the material's.
        Default 0: smooth platens and side walls, as in YADE's triaxial scripts and a
        lubricated lab test; walls with friction carry part of the lid's load down the
        sides (Janssen), and the sample's stress is then not the walls'.
    dt : float, optional
        Time step (s). Default `stage_time_step` at 5 sigma_3 (the peak's axial stress
        at most), never above the consolidation's.

    Raises
    ------
    InvalidParameterError
        A setting out of range, a pack that is not consolidated, or a periodic cell (it
        has no side walls to hold sigma_3: run `oedometer` or `isotropic_compression`).
    """
    rec = _consolidated(pack, "triaxial test")
    sc = pack.scene
    if sc.container == "periodic":
        raise InvalidParameterError(
            "invalid container = 'periodic' for a triaxial test: a periodic cell has no side "
            "walls to hold the confining stress sigma_3; consolidate the deposit in a box or "
            "a cylinder, or run granpack.oedometer or granpack.isotropic_compression",
            parameter="container",
            value="periodic",
            expected="'box' or 'cylinder'",
        )
    if confining is None:
        targets = {k: v for k, v in rec.settings.get("targets", {}).items() if k != "lid"}
        if not targets:
            raise InvalidParameterError(
                "invalid confining = None: the sample was consolidated oedometrically and has "
                "no lateral target; give confining (Pa), the sigma_3 the side walls hold",
                parameter="confining",
                expected="a number in (0, 1e+12] Pa",
            )
        confining = float(np.mean(list(targets.values())))
    v = _triaxial_values(
        confining=confining,
        axial_strain=axial_strain,
        inertial_number=inertial_number,
        constant_p=constant_p,
        checks=checks,
        local_damping=local_damping,
        gain=gain,
        wall_friction=wall_friction,
    )
    confining, axial_strain = v["confining"], v["axial_strain"]
    inertial_number, constant_p, checks = v["inertial_number"], v["constant_p"], v["checks"]
    local_damping, gain, wall_friction = v["local_damping"], v["gain"], v["wall_friction"]
    grav = _gravity(gravity, rec)
    default_dt = min(
        float(rec.settings.get("dt", sc.dt)), stage_time_step(pack, PEAK_STRESS_RATIO * confining)
    )
    step = default_dt if dt is None else _real("dt", dt, 0.0, default_dt)

    start = time.perf_counter()
    rig = _Rig(pack, rec, step, grav, wall_friction)
    # the start: the sample in equilibrium again at its consolidation (its height H0)
    reseat = rig.reseat(rec, stacklevel=3)
    eps_dot = inertial_number / (rig.d_mean * math.sqrt(rig.rho / confining))
    speed = eps_dot * rig.h0
    total = math.ceil(axial_strain * rig.h0 / (speed * step))
    if total > _core.MAX_STEPS_PER_CALL:
        raise InvalidParameterError(
            f"invalid inertial_number = {inertial_number:g}: the test would take {total} steps "
            f"of {step:.3g} s, more than {_core.MAX_STEPS_PER_CALL}; give a larger inertial "
            "number or a smaller axial_strain",
            parameter="inertial_number",
            value=inertial_number,
        )
    width = max(float(b) for b in sc.base)
    cap = OVERRUN_FRACTION * float(np.min(pack.radii)) / step
    lateral_speed = min(cap, max(LATERAL_SPEED_FACTOR * eps_dot * width, speed))
    if speed > cap:
        raise InvalidParameterError(
            f"invalid inertial_number = {inertial_number:g}: the lid would move {speed:.3g} m/s, "
            f"more than {OVERRUN_FRACTION} r_min per step of {step:.3g} s; give a smaller one",
            parameter="inertial_number",
            value=inertial_number,
        )
    bounds = np.unique(np.round(np.linspace(0, total, checks)).astype(np.int64))
    rows = [rig.row(0, 0.0, eps_dot)]
    # constant p: the walls' mean stress at the start, the sample re-seated
    mean_stress = float(rows[0]["p"]) if constant_p else None
    done = 0
    for stop in bounds[1:]:
        rig.sim._sim.shear(
            rig.lid,
            speed,
            rig.sides,
            confining=None if constant_p else confining,
            mean_stress=mean_stress,
            steps=int(stop - done),
            max_wall_speed=lateral_speed,
            gain=gain,
            local_damping=local_damping,
        )
        done = int(stop)
        rows.append(rig.row(done, done * step, eps_dot))
    seconds = time.perf_counter() - start
    table = _table(rows)
    settings = {
        "confining": confining,
        "axial_strain": axial_strain,
        "inertial_number": inertial_number,
        "constant_p": constant_p,
        "mean_stress": mean_stress,
        "checks": checks,
        "gravity": grav,
        "local_damping": local_damping,
        "gain": gain,
        "wall_friction": wall_friction,
        "dt": step,
        "strain_rate": eps_dot,
        "lid_speed": speed,
        "max_wall_speed": lateral_speed,
        "reseat_steps": reseat,
        "reseat_void_ratio_change": rig.reseat_de,
    }
    report = {
        "table": table,
        "start_height": rig.h0,
        "start_volume": rig.v0,
        "lab": lab.triaxial_report(_frame(table), rig.dim),
    }
    return rig.final_pack("triaxial", settings, report, seconds, total)


def _stress_path(
    test: str,
    pack: Pack,
    stresses: Any,
    *,
    stress_tol: float,
    unbalanced_tol: float,
    hold: int,
    check_every: int,
    max_steps: int,
    gain: float,
    local_damping: float,
    gravity: bool | None,
    wall_friction: float | None,
    dt: float | None,
) -> Pack:
    """The oedometer's and the isotropic compression's loop: each stress held to
    equilibrium in turn, one row each."""
    rec = _consolidated(pack, "oedometer" if test == "oedometer" else "isotropic compression")
    sc = pack.scene
    if test == "isotropic" and sc.container == "periodic":
        raise InvalidParameterError(
            "invalid container = 'periodic' for an isotropic compression: a periodic cell has "
            "no side walls to load; consolidate the deposit in a box or a cylinder, or run "
            "granpack.oedometer",
            parameter="container",
            value="periodic",
            expected="'box' or 'cylinder'",
        )
    checked = _path_values(
        sc,
        stresses=stresses,
        stress_tol=stress_tol,
        unbalanced_tol=unbalanced_tol,
        hold=hold,
        check_every=check_every,
        max_steps=max_steps,
        gain=gain,
        local_damping=local_damping,
        wall_friction=wall_friction,
    )
    targets, stress_tol = checked["stresses"], checked["stress_tol"]
    gain, wall_friction = checked["gain"], checked["wall_friction"]
    grav = _gravity(gravity, rec)
    default_dt = min(float(rec.settings.get("dt", sc.dt)), stage_time_step(pack, max(targets)))
    step = default_dt if dt is None else _real("dt", dt, 0.0, default_dt)
    rig = _Rig(pack, rec, step, grav, wall_friction)
    cap = OVERRUN_FRACTION * float(np.min(pack.radii)) / step
    rows = []
    start = time.perf_counter()
    reseat = rig.reseat(rec, stacklevel=4)
    steps = 0
    # the first row: the sample at its consolidation, in equilibrium again
    first = rig.row(0, 0.0, 0.0)
    previous = first["sigma_1"] if test == "oedometer" else first["p"]
    first["target"] = previous
    if test == "oedometer":
        first["k0"] = first["sigma_3"] / first["sigma_1"]
    rows.append(first)
    for target in targets:
        # the consolidation's quasi-static wall speed, at the lower of the two stresses
        height = rig.positions()["lid"]
        level = max(min(previous, target), 1e-12)
        speed = min(cap, INERTIAL_NUMBER * height * math.sqrt(level / rig.rho) / rig.d_mean)
        walls = [rig.lid] if test == "oedometer" else [rig.lid, *rig.sides]
        out: dict[str, Any] = dict(
            rig.sim._sim.consolidate(
                [(w, target) for w in walls],
                stress_tol=stress_tol,
                unbalanced_tol=checked["unbalanced_tol"],
                hold=checked["hold"],
                check_every=checked["check_every"],
                max_steps=checked["max_steps"],
                max_wall_speed=speed,
                gain=gain,
                local_damping=checked["local_damping"],
            )
        )
        _check_converged(out, [rig.names[w] for w in walls], {**checked, "stress_tol": stress_tol})
        steps += int(out["steps"])
        row = rig.row(steps, steps * step, 0.0)
        row["target"] = target
        if test == "oedometer":
            row["k0"] = row["sigma_3"] / row["sigma_1"]
        rows.append(row)
        previous = target
    seconds = time.perf_counter() - start
    table = _table(rows)
    settings = {
        "stresses": targets,
        "stress_tol": stress_tol,
        "unbalanced_tol": checked["unbalanced_tol"],
        "hold": checked["hold"],
        "check_every": checked["check_every"],
        "max_steps": checked["max_steps"],
        "gain": gain,
        "local_damping": checked["local_damping"],
        "wall_friction": wall_friction,
        "gravity": grav,
        "dt": step,
        "reseat_steps": reseat,
        "reseat_void_ratio_change": rig.reseat_de,
    }
    report = {
        "table": table,
        "start_height": rig.h0,
        "start_volume": rig.v0,
        "lab": lab.compression_report(_frame(table), test=test),
    }
    return rig.final_pack(test, settings, report, seconds, steps)


def oedometer(
    pack: Pack,
    stresses: Sequence[float],
    *,
    stress_tol: float = _C["stress_tol"],
    unbalanced_tol: float = _C["unbalanced_tol"],
    hold: int = _C["hold"],
    check_every: int = _C["check_every"],
    max_steps: int = _C["max_steps"],
    gain: float = _C["gain"],
    local_damping: float = _C["local_damping"],
    gravity: bool | None = None,
    wall_friction: float | None = 0.0,
    dt: float | None = None,
) -> Pack:
    """Oedometric loading and unloading of a consolidated pack: the lid's servo takes
    each stress of `stresses` in turn and holds it to equilibrium (as
    `granpack.consolidate` does), the side walls fixed (a periodic cell keeps its
    periods). Returns the sample at the last stress; its history gains the "oedometer"
    record with one row for the start (the sample at its consolidation) and one per
    stress (K0 = sigma_3 / sigma_1 in ``k0``), and Cc and Cs
    (`granpack.element.lab.compression_report`).

    Parameters
    ----------
    pack : Pack
        A pack consolidated by `granpack.consolidate`: box, cylinder or periodic cell.
    stresses : sequence of float
        The lid's stresses sigma_1 (Pa; N/m in 2D), each in (0, 1e12], in the order to
        apply them, e.g. [25e3, 50e3, 100e3, 200e3, 400e3, 200e3, 100e3, 50e3]; at least
        one.
    stress_tol, unbalanced_tol, hold, check_every, max_steps, gain, local_damping
        The equilibrium at each stress, as `granpack.consolidate` takes them (defaults
        1e-3, 1e-4, 5, 100, 2e6, 0.5, 0.4).
    gravity : bool, optional
        Default: as in the consolidation.
    wall_friction : float or None
        The walls' Coulomb friction, >= 0, or None for the material's. Default 0 (a
        lubricated ring; `triaxial` says why).
    dt : float, optional
        Time step (s). Default `stage_time_step` at the largest stress, never above the
        consolidation's.

    Raises
    ------
    InvalidParameterError
        A setting out of range, an empty list, or a pack that is not consolidated.
    ConsolidationError
        A stress that `max_steps` does not bring to equilibrium.
    """
    return _stress_path(
        "oedometer",
        pack,
        stresses,
        stress_tol=stress_tol,
        unbalanced_tol=unbalanced_tol,
        hold=hold,
        check_every=check_every,
        max_steps=max_steps,
        gain=gain,
        local_damping=local_damping,
        gravity=gravity,
        wall_friction=wall_friction,
        dt=dt,
    )


def isotropic_compression(
    pack: Pack,
    stresses: Sequence[float],
    *,
    stress_tol: float = _C["stress_tol"],
    unbalanced_tol: float = _C["unbalanced_tol"],
    hold: int = _C["hold"],
    check_every: int = _C["check_every"],
    max_steps: int = _C["max_steps"],
    gain: float = _C["gain"],
    local_damping: float = _C["local_damping"],
    gravity: bool | None = None,
    wall_friction: float | None = 0.0,
    dt: float | None = None,
) -> Pack:
    """Isotropic compression of a consolidated pack in a box or a cylinder: every wall's
    servo (the lid and the side walls) takes each stress of `stresses` in turn and holds
    it to equilibrium. Returns the sample at the last stress; its history gains the
    "isotropic" record with one row for the start and one per stress (the e-ln p line:
    lambda and kappa,
    `granpack.element.lab.compression_report`). The settings are `oedometer`'s.

    Raises
    ------
    InvalidParameterError
        A setting out of range, an empty list, a periodic cell, or a pack that is not
        consolidated.
    ConsolidationError
        A stress that `max_steps` does not bring to equilibrium.
    """
    return _stress_path(
        "isotropic",
        pack,
        stresses,
        stress_tol=stress_tol,
        unbalanced_tol=unbalanced_tol,
        hold=hold,
        check_every=check_every,
        max_steps=max_steps,
        gain=gain,
        local_damping=local_damping,
        gravity=gravity,
        wall_friction=wall_friction,
        dt=dt,
    )


_TESTS = ("triaxial", "oedometer", "isotropic")


def _frame(table: dict[str, list]):
    import polars as pl

    return pl.DataFrame(
        {k: [math.nan if v is None else v for v in col] for k, col in table.items()},
        strict=False,
    )


def element_table(pack: Pack, test: str | None = None):
    """The table of the pack's last element test (or of its last `test`: "triaxial",
    "oedometer" or "isotropic") as a polars DataFrame, one row per check; the columns
    are in docs/element_tests.md. NaN where a quantity is undefined (no contact)."""
    if not isinstance(pack, Pack):
        raise _fail("pack", pack, "a granpack.Pack")
    if test is not None and test not in _TESTS:
        raise _fail("test", test, f"one of {', '.join(_TESTS)} or None")
    names = _TESTS if test is None else (test,)
    for rec in reversed(pack.history):
        if rec.stage in names:
            return _frame(rec.report["table"])
    raise InvalidParameterError(
        f"invalid pack: its history holds no {test or 'element'} test", parameter="pack"
    )
