"""Packing scenes: every parameter of the layer-by-layer technique, the paper's presets,
TOML files."""

from __future__ import annotations

import dataclasses
import math
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from numbers import Integral
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import tomli_w

from . import _core
from ._validate import (
    FileFormatError,
    GranpackError,
    InvalidParameterError,
    as_bool,
    as_int,
    as_real,
    short_repr,
    unknown_keys,
)
from .simulation import Material

if TYPE_CHECKING:
    from ._core import ContainerName, DensityMethod, RadiusLawName

__all__ = ["PackScene", "PRESETS", "RSA_SATURATION", "CONTAINERS", "RADIUS_LAWS"]

#: The containers a scene may have (`PackScene.container`), as the engine names them.
CONTAINERS: tuple[ContainerName, ...] = _core.CONTAINERS

#: The radius laws a scene may have (`PackScene.radius_law`; docs/scene.md, "Size
#: distributions"), as the engine names them.
RADIUS_LAWS: tuple[RadiusLawName, ...] = _core.RADIUS_LAWS

#: The keys that choose a pack's random stream: checked alone, as no other key's rule
#: involves them (`PackScene.replace`).
_STREAM_KEYS = frozenset(("seed", "stream"))

#: The scene keys that hold lists of numbers of a radius law.
_LAW_LISTS = ("radii", "fractions", "sieve_sizes", "sieve_passing")

#: Random sequential addition jams near these fractions (Feder 1980 for discs,
#: Talbot et al. 2000 / Torquato et al. 2006 for spheres); a layer fraction at or above
#: them cannot be reached.
RSA_SATURATION = {2: _core.RSA_SATURATION[0], 3: _core.RSA_SATURATION[1]}

_MATERIAL_KEYS = [f.name for f in dataclasses.fields(Material)]

#: Most DEM steps per layer (settle_time / dt); the paper's runs take 1e4.
MAX_STEPS_PER_LAYER = _core.MAX_STEPS_PER_LAYER
#: Most consecutive failed RSA placements (max_attempts); default 1e6.
MAX_ATTEMPTS: int = _core.MAX_ATTEMPTS
#: Most layers (max_layers); default 1e4.
MAX_LAYERS: int = _core.MAX_LAYERS


def _material_table(table: Mapping) -> Material:
    """A Material from a scene's material table; a bad entry is named as it is written
    in the scene, `material.<key>`."""
    unknown_keys("material", table, _MATERIAL_KEYS)
    try:
        return Material(**table)
    except InvalidParameterError as exc:
        # every Material check raises "invalid <key> = ..." (`as_real`) or, for a key
        # that another one needs, "missing <key>: ..."
        text = str(exc)
        for word in ("invalid ", "missing "):
            if text.startswith(word):
                text = word + "material." + text[len(word) :]
                break
        raise InvalidParameterError(
            text,
            parameter=f"material.{exc.parameter}",
            value=exc.value,
            expected=exc.expected,
        ) from None


def _preset_name(value: object) -> str:
    """The preset named by `value`, one of PRESETS' names (strings). A number is refused
    with the quoted name to write: ``preset = 4.1`` unquoted in TOML is a float, and
    4.10 would read the same."""
    names = ", ".join(repr(n) for n in sorted(PRESETS))
    if not isinstance(value, str):
        near = repr(value) if isinstance(value, float) and repr(value) in PRESETS else "4.1"
        raise InvalidParameterError(
            f"invalid preset = {short_repr(value)}: a preset name is a string, written in "
            f'quotes (preset = "{near}" in TOML); choose one of {names}',
            parameter="preset",
            value=value,
            expected=" | ".join(sorted(PRESETS)),
        )
    if value not in PRESETS:
        raise InvalidParameterError(
            f"unknown preset {short_repr(value)}: choose one of {names}",
            parameter="preset",
            value=value,
            expected=" | ".join(sorted(PRESETS)),
        )
    return value


#: What an empty scene file is told: a scene read from a file says what it is, so that a
#: truncated or wrong file is not run silently as the defaults.
_EMPTY_SCENE = (
    'a scene read from TOML must say what it is: write preset = "4.1" (the defaults, '
    "the paper's example 4.1) or set the keys (docs/scene.md)"
)

_TOO_DEEP = (
    "values are nested too deeply (a scene holds numbers, strings, flat lists and one "
    "[material] table)"
)

