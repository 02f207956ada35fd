"""Consolidation: a generated pack driven by servo-controlled walls to a target stress and
held there until it is in static equilibrium (a sample ready for an element test).

`consolidate` closes the container with a lid on the pack's top, and moves the controlled
walls with the engine's servo (``granpack._core.Simulation.consolidate``; the law and its
reasons are in docs/consolidation.md) until, for `hold` consecutive checks, every
controlled stress is within `stress_tol` of its target and YADE's unbalanced-force ratio
is at most `unbalanced_tol`. It returns a new `Pack` whose `consolidation` record holds
the walls, the targets, the stress state and the equilibrium reached.

Modes:
- ``"oedometric"`` (K0): the lid controls sigma_zz; the side walls stay where they are,
  or the horizontal axes stay periodic. Box, cylinder and periodic cell, 2D and 3D.
- ``"isotropic"``: the lid and every side wall (the box's four, or the cylinder's
  radius) target `stress`.
- ``"anisotropic"``: the lid targets `stress` (sigma_zz); the side walls target
  `lateral`: one value for all, or (sigma_xx, sigma_yy) in a 3D box.

Isotropic and anisotropic modes need lateral walls: a periodic cell has none.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from . import _core
from ._contact_model import has_rolling
from ._validate import short_repr
from .analysis.stress import contact_forces, love_weber
from .contacts import LID_ID, Contacts
from .errors import ConsolidationError, DensityTargetError, InvalidParameterError
from .history import StageRecord
from .pack import Pack
from .simulation import Simulation

__all__ = ["consolidate", "settle", "ConsolidationError", "MODES", "stage_time_step"]

#: The consolidation modes (the engine's list, `granpack._core.CONSOLIDATION_MODES`).
MODES = _core.CONSOLIDATION_MODES

# The stages' defaults are the engine's (src/scene/stages.rs), as the signatures take them.
_C = _core.DEFAULT_CONSOLIDATE
_R = _core.DEFAULT_REST

#: Gravity is off by default when the target exceeds this many times the weight stress
#: at the floor (the pack's weight over its base).
GRAVITY_OFF_ABOVE = 100.0

#: The quasi-static inertial number the default wall speed keeps to: I = (v / H) d
#: sqrt(rho / sigma) (GDR MiDi 2004: I < 1e-3 is the quasi-static regime).
INERTIAL_NUMBER = 1e-3

#: The largest wall speed, as a fraction of r_min per step: a wall never moves more than
#: this share of the smallest radius in one step, whatever the stress asks.
OVERRUN_FRACTION = 0.05

#: Lowering friction under the servo (a density target, `target_phi`): each phase
#: multiplies the friction by at most this factor until two phases give a slope ...
FRICTION_STEP = 0.5
#: ... and by at least this one when the slope predicts a larger step.
FRICTION_STEP_MIN = 0.1
#: Below this share of the material's friction a phase goes to zero friction.
FRICTION_FLOOR = 0.01
#: Most friction phases (each one run to equilibrium) before the stage gives up.
MAX_FRICTION_PHASES = 16
#: A phase is accepted when its phi lies within this share of density_tol of the target:
#: the rest of the tolerance is the margin for restoring the friction afterwards.
ACCEPT_SHARE = 0.75

#: The stage's step is this fraction of sqrt(m / k) for the stiffest contact it expects
#: (see `stage_time_step`).
STEP_FRACTION = 0.2


def hertz_overlap(force: float, r_eff: float, e_star: float) -> float:
    """The overlap (m) at which a Hertz contact of effective radius `r_eff` carries
    `force`: F = 4/3 E* sqrt(R*) d^(3/2)."""
    return (3.0 * force / (4.0 * e_star * math.sqrt(r_eff))) ** (2.0 / 3.0)


def _volumes(r: np.ndarray, dim: int) -> np.ndarray:
    return np.pi * r**2 if dim == 2 else 4.0 / 3.0 * np.pi * r**3


def _masses(scene, r: np.ndarray) -> np.ndarray:
    """Masses (kg) of spheres of radii `r` of the scene's material, as the engine gives
    them: a disc's per metre of thickness in 2D with inertia_2d = "disc"."""
    disc = scene.dim == 2 and scene.inertia_2d == "disc"
    return scene.material.density * (np.pi * r**2 if disc else 4.0 / 3.0 * np.pi * r**3)