#: Adaptive settling tolerance of `PackScene.fast()` (kinetic energy per moving particle
#: over m g r).
FAST_SETTLE_TOL = 1e-2
#: Freezing depth of `PackScene.fast()`, in layer thicknesses h_layer.
FAST_FREEZE_LAYERS = 1.0
#: Time step of `PackScene.fast()`, as a fraction of the Rayleigh estimate for r_min
#: (never below the scene's own dt). A landing collision then lasts about 6 steps, and
#: its restitution, averaged over where in a step the contact begins, is within 0.5 %
#: of the resolved one, as at the paper's dt (`studies/collision_dt/collision_dt.py`); 20
#: packs of 4.3 lie within 0.54 sd of the full-fidelity ensemble (docs/performance.md,
#: "The fast settings").
FAST_DT_RAYLEIGH = 0.55
#: Time step of `PackScene.fast()` once a layer has fallen through its slab (settle_dt),
#: as a fraction of the Rayleigh estimate (unset where the scene's dt is already at
#: least that). The landing collisions are over by then; what follows is rolling and
#: creep, which the coarser step resolves as well: 20 packs of 4.3 lie within 0.54 sd
#: of the full-fidelity ensemble, where 0.75 from the start moved Z by -1.12 sd
#: (docs/performance.md, "The fast settings").
FAST_SETTLE_DT_RAYLEIGH = 0.75


@dataclass(frozen=True)
class PackScene:
    """A packing scene (SI units). Defaults are the paper's example 4.1.

    Attributes
    ----------
    dim : int
        2 (discs, vertical y) or 3 (spheres, vertical z).
    base : tuple of float
        Box lengths along the horizontal axes (m): (L,) in 2D, (B1, B2) in 3D. The box
        spans [0, L] (x [0, B2]); the floor is at 0; the top is open. In a periodic
        container these are the periods; in a cylinder (2R, 2R).
    container : str
        One of `CONTAINERS`: what bounds the pack laterally (the floor is a wall and the top is open
        in all three). "box" (default): the paper's walls at 0 and base. "periodic": the horizontal
        axes are periodic with periods base (2D and 3D): no side walls, centres in [0, L).
        "cylinder" (3D only): a vertical cylinder of radius cylinder_radius with its axis through
        (R, R), so that the pack lies in [0, 2R]^2 laterally.
    cylinder_radius : float or None
        Radius R of the cylinder (m), at least 2 r_max; base is then (2R, 2R). None
        (default): R = base / 2 (base must be square). Only with container="cylinder".
    height : float
        Desired pack height H_d (m): layers are added while max(z + r) < H_d.
    radius_law : str
        One of `RADIUS_LAWS`: the radius distribution (docs/scene.md, "Size
        distributions"). Default "constant".
    r_mean : float
        Radius (constant law), or the mean of the radius before truncation (gaussian,
        lognormal) (m). Derived (the mean by number) for the uniform, discrete and
        sieve laws. Default 0.01.
    r_std : float
        Standard deviation of the radius before truncation (gaussian, lognormal) (m),
        >= 0, default 0. Derived (by number) for the uniform, discrete and sieve laws.
    r_min, r_max : float or None
        Truncation (gaussian, lognormal) or bounds (uniform, both needed) of the radius
        (m). Defaults: r_mean -/+ 3 r_std (gaussian), exp(mu -/+ 3 sigma) of ln r
        (lognormal). Derived for every law: the smallest and largest radius it can
        produce (r_min sets the Rayleigh dt check, r_max the base checks).
    radii : tuple of float or None
        The radii of a discrete mixture (m), strictly increasing.
    fractions : tuple of float or None
        The fraction of each of `radii`, >= 0, summing to 1 within 1e-9.
    fractions_by : {"number", "mass"}
        What `fractions` count. Default "number". Mass is the engine's particle mass:
        r^3 in 3D and for 2D spheres (inertia_2d = "sphere"), r^2 for 2D discs
        (inertia_2d = "disc").
    sieve_sizes : tuple of float or None
        Sieve openings (diameters, m) of a sieve curve, strictly increasing.
    sieve_passing : tuple of float or None
        Cumulative mass fraction passing each of `sieve_sizes`, non-decreasing from 0
        to 1. Within a class the mass is spread log-linearly in the diameter.
    h_layer : float
        Thickness of the slab in which each layer's centres are placed (m). Default 0.1.
    phi_layer : float
        Solid fraction of each RSA layer, in (0, RSA saturation). Default 0.4
        (paper: 0.4 in 2D, 0.25 in 3D).
    material : Material
        Particle and wall material. Default ``Material()``.
    dt : float
        DEM time step (s). Default 1e-4.
    settle_time : float
        DEM time per layer, the jamming stage (s). Default 1.0.
    gravity : float
        Magnitude of the jamming pseudo-force's acceleration, along -vertical (m/s^2).
        Default 2.
    drag : float
        Linear drag constant c_D (N s/m). Default 0.005.
    rotations : bool
        Integrate spins during jamming. Default True.
    seed : int
        Master random seed (>= 0). Default 0.
    stream : int
        Random stream of this pack within an ensemble of the same seed (>= 0). Default 0.
    inertia_2d : {"sphere", "disc"}
        2D mass model. Default "disc": a disc of unit thickness, m = pi r^2 rho per
        metre, I = m r^2 / 2 (LAMMPS ``density/disc``, PFC2D); "sphere": a sphere
        confined to the plane, m = 4/3 pi r^3 rho, I = 2/5 m r^2.
    skin_ratio : float
        Verlet skin over the smallest radius. Default 0.2.
    max_overlap_ratio : float
        Blow-up guard: largest overlap over the smaller radius. Default 0.5.
    max_attempts : int
        Consecutive failed RSA placements before reporting saturation. Default 1e6.
    max_layers : int
        Most layers before giving up. Default 10000.
    settle_tol : float or None
        Adaptive settling: end a layer's jamming run once its kinetic energy per moving
        particle is below settle_tol * m g r (mean particle), after the new layer has had
        time to fall through its slab; settle_time is then the upper bound. None
        (default): the paper's fixed settle_time.
    settle_dt : float or None
        Time step (s) for the rest of each layer's jamming run once the new layer has
        had time to fall through its slab (sqrt(2 h_layer / g) after it is placed), and
        for the last layer's remainder and the final relax; at most the Rayleigh step.
        The landing collisions keep dt. None (default): dt throughout, as the paper.
    freeze_depth : float or None
        Freeze settled particles whose top lies more than this depth (m) below the pack
        height: they are no longer integrated and their mutual contacts keep their last
        force; they thaw when pushed. After the last layer every particle thaws and the
        pack relaxes for 0.1 s (at most settle_time) so that all contacts carry the
        final load. None (default): never freeze.
    freeze_speed : float
        Speed (m/s) under which a buried particle may freeze. Default 1e-3.
    freeze_force : float
        Net force over weight under which a particle may freeze and above which a frozen
        one thaws (-). Default 0.1 (0.5 thaws less often and runs faster, but moved the
        force anisotropy |a^n| of example 4.1 well beyond the full runs' spread).
    trim : bool
        A flat top (default False): after the last layer, remove every particle whose
        top z + r lies above H_d (``height``), then relax the rest as the final relax
        does (0.1 s, at most settle_time, every particle thawed). The pack then ends
        at or below H_d; ``Pack.record("trim")`` records what was removed and phi up to H_d.
    consolidate : dict or None
        A ``[consolidate]`` table: `granpack.consolidate`'s keyword arguments (``stress``
        needed), run on every generated pack. None (default): the pack is a deposit.
    rest_tol : float or None
        A final phase: after the last layer (and the flat top), run the deposit on under
        its own weight until its unbalanced-force ratio is at most rest_tol, in
        [1e-9, 1) (`granpack.settle`). None (default): the paper's recipe ends with the
        last layer's jamming run.
    target_phi : float or None
        A density target: the packing fraction, in (0, 1). At most one of the three
        targets. The pack's phi is taken between the floor and the lid when the scene
        consolidates, and in the core window (`Microstructure.phi_core`) otherwise
        (docs/density.md). None (default): the recipe's density.
    target_void_ratio : float or None
        A density target: the void ratio e = 1/phi - 1, > 0. None (default).
    target_relative_density : float or None
        A density target: Dr = (e_max - e) / (e_max - e_min), in [0, 1], with the
        model's own e_min and e_max for this scene and seed
        (`granpack.void_ratio_limits`). None (default).
    density_tol : float or None
        Largest |realised - target|, in the target's own quantity, in (0, 0.1]. None
        (default): 0.002 in phi, and its equivalent in e or Dr.
    density_method : {"auto", "deposition", "servo"}
        How a target is reached (docs/density.md): "deposition" jams every layer with
        a deposition friction found by search and restores the material's friction
        once the pack is jammed; "servo" lowers the friction while the consolidation's
        servo holds the stress, then restores it (needs ``consolidate``); "auto"
        (default) does the servo's when the scene consolidates and the recipe's pack is
        looser than the target, and the deposition's otherwise.
    triaxial : dict or None
        A ``[triaxial]`` table: `granpack.triaxial`'s keyword arguments (``confining``,
        ``axial_strain``, ``inertial_number``, ``constant_p``, ``checks``, ``gravity``,
        ``local_damping``, ``gain``, ``wall_friction``, ``dt``; each optional), run on
        the consolidated pack (needs ``consolidate``). None (default): no triaxial test.
    oedometer : dict or None
        An ``[oedometer]`` table: `granpack.oedometer`'s keyword arguments
        (``stresses`` needed, Pa), run on the consolidated pack (needs ``consolidate``).
        None (default).
    isotropic : dict or None
        An ``[isotropic]`` table: `granpack.isotropic_compression`'s keyword arguments
        (``stresses`` needed, Pa), run on the consolidated pack (needs ``consolidate``).
        None (default). A scene gives one of the three element tables at most.
    """

    dim: int = 2
    base: tuple[float, ...] = (1.0,)
    container: ContainerName = "box"
    cylinder_radius: float | None = None
    height: float = 0.5
    radius_law: RadiusLawName = "constant"
    r_mean: float = 0.01
    r_std: float = 0.0
    r_min: float | None = None
    r_max: float | None = None
    radii: tuple[float, ...] | None = None
    fractions: tuple[float, ...] | None = None
    fractions_by: Literal["number", "mass"] = "number"
    sieve_sizes: tuple[float, ...] | None = None
    sieve_passing: tuple[float, ...] | None = None
    h_layer: float = 0.1
    phi_layer: float = 0.4
    material: Material = field(default_factory=Material)
    dt: float = 1e-4
    settle_time: float = 1.0
    gravity: float = 2.0
    drag: float = 0.005
    rotations: bool = True
    seed: int = 0
    stream: int = 0
    inertia_2d: Literal["sphere", "disc"] = "disc"
    skin_ratio: float = 0.2
    max_overlap_ratio: float = 0.5
    max_attempts: int = 1_000_000
    max_layers: int = 10_000
    settle_tol: float | None = None
    settle_dt: float | None = None
    freeze_depth: float | None = None
    freeze_speed: float = 1e-3
    freeze_force: float = 0.1
    trim: bool = False
    consolidate: dict | None = None
    rest_tol: float | None = None
    target_phi: float | None = None
    target_void_ratio: float | None = None
    target_relative_density: float | None = None
    density_tol: float | None = None
    density_method: DensityMethod = _core.DEFAULT_DENSITY["density_method"]
    triaxial: dict | None = None
    oedometer: dict | None = None
    isotropic: dict | None = None

    def __post_init__(self) -> None:
        s = object.__setattr__
        dim = self.dim
        if isinstance(dim, bool) or not isinstance(dim, Integral) or dim not in (2, 3):
            raise InvalidParameterError(
                f"invalid dim = {short_repr(self.dim)}: must be 2 or 3", parameter="dim"
            )
        s(self, "dim", int(self.dim))
        # Every key gets its type first, so that the checks which combine keys below
        # (and the engine's, which reads them by attribute) only ever see numbers,
        # strings and lists of the kind they expect.
        self._check_types()
        try:
            base = tuple(self.base)
        except TypeError:
            raise InvalidParameterError(
                f"invalid base = {short_repr(self.base)}: expected {self.dim - 1} lengths (m)",
                parameter="base",
            ) from None
        if len(base) != self.dim - 1:
            raise InvalidParameterError(
                f"invalid base = {short_repr(self.base)}: expected {self.dim - 1} length(s) (m) "
                f"for dim = {self.dim}",
                parameter="base",
            )
        s(self, "base", tuple(as_real("base", b, unit="m") for b in base))
        if not isinstance(self.material, Material):
            if isinstance(self.material, dict):
                s(self, "material", _material_table(self.material))
            else:
                raise InvalidParameterError(
                    f"invalid material = {short_repr(self.material)}: must be a Material",
                    parameter="material",
                )
        self._check_radius_law()
        # Every rule about the values, and what they resolve to, is the engine's: the
        # scene's one validator (src/scene/), the same that the layer loop runs, so a
        # scene that is built is one that generates.
        resolved = _core.resolve_scene(self)
        self._refuse_conflicting_derived(resolved)
        s(self, "r_min", resolved["r_min"])
        s(self, "r_max", resolved["r_max"])
        if self.radius_law in ("constant", "uniform", "discrete", "sieve"):
            s(self, "r_mean", resolved["r_mean"])
            s(self, "r_std", resolved["r_std"])
        s(self, "base", tuple(resolved["base"]))
        s(self, "cylinder_radius", resolved["cylinder_radius"])
        # the [consolidate] table as given, its values typed: the engine checked it with
        # the scene (keys, ranges, the mode against the container, the stresses and the
        # step against these radii and this material), now rather than after the deposit
        s(self, "consolidate", resolved["consolidate"])
        if any(getattr(self, k) is not None for k in _ELEMENT_KEYS):
            # the element tests' own checks of their settings (granpack.element.run),
            # now rather than after the deposit and the consolidation; the engine's
            # scene does not carry these tables
            from .element_settings import check_scene_tables

            for key, table in check_scene_tables(self).items():
                s(self, key, table)

    def _check_types(self) -> None:
        """Types every key (`_KEY_TYPES`) without checking its range: a value of the
        wrong type is an InvalidParameterError naming the key, whatever else is set."""
        s = object.__setattr__
        for key, kind in _KEY_TYPES.items():
            value = getattr(self, key)
            if value is None and kind in _OPTIONAL_KINDS:
                continue
            if kind in ("real", "real?"):
                s(self, key, as_real(key, value, unit=_UNITS.get(key, "")))
            elif kind == "int":
                if isinstance(value, bool) or not isinstance(value, Integral):
                    as_int(key, value, 0)  # raises, naming the key
                s(self, key, int(value))
            elif kind == "bool":
                s(self, key, as_bool(key, value))
            elif kind in ("reals", "reals?"):
                if isinstance(value, str | bytes | Mapping) or not hasattr(value, "__iter__"):
                    raise InvalidParameterError(
                        f"invalid {key} = {short_repr(value)}: expected a list of numbers",
                        parameter=key,
                        value=value,
                        expected="a list of numbers",
                    )
                items = []
                for k, v in enumerate(value):
                    try:
                        items.append(as_real(f"{key}[{k}]", v, unit=_UNITS.get(key, "")))
                    except InvalidParameterError as exc:
                        raise InvalidParameterError(
                            str(exc), parameter=key, value=value, expected="a list of numbers"
                        ) from None
                s(self, key, tuple(items))
            elif kind == "text":
                if not isinstance(value, str):
                    choices = _TEXT_CHOICES[key]
                    raise InvalidParameterError(
                        f"invalid {key} = {short_repr(value)}: must be one of "
                        + ", ".join(repr(c) for c in choices),
                        parameter=key,
                        value=value,
                        expected=" | ".join(choices),
                    )
            elif kind == "consolidate?":
                pass  # a table of the stage's settings: the engine types and checks it
            elif kind == "element?":
                # a table of an element test's settings: its keys and values are checked
                # once the scene is resolved (`granpack.element_settings`)
                if not isinstance(value, Mapping):
                    raise InvalidParameterError(
                        f"invalid {key} = {short_repr(value)}: expected a table of the "
                        f"{key} test's settings (e.g. [{key}] in TOML)",
                        parameter=key,
                        value=value,
                        expected="a table",
                    )
            elif kind == "material":
                if isinstance(value, Mapping) and not isinstance(value, Material):
                    s(self, key, _material_table(dict(value)))
                elif not isinstance(value, Material):
                    raise InvalidParameterError(
                        f"invalid material = {short_repr(value)}: must be a Material or a "
                        "table of material constants",
                        parameter="material",
                        value=value,
                        expected="a Material or a table of material constants",
                    )
            else:  # pragma: no cover - a key added to the scene without its type
                raise AssertionError(f"scene key {key} has no type")

    def _refuse_conflicting_derived(self, resolved: Mapping) -> None:
        """Refuses, by name, a key that the radius law derives (`_DERIVED_KEYS`) given
        with another value than the one derived (``radius_law = "uniform"`` with
        ``r_mean = 0.5``): it would otherwise be replaced silently. Its default, and the
        derived value itself (a scene written and read back, or copied by `replace`),
        are taken."""
        for key in _DERIVED_KEYS[self.radius_law]:
            given, derived = getattr(self, key), float(resolved[key])
            if given is None or given == _LAW_KEY_UNSET[key]:
                continue
            if math.isclose(given, derived, rel_tol=1e-12, abs_tol=0.0):
                continue
            inputs = ", ".join(_LAW_INPUTS[self.radius_law])
            raise InvalidParameterError(
                f"invalid {key} = {given!r}: radius_law = {self.radius_law!r} derives {key} "
                f"from {inputs} ({derived:.6g} m here); leave {key} out, or choose a law "
                f"that takes it",
                parameter=key,
                value=given,
                expected=f"{derived!r} (derived) or left out",
            )

    def _check_radius_law(self) -> None:
        """Types the radius law's keys (the engine checks the law and derives r_min,
        r_max, and r_mean, r_std where the law does not take them)."""
        s = object.__setattr__
        if not isinstance(self.radius_law, str):
            raise InvalidParameterError(
                f"invalid radius_law = {short_repr(self.radius_law)}: must be one of "
                + ", ".join(repr(n) for n in RADIUS_LAWS),
                parameter="radius_law",
                value=self.radius_law,
                expected=" | ".join(RADIUS_LAWS),
            )
        s(self, "r_mean", as_real("r_mean", self.r_mean, unit="m"))
        s(self, "r_std", as_real("r_std", self.r_std, unit="m"))
        for key in ("r_min", "r_max"):
            if getattr(self, key) is not None:
                s(self, key, as_real(key, getattr(self, key), unit="m"))
        for key in _LAW_LISTS:
            value = getattr(self, key)
            if value is None:
                continue
            if isinstance(value, str | bytes) or not hasattr(value, "__iter__"):
                raise InvalidParameterError(
                    f"invalid {key} = {short_repr(value)}: expected a list of numbers",
                    parameter=key,
                    value=value,
                    expected="a list of numbers",
                )
            s(self, key, tuple(as_real(f"{key}[{k}]", v) for k, v in enumerate(value)))
        if not isinstance(self.fractions_by, str):
            raise InvalidParameterError(
                f"invalid fractions_by = {short_repr(self.fractions_by)}: must be 'number' "
                "or 'mass'",
                parameter="fractions_by",
                value=self.fractions_by,
                expected="'number' | 'mass'",
            )

    # -- construction ---------------------------------------------------------------
    @classmethod
    def preset(cls, name: str) -> PackScene:
        """The paper's examples "4.1", "4.2" (2D) and "4.3", "4.4" (3D); the name is a
        string (a number such as 4.1 is refused, saying so)."""
        return cls(**PRESETS[_preset_name(name)])

    def fast(self) -> PackScene:
        """The same scene with the fast settings: adaptive settling (settle_tol =
        FAST_SETTLE_TOL), freezing below FAST_FREEZE_LAYERS layer thicknesses (or below
        the scene's own ``freeze_depth``, where it sets one), dt = FAST_DT_RAYLEIGH of
        the Rayleigh estimate (or the scene's dt, if larger: the 2D presets keep theirs)
        and, once each layer has fallen, settle_dt = FAST_SETTLE_DT_RAYLEIGH of it
        (unset where that is not larger than dt). The physics constants are untouched;
        `studies/fast_vs_full/fast_vs_full.py` measures how far the ensemble statistics
        move (docs/performance.md, "The fast settings").

        A scene's own ``freeze_depth`` and ``freeze_force`` are kept: a tall pack with
        ``freeze_depth`` at 4 h_layer and ``freeze_force=10`` has a bed frozen for good
        that far below the top (no landing thaws it), whose layers then cost the same at
        any depth (docs/performance.md, "A tall pack")."""
        assert self.r_min is not None  # set by __post_init__
        crit = self.material.critical_time_step(self.r_min)
        dt = max(self.dt, FAST_DT_RAYLEIGH * crit)
        settle_dt = FAST_SETTLE_DT_RAYLEIGH * crit
        return self.replace(
            settle_tol=FAST_SETTLE_TOL,
            freeze_depth=(
                FAST_FREEZE_LAYERS * self.h_layer
                if self.freeze_depth is None
                else self.freeze_depth
            ),
            dt=dt,
            settle_dt=settle_dt if settle_dt > dt else None,
        )

    #: The density target keys, at most one of which a scene gives (the engine's list,
    #: `granpack._core.TARGET_KEYS`).
    TARGET_KEYS = _core.TARGET_KEYS

    @property
    def density_target(self) -> tuple[str, float] | None:
        """The scene's density target as (key, value), or None."""
        for key in self.TARGET_KEYS:
            value = getattr(self, key)
            if value is not None:
                return key, value
        return None

    def replace(self, **changes) -> PackScene:
        """A copy with some fields changed (validated again; a change of `seed` and
        `stream` alone checks those two, as they enter no rule that combines keys)."""
        unknown_keys("scene", changes, [f.name for f in dataclasses.fields(self)])
        # what the (new) law derives is derived again, not carried over from this
        # scene's values, which its old inputs set
        law = changes.get("radius_law", self.radius_law)
        if (changes.keys() - _STREAM_KEYS) and isinstance(law, str):
            for key in _DERIVED_KEYS.get(law, ()):
                changes.setdefault(key, _LAW_KEY_UNSET[key])
        if changes and changes.keys() <= _STREAM_KEYS:
            new = object.__new__(PackScene)
            new.__dict__.update(self.__dict__)
            for key, value in changes.items():
                # the checks __post_init__ gives these keys: the type, then the range
                if isinstance(value, bool) or not isinstance(value, Integral):
                    as_int(key, value, 0)
                object.__setattr__(new, key, as_int(key, int(value), 0, 2**64 - 1))
            return new
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_dict(cls, d: dict) -> PackScene:
        """From a flat dict (a TOML document); `preset = "4.3"` starts from a preset."""
        if not isinstance(d, Mapping):
            raise InvalidParameterError(
                f"invalid scene = {short_repr(d)}: expected a table (dict) of scene keys",
                parameter="scene",
            )
        d = dict(d)
        known = [f.name for f in dataclasses.fields(cls)] + ["preset"]
        unknown_keys("scene", d, known)
        base = {}
        if "preset" in d:
            base = dict(PRESETS[_preset_name(d.pop("preset"))])
        if "material" in d:
            if not isinstance(d["material"], dict):
                raise InvalidParameterError(
                    "invalid material: expected a table of material constants", parameter="material"
                )
            unknown_keys("material", d["material"], _MATERIAL_KEYS)
            mat = dict(base.get("material", Material()).to_dict())
            mat.update(d.pop("material"))
            d["material"] = _material_table(mat)
        if "base" in d and not isinstance(d["base"], list | tuple):
            raise InvalidParameterError(
                f"invalid base = {short_repr(d['base'])}: expected a list of lengths (m)",
                parameter="base",
            )
        base.update(d)
        # a preset's radius keys give way to what the file's own law derives
        law = base.get("radius_law", "constant")
        for key in _DERIVED_KEYS.get(law, ()) if isinstance(law, str) else ():
            if key not in d:
                base.pop(key, None)
        return cls(**base)

    @classmethod
    def from_toml(cls, path: str | Path) -> PackScene:
        """Reads a scene from a TOML file (flat keys, a [material] table). A file that sets
        no key (empty, or comments only) is refused: write ``preset = "4.1"`` for the
        defaults."""
        if not isinstance(path, str | os.PathLike):
            raise InvalidParameterError(
                f"invalid path = {short_repr(path)}: expected a file name", parameter="path"
            )
        try:
            with open(path, "rb") as f:
                doc = tomllib.load(f)
        except RecursionError:
            raise FileFormatError(f"invalid scene file {path}: {_TOO_DEEP}", path=path) from None
        except tomllib.TOMLDecodeError as exc:
            raise FileFormatError(f"invalid scene file {path}: {exc}", path=path) from None
        except UnicodeDecodeError as exc:
            raise FileFormatError(
                f"invalid scene file {path}: not UTF-8 text ({exc})", path=path
            ) from None
        except OSError as exc:
            raise GranpackError(f"cannot read scene file {path}: {exc.strerror}") from None
        if not doc:
            raise FileFormatError(
                f"invalid scene file {path}: it sets no key (empty, or comments only); "
                f"{_EMPTY_SCENE}",
                path=path,
                reason="no key",
            )
        return cls.from_dict(doc)

    @classmethod
    def from_toml_string(cls, text: str) -> PackScene:
        """Reads a scene from TOML text (str, or UTF-8 bytes); text that sets no key is
        refused, as `from_toml` refuses an empty file."""
        try:
            if isinstance(text, bytes | bytearray):
                text = bytes(text).decode()
            if not isinstance(text, str):
                raise InvalidParameterError(
                    f"invalid text = {short_repr(text)}: expected TOML text (str)", parameter="text"
                )
            doc = tomllib.loads(text)
        except RecursionError:
            raise InvalidParameterError(
                f"invalid scene TOML: {_TOO_DEEP}", parameter="scene"
            ) from None
        except UnicodeDecodeError as exc:
            raise InvalidParameterError(
                f"invalid scene TOML: not UTF-8 text ({exc})", parameter="scene"
            ) from None
        except tomllib.TOMLDecodeError as exc:
            raise InvalidParameterError(f"invalid scene TOML: {exc}", parameter="scene") from None
        if not doc:
            raise InvalidParameterError(
                f"invalid scene TOML: it sets no key (empty, or comments only); {_EMPTY_SCENE}",
                parameter="scene",
            )
        return cls.from_dict(doc)

    def to_dict(self) -> dict:
        """A flat dict that `from_dict` reads back to an equal scene."""
        d = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, Material):
                v = v.to_dict()
            elif isinstance(v, tuple):
                v = list(v)
            elif isinstance(v, dict):
                v = {k: list(x) if isinstance(x, tuple) else x for k, x in v.items()}
            d[f.name] = v
        return d

    def to_toml(self) -> str:
        """TOML text of the scene."""
        d = self.to_dict()
        # TOML has no None; drop unset truncations (they are derived again).
        return tomli_w.dumps({k: v for k, v in d.items() if v is not None})

    # -- derived ----------------------------------------------------------------------
    @property
    def vertical(self) -> int:
        """Index of the vertical axis."""
        return self.dim - 1

    @property
    def base_area(self) -> float:
        """Cross-section of the container: base length (2D) or area (3D) (m or m^2);
        pi R^2 for a cylinder."""
        if self.container == "cylinder":
            assert self.cylinder_radius is not None
            return math.pi * self.cylinder_radius**2
        return math.prod(self.base)

    def particle_volume(self, r: float) -> float:
        # products, not r**3: a huge radius gives inf instead of raising OverflowError
        return math.pi * r * r if self.dim == 2 else 4.0 / 3.0 * math.pi * r * r * r

    def estimated_particles(self) -> float:
        """Rough particle count: layers of phi_layer filling about H_d / h_layer slabs."""
        n_layers = max(1.0, self.height / self.h_layer) * 1.5
        vol = self.particle_volume(self.r_mean)
        if vol == 0.0:  # the radius underflows: too many particles by any measure
            return math.inf
        per_layer = self.phi_layer * self.base_area * self.h_layer / vol
        return n_layers * per_layer