def stage_time_step(pack: Pack, stress: float) -> float:
    """The consolidation stage's time step (s): the scene's dt, or less where the
    contacts at the target are stiffer than the deposit's.

    Under a confining stress the Hertz contacts stiffen (k_n = 2 E* sqrt(R* d) grows
    with the overlap), and the Rayleigh step, a wave-speed estimate that ignores the
    overlap, no longer bounds the step: at 100 kPa with E = 1e8 Pa the scene's 1e-4 s
    leaves the stiffest modes at the edge of the velocity-Verlet limit (omega dt = 2),
    where they ring at every step and the pack never comes to rest. The stage takes
    STEP_FRACTION sqrt(m_min / k) for a contact of the largest particles carrying four
    times the mean force sigma (2 r_max)^2 (contact forces spread about four times
    their mean), at the smallest particle's mass: 5.3e-5 s for example 4.3 at 100 kPa,
    close to YADE's 0.8 of its P-wave step (5.1e-5 s) on the same pack.

    The linear law's springs do not stiffen: its k is the material's normal_stiffness
    k_n at any stress (docs/contact_models.md).
    """
    sc = pack.scene
    e_star = sc.material.e_star
    r_max = float(np.max(pack.radii))
    r_min = float(np.min(pack.radii))
    if sc.material.contact_law == "linear":
        assert sc.material.normal_stiffness is not None  # the linear law requires it
        m_min = float(_masses(sc, np.array([r_min]))[0])
        return min(float(sc.dt), STEP_FRACTION * math.sqrt(m_min / sc.material.normal_stiffness))
    force = 4.0 * stress * (2.0 * r_max) ** 2
    if pack.dim == 2:
        force = 4.0 * stress * 2.0 * r_max  # N per m of thickness over a disc's width
    d = hertz_overlap(force, 0.5 * r_max, e_star)
    k = 2.0 * e_star * math.sqrt(0.5 * r_max * d)
    if k <= 0.0:  # a stress too small to stiffen any contact (it underflows): the scene's
        return float(sc.dt)
    m_min = float(_masses(sc, np.array([r_min]))[0])
    return min(float(sc.dt), STEP_FRACTION * math.sqrt(m_min / k))


def consolidate(
    pack: Pack,
    stress: float,
    mode: str = _C["mode"],
    *,
    lateral=_C["lateral"],
    gravity: bool | None = _C["gravity"],
    stress_tol: float = _C["stress_tol"],
    unbalanced_tol: float = _C["unbalanced_tol"],
    hold: int = _C["hold"],
    check_every: int = _C["check_every"],
    max_steps: int = _C["max_steps"],
    max_wall_speed: float | None = _C["max_wall_speed"],
    gain: float = _C["gain"],
    local_damping: float = _C["local_damping"],
    dt: float | None = _C["dt"],
    wall_friction: float | None = _C["wall_friction"],
    target_phi: float | None = None,
    density_tol: float = _core.DEFAULT_DENSITY_TOL,
) -> Pack:
    """Consolidates `pack` to a target stress with servo-controlled walls, until it is
    in static equilibrium; returns a new Pack (the input is not changed).

    Parameters
    ----------
    pack : Pack
        A generated pack (`granpack.generate`, `granpack.load_pack`), with at least one
        particle.
    stress : float
        Target normal stress on the lid, sigma_zz (Pa; N/m in 2D), in (0, 1e12].
    mode : {"oedometric", "isotropic", "anisotropic"}
        Which walls the servo moves (see the module's notes). Default "oedometric".
    lateral : float or (float, float), optional
        The side walls' target (Pa) in the anisotropic mode: one value (sigma_rr in a
        cylinder), or (sigma_xx, sigma_yy) in a 3D box.
    gravity : bool, optional
        Gravity (the scene's) during the stage. Default: on, unless `stress` exceeds
        GRAVITY_OFF_ABOVE (100) times the weight stress at the floor; then the weight's
        share of the stress is below 1 % and the sample is uniform in depth.
    stress_tol : float
        Largest |sigma - sigma*| / sigma* at equilibrium, in [1e-9, 1). Default 1e-3.
    unbalanced_tol : float
        Largest unbalanced-force ratio (mean |net force| over mean |contact force|) at
        equilibrium, in [1e-9, 1). Default 1e-4.
    hold : int
        Consecutive checks that must meet both tolerances, in [1, 1000]. Default 5.
    check_every : int
        Steps between checks, in [1, 1e6]. Default 100.
    max_steps : int
        Step budget, in [1, 1e10]. Default 2e6. Reaching it raises ConsolidationError.
    max_wall_speed : float, optional
        Largest wall speed (m/s), the loading rate; the sample depends on it. Default:
        the speed that keeps the inertial number I = (v/H) d_mean sqrt(rho/sigma) at
        1e-3, and never above 0.05 r_min per step.
    gain : float
        Servo gain, the share of the stress error corrected per step, in (0, 1].
        Default 0.5.
    local_damping : float
        Local non-viscous damping during the stage, in [0, 1). Default 0.4 (YADE's
        usual value for quasi-static loading).
    dt : float, optional
        Time step (s). Default `stage_time_step(pack, stress)`.
    wall_friction : float, optional
        The walls' Coulomb friction during the stage (-), finite and >= 0. Default: the
        material's. A sample meant for an element test (`granpack.triaxial`, whose
        walls are smooth) is best made with 0: walls with friction carry part of the
        lid's load down the sides, and a loose sample that was held by them compacts
        when the test takes their friction away (docs/element_tests.md).
    target_phi : float, optional
        A density target, phi between the floor and the lid, in (0, 1). Once the sample
        is in equilibrium and looser than the target, the friction is lowered in phases,
        each run to equilibrium under the servo, until phi lies within density_tol / 2
        of the target; then the material's friction is restored and equilibrium reached
        again (docs/density.md). A material's rolling model stays as it is in every
        phase but one at zero friction, which runs without rolling resistance (mu_r = 0:
        the frictionless dense end); restoring the friction restores it
        (docs/contact_models.md). The record's ``density`` holds the phases. Default:
        none, the stage keeps the material's friction.
    density_tol : float
        Largest |phi - target_phi| at the end, in (0, 0.1]. Default 0.002.

    Raises
    ------
    InvalidParameterError
        A parameter out of range, a mode the container cannot do, an empty pack, or a
        target whose estimated overlap exceeds the scene's `max_overlap_ratio`.
    ConsolidationError
        `max_steps` reached before equilibrium; it says how far the stage got.
    DensityTargetError
        `target_phi` above what zero friction reaches (the window is in the error), or
        below the sample's phi at the material's friction.
    """
    given = dict(locals())  # the arguments, checked below as a scene's table is
    if not isinstance(pack, Pack):
        raise InvalidParameterError(
            f"invalid pack = {short_repr(pack)}: expected a granpack.Pack",
            parameter="pack",
        )
    if len(pack) == 0:
        raise InvalidParameterError(
            "invalid pack: it holds no particle; there is nothing to consolidate",
            parameter="pack",
        )
    if pack.record("consolidate") is not None:
        raise InvalidParameterError(
            "invalid pack: it is consolidated already (its lid is in its record); "
            "consolidate the deposit it came from",
            parameter="pack",
        )
    sc = pack.scene
    dim = pack.dim
    mat = sc.material
    r = pack.radii
    r_mean, r_min = float(np.mean(r)), float(np.min(r))
    # the engine's one check of the stage's settings (the scene's table meets the same),
    # with every target against what the Hertz law and the positions allow for this
    # pack's own radii; it names the keys as the table does (`consolidate.stress`)
    s = _core.resolve_stage(
        "consolidate",
        sc,
        {k: v for k, v in given.items() if k in _core.CONSOLIDATE_KEYS},
        r_mean=r_mean,
        r_min=r_min,
    )
    _core.resolve_stage("density", sc, {"target_phi": target_phi, "density_tol": density_tol})
    stress, mode, gravity = s["stress"], s["mode"], s["gravity"]
    targets = dict(s["targets"])
    top = max(targets.values())
    step = stage_time_step(pack, top) if s["dt"] is None else s["dt"]

    weight_stress = float(np.sum(_masses(sc, r))) * float(sc.gravity) / float(sc.base_area)
    if gravity is None:
        gravity = bool(stress <= GRAVITY_OFF_ABOVE * weight_stress)

    height = float(np.max(pack.positions[:, -1] + r))
    cap = OVERRUN_FRACTION * r_min / step
    if s["max_wall_speed"] is None:
        d_mean = 2.0 * r_mean
        quasi_static = INERTIAL_NUMBER * height * math.sqrt(stress / mat.density) / d_mean
        max_wall_speed = min(quasi_static, cap)
    elif s["max_wall_speed"] > cap:
        # the pack's own cap, below the stage's range (0, MAX_WALL_SPEED]
        max_wall_speed = s["max_wall_speed"]
        raise InvalidParameterError(
            f"invalid consolidate.max_wall_speed = {max_wall_speed}: must lie in (0, {cap}] "
            f"(m/s): at most {OVERRUN_FRACTION} r_min per step of {step:.6g} s",
            parameter="consolidate.max_wall_speed",
            value=max_wall_speed,
            expected=f"(0, {cap:.6g}] m/s",
        )
    else:
        max_wall_speed = s["max_wall_speed"]

    sim = _simulation(pack, step, gravity, drag=0.0)
    if s["wall_friction"] is not None:
        sim._sim.set_wall_friction(s["wall_friction"])
    lid = sim._sim.add_lid(height)
    names = list(s["walls"])
    assert lid == len(names) - 1
    index = {n: k for k, n in enumerate(names)}
    order = list(targets)
    start = time.perf_counter()

    def run() -> dict:
        out: dict = dict(
            sim._sim.consolidate(
                [(index[n], targets[n]) for n in order],
                stress_tol=s["stress_tol"],
                unbalanced_tol=s["unbalanced_tol"],
                hold=s["hold"],
                check_every=s["check_every"],
                max_steps=s["max_steps"],
                max_wall_speed=max_wall_speed,
                gain=s["gain"],
                local_damping=s["local_damping"],
            )
        )
        _check_converged(out, order, s)
        return out

    rep = run()
    density = None
    if target_phi is not None:
        solid = float(np.sum(_volumes(r, dim)))

        def phi_now() -> float:
            return solid / _sample_volume(_wall_positions(sim, names), sc)

        rep, density = _lower_friction(sim, run, phi_now, rep, target_phi, density_tol, mat)
    seconds = time.perf_counter() - start
    record = _consolidated_pack(
        pack,
        sim,
        names,
        targets,
        rep,
        seconds,
        # what it ran with: the checked settings, and the defaults it chose
        settings={
            **{
                k: s[k]
                for k in _core.CONSOLIDATE_KEYS
                # the walls' own friction where one was given (a record without it:
                # the material's, as before the key existed)
                if k not in ("stress", "lateral") and (k != "wall_friction" or s[k] is not None)
            },
            "gravity": gravity,
            "max_wall_speed": max_wall_speed,
            "dt": step,
        },
        density=density,
    )
    return record