#: The radius keys each law derives (from its own keys, `_LAW_INPUTS`) rather than
#: takes: a value given for one of them must be its default or the derived value.
_DERIVED_KEYS: dict[str, tuple[str, ...]] = {
    "constant": ("r_std", "r_min", "r_max"),
    "gaussian": (),
    "lognormal": (),
    "uniform": ("r_mean", "r_std"),
    "discrete": ("r_mean", "r_std", "r_min", "r_max"),
    "sieve": ("r_mean", "r_std", "r_min", "r_max"),
}
_LAW_INPUTS: dict[str, tuple[str, ...]] = {
    "constant": ("r_mean",),
    "gaussian": ("r_mean", "r_std", "r_min", "r_max"),
    "lognormal": ("r_mean", "r_std", "r_min", "r_max"),
    "uniform": ("r_min", "r_max"),
    "discrete": ("radii", "fractions"),
    "sieve": ("sieve_sizes", "sieve_passing"),
}
_LAW_KEY_UNSET = {"r_mean": 0.01, "r_std": 0.0, "r_min": None, "r_max": None}

#: The type of every scene key, checked before anything else (`PackScene._check_types`):
#: "real", "int" (>= 0), "bool", "text" (one of `_TEXT_CHOICES`), "reals" (a list of
#: numbers), "material"; a "?" allows None.
_KEY_TYPES: dict[str, str] = {
    "dim": "int",
    "base": "reals",
    "container": "text",
    "cylinder_radius": "real?",
    "height": "real",
    "radius_law": "text",
    "r_mean": "real",
    "r_std": "real",
    "r_min": "real?",
    "r_max": "real?",
    "radii": "reals?",
    "fractions": "reals?",
    "fractions_by": "text",
    "sieve_sizes": "reals?",
    "sieve_passing": "reals?",
    "h_layer": "real",
    "phi_layer": "real",
    "material": "material",
    "dt": "real",
    "settle_time": "real",
    "gravity": "real",
    "drag": "real",
    "rotations": "bool",
    "seed": "int",
    "stream": "int",
    "inertia_2d": "text",
    "skin_ratio": "real",
    "max_overlap_ratio": "real",
    "max_attempts": "int",
    "max_layers": "int",
    "settle_tol": "real?",
    "settle_dt": "real?",
    "freeze_depth": "real?",
    "freeze_speed": "real",
    "freeze_force": "real",
    "trim": "bool",
    "consolidate": "consolidate?",
    "rest_tol": "real?",
    "target_phi": "real?",
    "target_void_ratio": "real?",
    "target_relative_density": "real?",
    "density_tol": "real?",
    "density_method": "text",
    "triaxial": "element?",
    "oedometer": "element?",
    "isotropic": "element?",
}
_OPTIONAL_KINDS = ("real?", "reals?", "consolidate?", "element?")
#: The element tests' tables (`granpack.stages.triaxial`, ``oedometer``, ``isotropic``).
_ELEMENT_KEYS = ("triaxial", "oedometer", "isotropic")
_UNITS = {
    "base": "m",
    "cylinder_radius": "m",
    "height": "m",
    "r_mean": "m",
    "r_std": "m",
    "r_min": "m",
    "r_max": "m",
    "radii": "m",
    "sieve_sizes": "m",
    "h_layer": "m",
    "dt": "s",
    "settle_time": "s",
    "gravity": "m/s^2",
    "drag": "N s/m",
    "settle_dt": "s",
    "freeze_depth": "m",
    "freeze_speed": "m/s",
}
_TEXT_CHOICES = {
    "container": CONTAINERS,
    "radius_law": RADIUS_LAWS,
    "fractions_by": ("number", "mass"),
    "inertia_2d": ("sphere", "disc"),
    "density_method": _core.DENSITY_METHODS,
}