def _check_converged(rep: dict, order: list[str], s: dict) -> None:
    """Raises ConsolidationError when a servo run ended on its step budget."""
    hist = rep["history"]
    last = {n: float(hist["stress"][-1, k]) for k, n in enumerate(order)}
    if not rep["converged"]:
        raise ConsolidationError(
            f"consolidation did not reach equilibrium in max_steps = {s['max_steps']} steps: "
            f"stresses {', '.join(f'{n} {v:.6g} Pa' for n, v in last.items())} "
            f"(largest error {hist['stress_error'][-1]:.2e}, stress_tol {s['stress_tol']:g}), "
            f"unbalanced ratio {hist['unbalanced'][-1]:.2e} (unbalanced_tol "
            f"{s['unbalanced_tol']:g}); give more max_steps, or looser tolerances",
            steps=int(rep["steps"]),
            stress=last,
            stress_error=float(hist["stress_error"][-1]),
            unbalanced=float(hist["unbalanced"][-1]),
        )


def _wall_positions(sim: Simulation, names: list[str]) -> dict[str, float]:
    """Each wall's position now (m), by name."""
    walls = sim._sim.walls()
    return {n: float(walls["position"][k]) for k, n in enumerate(names)}


def _sample_volume(pos: dict[str, float], sc) -> float:
    """The volume between the floor, the lid and the side walls at positions `pos` (m^3;
    m^2 in 2D)."""
    height = pos["lid"] - pos["floor"]
    if sc.container == "cylinder":
        return math.pi * pos["cylinder"] ** 2 * height
    if sc.container == "box":
        area = 1.0
        for a in ["x", "y"][: sc.dim - 1]:
            area *= pos[f"{a}_hi"] - pos[f"{a}_lo"]
        return area * height
    return float(sc.base_area) * height


def _phase_rolling(mat, mu: float) -> float | None:
    """The rolling friction mu_r (-) of a friction phase at `mu`: the material's (its
    rolling model unchanged) at any friction above zero; 0, no rolling resistance, at
    zero friction, the frictionless dense end that stands for the densest state; None
    for a material without a rolling model."""
    if not has_rolling(mat):
        return None
    return 0.0 if mu == 0.0 and mat.friction > 0.0 else float(mat.rolling_friction)


def _set_phase(sim, mat, mu: float) -> None:
    """The engine's contacts switched to the phase at friction `mu`, its rolling
    friction `_phase_rolling` (the material's rolling model is left alone where the
    material has none)."""
    sim._sim.set_friction(mu)
    mu_r = _phase_rolling(mat, mu)
    if mu_r is not None:
        sim._sim.set_rolling_friction(mu_r)


def _lower_friction(sim, run, phi_now, rep, target, tol, mat) -> tuple[dict, dict]:
    """Lowers the friction under the servo, one phase to equilibrium at a time, until
    phi is within ACCEPT_SHARE * tol of `target`, then restores the material's friction
    and reaches equilibrium again. A phase that overshoots is undone (the engine's state
    before it is restored, bit for bit) and a friction between the last two is tried.
    A material's rolling model is kept in every phase but the one at zero friction,
    which runs without rolling resistance (`_phase_rolling`); restoring the friction
    restores it. Returns the last servo report, with the steps of every phase, and the
    record (each phase's ``rolling_friction`` too, for a material with a rolling
    model)."""
    mu0 = float(mat.friction)
    phi0 = phi_now()
    steps = int(rep["steps"])

    def phase(mu: float, phi: float, steps: int) -> dict:
        out: dict = {"friction": mu}
        mu_r = _phase_rolling(mat, mu)
        if mu_r is not None:
            out["rolling_friction"] = mu_r
        return {**out, "phi": phi, "steps": steps, "kept": True}

    phases = [phase(mu0, phi0, steps)]

    def record(phi: float, status: str) -> dict:
        return {
            "target_phi": target,
            "density_tol": tol,
            "phi_before": phi0,
            "phi": phi,
            "phases": phases,
            "status": status,
        }

    if phi0 > target + tol:
        raise _servo_error(
            f"invalid target_phi = {target:g}: the sample is at phi = {phi0:.4f} with the "
            f"material's friction {mu0:g} already, denser than the target; lowering the "
            "friction under the servo only densifies. Reach a looser target by the "
            "deposition friction (density_method = 'deposition')",
            target,
            phi0,
            phi0,
        )
    if abs(phi0 - target) <= ACCEPT_SHARE * tol or mu0 == 0.0:
        if phi0 < target - tol:
            raise _beyond_zero_friction(target, phi0, phi0)
        return rep, record(phi0, "reached at the material's friction")
    below = [(mu0, phi0)]  # phases kept, all looser than the target
    above: tuple[float, float] | None = None  # the nearest phase that overshot
    snapshot = sim._sim.clone()
    reached = False
    for _ in range(MAX_FRICTION_PHASES):
        mu_lo, phi_lo = below[-1]
        if above is not None:
            mu_hi, phi_hi = above
            w = (target - phi_lo) / (phi_hi - phi_lo) if phi_hi > phi_lo else 0.5
            mu = mu_lo + min(max(w, 0.1), 0.9) * (mu_hi - mu_lo)
        else:
            factor = FRICTION_STEP
            if len(below) >= 2 and phi_lo > below[-2][1]:
                (mu_a, phi_a), (mu_b, phi_b) = below[-2], below[-1]
                guess = mu_b + (target - phi_b) * (mu_b - mu_a) / (phi_b - phi_a)
                factor = min(max(guess / mu_b, FRICTION_STEP_MIN), FRICTION_STEP)
            mu = mu_lo * factor
            if mu < FRICTION_FLOOR * mu0:
                mu = 0.0
        _set_phase(sim, mat, mu)
        rep = run()
        steps += int(rep["steps"])
        phi = phi_now()
        phases.append(phase(mu, phi, int(rep["steps"])))
        if abs(phi - target) <= ACCEPT_SHARE * tol:
            reached = True
            break
        if phi < target:
            if mu == 0.0:
                raise _beyond_zero_friction(target, phi0, phi)
            below.append((mu, phi))
            snapshot = sim._sim.clone()
        else:
            # overshot: back to the last kept phase's state, bit for bit
            phases[-1]["kept"] = False
            above = (mu, phi)
            sim._sim = snapshot.clone()
    if not reached:
        raise _servo_error(
            f"target_phi = {target:g} not reached in {MAX_FRICTION_PHASES} friction phases "
            f"under the servo (phi from {phi0:.4f} at friction {mu0:g}; nearest "
            f"{min(phases, key=lambda p: abs(p['phi'] - target))['phi']:.4f}); give a "
            "larger density_tol, or density_method = 'deposition'",
            target,
            phi0,
            min((p["phi"] for p in phases), key=lambda v: abs(v - target)),
        )
    _set_phase(sim, mat, mu0)
    rep = run()
    steps += int(rep["steps"])
    phi = phi_now()
    phases.append(phase(mu0, phi, int(rep["steps"])))
    if abs(phi - target) > tol:
        raise _servo_error(
            f"target_phi = {target:g} reached under lowered friction, but restoring the "
            f"material's friction {mu0:g} moved phi to {phi:.4f}, beyond density_tol = "
            f"{tol:g}; give a larger density_tol",
            target,
            phi0,
            phi,
        )
    return {**rep, "steps": steps}, record(phi, "reached")