_COMMON = {
    "material": Material(),
    "dt": 1e-4,
    "settle_time": 1.0,
    "gravity": 2.0,
    "drag": 0.005,
    "height": 0.5,
    "h_layer": 0.1,
}

#: The paper's section 4 examples, numbers as printed (r_min of 4.2 is r_m - 3 sd).
PRESETS: dict[str, dict] = {
    "4.1": {
        **_COMMON,
        "dim": 2,
        "base": (1.0,),
        "radius_law": "constant",
        "r_mean": 0.01,
        "phi_layer": 0.4,
    },
    "4.2": {
        **_COMMON,
        "dim": 2,
        "base": (1.0,),
        "radius_law": "gaussian",
        "r_mean": 0.01,
        "r_std": 0.001,
        "r_min": 0.007,
        "r_max": 0.013,
        "phi_layer": 0.4,
    },
    "4.3": {
        **_COMMON,
        "dim": 3,
        "base": (1.0, 1.0),
        "radius_law": "constant",
        "r_mean": 0.02,
        "phi_layer": 0.25,
    },
    "4.4": {
        **_COMMON,
        "dim": 3,
        "base": (1.0, 1.0),
        "radius_law": "gaussian",
        "r_mean": 0.02,
        "r_std": 0.002,
        "r_min": 0.014,
        "r_max": 0.026,
        "phi_layer": 0.25,
    },
}