def _servo_error(message: str, target: float, phi0: float, realised: float) -> DensityTargetError:
    """The stage's DensityTargetError: the window's lower end is the sample at the
    material's friction; its upper end is unknown where the stage did not reach zero."""
    return DensityTargetError(
        message,
        parameter="target_phi",
        value=target,
        target_phi=target,
        phi_min=phi0,
        phi_max=math.nan,
        realised=realised,
    )


def _beyond_zero_friction(target: float, phi0: float, phi_max: float) -> DensityTargetError:
    return DensityTargetError(
        f"invalid target_phi = {target:g}: out of reach; under the servo the sample goes "
        f"from phi = {phi0:.4f} (the material's friction) to {phi_max:.4f} at zero "
        f"friction, the densest it reaches: the window is [{phi0:.4f}, {phi_max:.4f}]",
        parameter="target_phi",
        value=target,
        target_phi=target,
        phi_min=phi0,
        phi_max=phi_max,
        realised=phi_max,
    )


def _simulation(pack: Pack, dt: float, gravity: bool, drag: float) -> Simulation:
    """The engine with the pack's particles in its container (walls at the scene's
    corners), its material and settings, at step `dt`; gravity the scene's or none."""
    sc = pack.scene
    dim = pack.dim
    g = [0.0] * dim
    if gravity:
        g[-1] = -float(sc.gravity)
    radius = sc.base[0] / 2.0 if sc.container == "cylinder" else None
    sim = Simulation(
        dim,
        sc.material,
        dt,
        gravity=g,
        drag=drag,
        box=([0.0] * dim, [*sc.base, math.inf]),
        rotations=sc.rotations,
        skin_ratio=sc.skin_ratio,
        max_overlap_ratio=sc.max_overlap_ratio,
        inertia_2d=sc.inertia_2d,
        container=sc.container,
        cylinder_radius=radius,
    )
    sim.add_particles(pack.positions, pack.radii, pack.velocities, pack.spins)
    return sim


def settle(
    pack: Pack,
    unbalanced_tol: float = _R["unbalanced_tol"],
    *,
    hold: int = _R["hold"],
    check_every: int = _R["check_every"],
    max_steps: int = _R["max_steps"],
    local_damping: float = _R["local_damping"],
) -> Pack:
    """Runs a deposit on, under its own weight, until it is at rest: YADE's
    unbalanced-force ratio at most `unbalanced_tol` for `hold` checks `check_every` steps
    apart. Returns a new Pack whose `rest` record says how far it went (the input is not
    changed). The scene's dt, gravity and drag; `local_damping` (in [0, 1), default 0.4)
    is the same quasi-static aid as consolidation's. The scene's `rest_tol` runs it at the
    end of `generate`.

    Raises ConsolidationError when `max_steps` runs out first."""
    if not isinstance(pack, Pack):
        raise InvalidParameterError(
            f"invalid pack = {short_repr(pack)}: expected a granpack.Pack", parameter="pack"
        )
    if len(pack) == 0:
        raise InvalidParameterError(
            "invalid pack: it holds no particle; there is nothing to settle", parameter="pack"
        )
    if pack.record("consolidate") is not None:
        raise InvalidParameterError(
            "invalid pack: it is consolidated, and so at rest under its lid already",
            parameter="pack",
        )
    sc = pack.scene
    # the engine's check of the settling stage, the one the scene's rest_tol meets
    rest = _core.resolve_stage(
        "rest",
        sc,
        {
            "unbalanced_tol": unbalanced_tol,
            "hold": hold,
            "check_every": check_every,
            "max_steps": max_steps,
            "local_damping": local_damping,
        },
    )
    unbalanced_tol, hold = rest["unbalanced_tol"], rest["hold"]
    check_every, max_steps = rest["check_every"], rest["max_steps"]
    local_damping = rest["local_damping"]
    sim = _simulation(pack, float(sc.dt), True, float(sc.drag))
    start = time.perf_counter()
    rep = sim._sim.consolidate(
        [],
        # no wall is controlled: the stress settings and the wall speed are unused
        stress_tol=_C["stress_tol"],
        unbalanced_tol=unbalanced_tol,
        hold=hold,
        check_every=check_every,
        max_steps=max_steps,
        max_wall_speed=1.0,
        gain=_C["gain"],
        local_damping=local_damping,
    )
    seconds = time.perf_counter() - start
    hist = rep["history"]
    if not rep["converged"]:
        raise ConsolidationError(
            f"the deposit did not come to rest in max_steps = {max_steps} steps: the "
            f"unbalanced ratio is {hist['unbalanced'][-1]:.2e} (unbalanced_tol "
            f"{unbalanced_tol:g}); give more max_steps, or a looser unbalanced_tol",
            steps=int(rep["steps"]),
            stress={},
            stress_error=0.0,
            unbalanced=float(hist["unbalanced"][-1]),
        )
    contacts = sim.contacts()
    x = np.array(sim.positions, dtype=np.float64)
    r = pack.radii
    balance = sim._sim.force_balance()
    record = {
        "unbalanced_tol": unbalanced_tol,
        "hold": hold,
        "check_every": check_every,
        "local_damping": local_damping,
        "unbalanced": float(balance["unbalanced"]),
        "max_ratio": float(balance["max_ratio"]),
        "steps": int(rep["steps"]),
        "seconds": seconds,
        "history": {
            "step": hist["step"].tolist(),
            "unbalanced": hist["unbalanced"].tolist(),
            "max_ratio": hist["max_ratio"].tolist(),
        },
    }
    return dataclasses.replace(
        pack,
        positions=x,
        velocities=np.array(sim.velocities),
        spins=np.array(sim.spins),
        contacts=contacts,
        height=float(np.max(x[:, -1] + r)),
        history=(*pack.history, StageRecord.from_table("rest", record)),
    )


def _consolidated_pack(pack, sim, names, targets, rep, seconds, settings, density=None) -> Pack:
    """The new Pack and its record: walls moved to the origin's corner, the stresses
    (and the phases of a density target, `density`, where the friction was lowered)."""
    dim = pack.dim
    sc = pack.scene
    walls = sim._sim.walls()
    pos = {n: float(walls["position"][k]) for k, n in enumerate(names)}
    wall_stress = {n: float(walls["force"][k] / walls["area"][k]) for k, n in enumerate(names)}
    # in the cell: the engine wraps periodic axes
    x = np.array(sim.positions, dtype=np.float64)
    contacts = sim.contacts()
    # the lid's id is the same in every container (granpack.contacts.LID_ID)
    j = contacts.j.copy()
    j[j == -len(names)] = LID_ID
    # Side walls that moved: the box becomes the space between them, its corner at the
    # origin again (the cylinder: its new radius, its axis at (R, R)).
    shift = np.zeros(dim)
    scene = sc
    if sc.container == "box" and any(n in targets for n in ("x_lo", "x_hi", "y_lo", "y_hi")):
        axes = ["x", "y"][: dim - 1]
        shift[: dim - 1] = [-pos[f"{a}_lo"] for a in axes]
        base = tuple(pos[f"{a}_hi"] - pos[f"{a}_lo"] for a in axes)
        scene = _moved_walls_scene(sc, settings["mode"], targets, rep, {"base": base})
    elif sc.container == "cylinder" and "cylinder" in targets:
        radius = pos["cylinder"]
        shift[:2] = radius - sc.base[0] / 2.0
        scene = _moved_walls_scene(
            sc,
            settings["mode"],
            targets,
            rep,
            {"base": (2.0 * radius, 2.0 * radius), "cylinder_radius": radius},
        )
    x = x + shift
    lid = pos["lid"] - pos["floor"]
    vol_solid = float(np.sum(_volumes(pack.radii, dim)))
    # the volume the density target's phases measure too (`_sample_volume`)
    volume = _sample_volume(pos, sc)
    phi = vol_solid / volume
    forces = contact_forces(contacts.normal, contacts.force_normal, contacts.force_tangential)
    lw = love_weber(forces, contacts.branch, volume)
    wall = contacts.j < 0
    points = x[contacts.i[wall]] + contacts.branch[wall]
    boundary = np.einsum("ma,mb->ab", points, forces[wall]) / volume
    if settings["gravity"]:
        g = np.zeros(dim)
        g[-1] = -float(sc.gravity)
        boundary -= np.einsum("n,na,b->ab", sim.masses, x, g) / volume
    if sc.container == "periodic":
        # Across a periodic seam the stress passes from particle to particle, never
        # through a wall: the boundary sum holds only the vertical row (the floor and the
        # lid, whose heights are not wrapped). Its lateral entries, x_c f_c with wrapped
        # x_c, depend on where the cell's origin lies and are no stress; they are NaN.
        row = boundary[-1].copy()
        boundary = np.full((dim, dim), math.nan)
        boundary[-1, :] = row
        boundary[:, -1] = row
    else:
        boundary = 0.5 * (boundary + boundary.T)
    vertical = wall_stress["lid"]
    if sc.container == "periodic":
        lateral = float(np.trace(lw[:-1, :-1]) / (dim - 1))
        lateral_source = "love_weber"
    else:
        sides = [n for n in names if n not in ("floor", "lid")]
        lateral = float(np.mean([wall_stress[n] for n in sides]))
        lateral_source = "walls"
    balance = sim._sim.force_balance()
    hist = rep["history"]
    record = {
        **settings,
        "targets": dict(targets),
        "walls": {n: pos[n] + _wall_shift(n, shift) for n in names},
        "wall_stress": wall_stress,
        "wall_contacts": {n: int(walls["contacts"][k]) for k, n in enumerate(names)},
        "love_weber": lw.tolist(),
        "boundary_stress": boundary.tolist(),
        "k0": lateral / vertical,
        "k0_from": lateral_source,
        "phi": phi,
        "void_ratio": 1.0 / phi - 1.0,
        "height": lid,
        "unbalanced": float(balance["unbalanced"]),
        "max_ratio": float(balance["max_ratio"]),
        "steps": int(rep["steps"]),
        "seconds": seconds,
        "max_speed": float(rep["max_speed"]),
        "shift": shift.tolist(),
        # the deposit's container, which the scene describes no more where side walls
        # moved: generating again from the pack's scene needs it back
        "deposit_base": list(sc.base),
        "history": {
            "step": hist["step"].tolist(),
            "stress": {n: hist["stress"][:, k].tolist() for k, n in enumerate(targets)},
            "stress_error": hist["stress_error"].tolist(),
            "unbalanced": hist["unbalanced"].tolist(),
            "max_ratio": hist["max_ratio"].tolist(),
        },
    }
    if density is not None:
        record["density"] = density
    return dataclasses.replace(
        pack,
        scene=scene,
        positions=x,
        velocities=np.array(sim.velocities),
        spins=np.array(sim.spins),
        contacts=Contacts.from_dict({**contacts.to_dict(), "j": j}),
        height=lid,
        history=(*pack.history, StageRecord.from_table("consolidate", record)),
    )


def _moved_walls_scene(sc, mode: str, targets: dict[str, float], rep: dict, changes: dict):
    """The scene of a sample whose side walls moved: the deposit's with the container
    the walls now bound. A pack's scene is one that generates (its file is read back
    through the scene's checks), whose container holds at least one particle diameter
    2 r_max; side walls squeezed closer than that (a sample one or two particles wide
    under a stress that presses the walls into them) make no such scene, and the stage
    says so in its own terms instead of refusing a base the user never set."""
    try:
        return sc.replace(**changes)
    except InvalidParameterError as exc:
        if exc.parameter not in ("base", "cylinder_radius"):
            raise
        hist = rep["history"]
        lateral = max(v for n, v in targets.items() if n != "lid")
        diameter = f"2 r_max = {2.0 * float(sc.r_max):.6g} m"
        if "cylinder_radius" in changes:
            what = f"its radius to {changes['cylinder_radius']:.6g} m, below {diameter}"
        else:
            apart = " x ".join(f"{b:.6g}" for b in changes["base"])
            what = f"its side walls to {apart} m apart, closer than one diameter {diameter}"
        raise ConsolidationError(
            f"the {mode} consolidation to stress = {targets['lid']:g} Pa (side walls at "
            f"{lateral:g} Pa) squeezed the sample too narrow to keep: it moved {what}, the "
            f"least a pack's {sc.container} must hold. Give the deposit a wider base, or "
            "consolidate it with mode='oedometric' (the side walls stay)",
            steps=int(rep["steps"]),
            stress={n: float(hist["stress"][-1, k]) for k, n in enumerate(targets)},
            stress_error=float(hist["stress_error"][-1]),
            unbalanced=float(hist["unbalanced"][-1]),
        ) from None


def _wall_shift(name: str, shift: np.ndarray) -> float:
    """How far the translation of a consolidated pack moves wall `name` (m)."""
    if name.startswith("x_"):
        return float(shift[0])
    if name.startswith("y_"):
        return float(shift[1])
    return 0.0
