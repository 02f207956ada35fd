"""The one input of every analysis, :class:`System`: a pack's particles, container and
contacts, checked once.

``System.from_any`` coerces what the analysis functions are given (a generated
:class:`granpack.Pack`, a :class:`granpack.ParticleFile` from :func:`granpack.read_particles`,
arrays, or a System already made), as freud's ``from_system`` does; every public function
of `granpack.analysis` goes through it, so the group of arguments that describes a pack
(`SystemArgs`) is written here only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, TypedDict, Unpack

import numpy as np

from .._validate import GranpackError, InvalidParameterError, as_real
from ..contacts import LID_ID, Contacts
from .container import CONTAINERS, Container, lid_record, make_container
from .inputs import (
    _as_box,
    _as_contacts,
    _as_particles,
    _check_overlaps,
    _find_contacts,
    check_contacts_touch,
    find_container_contacts,
)

__all__ = ["System", "SystemArgs", "ContainerArgs", "analysis_container"]


class ContainerArgs(TypedDict, total=False):
    """The keywords that give a pack's contacts and container, or override what a pack
    says of them (see :meth:`System.from_any`)."""

    contacts: Any
    box: Any
    periodic: Any
    cylinder_radius: float | None
    container: str | None
    lid: float | None


class SystemArgs(ContainerArgs, total=False):
    """`ContainerArgs` and the particles as arrays: every keyword of
    :meth:`System.from_any`, the analysis functions' common signature."""

    positions: Any
    radii: Any


@dataclass(frozen=True)
class System:
    """A pack ready for analysis (arrays read-only by convention): what every analysis
    function takes, made by :meth:`System.from_any`.

    Attributes
    ----------
    x, r : (N, D), (N,) float64
        Centres (m; wrapped into the cell along periodic axes) and radii (m).
    n, d : int
        Number of particles and the dimension.
    lo, hi : (D,) float64
        The container's corners (m); ``hi[-1]`` is H_top (or the lid).
    container : Container
    contacts : Contacts
        The contacts given (checked against the particles) or found geometrically.
    contacts_given : bool
        Whether the contacts were given (they may then carry forces).
    solid, vol, h_top, volume
        The particles' volume (m^3; m^2 in 2D), each particle's, the top and the
        container's volume up to it.
    container_source : str
        Why this container: "argument", "scene", "file" or "assumed".
    body : (N, D) float64 or None
        Body force on each particle (N) where the pack says.
    source : object or None
        The Pack or ParticleFile the system was made from (None for arrays).
    """

    x: np.ndarray
    r: np.ndarray
    n: int
    d: int
    lo: np.ndarray
    hi: np.ndarray
    container: Container
    contacts: Contacts
    contacts_given: bool
    solid: float
    vol: np.ndarray
    h_top: float
    volume: float
    container_source: str = "argument"
    #: (N, D) body force on each particle (N): its weight where the pack says (a
    #: granpack Pack: the scene's gravity and material), None where nothing does
    body: np.ndarray | None = None
    source: Any = None

    @classmethod
    def from_any(cls, obj: Any = None, **where: Unpack[SystemArgs]) -> System:
        """The System of `obj`: a :class:`granpack.Pack`, a :class:`granpack.ParticleFile`,
        a System (returned as it is), or the positions (N, D) themselves; or, with `obj`
        None, of the arrays in `where`.

        Parameters
        ----------
        obj : Pack, ParticleFile, System or (N, D) array, optional
            What to analyse.

        Other Parameters
        ----------------
        positions, radii, contacts, box, periodic, cylinder_radius, container, lid : optional
            As in :func:`granpack.microstructure`: the particles as arrays (not with a
            pack), and the container to analyse in (overriding what the pack says).

        Raises
        ------
        GranpackError
            Bad input, naming the parameter.
        """
        unknown = set(where) - set(SystemArgs.__optional_keys__)
        if unknown:
            raise TypeError(f"unexpected keyword argument {sorted(unknown)[0]!r}")
        if isinstance(obj, System):
            given = [k for k, v in where.items() if v is not None]
            if given:
                raise InvalidParameterError(
                    f"invalid {given[0]}: a System is already analysed in its container; "
                    "give the pack or the arrays instead",
                    parameter=given[0],
                )
            return obj
        pack = obj
        positions, radii = where.get("positions"), where.get("radii")
        if obj is not None and not (hasattr(obj, "positions") and hasattr(obj, "radii")):
            if positions is not None or radii is None:
                raise InvalidParameterError(
                    f"invalid pack = {type(obj).__name__}: expected a granpack.Pack, the "
                    "result of granpack.read_particles, a System, or positions with radii",
                    parameter="pack",
                )
            pack, positions = None, obj
        return _prepare(
            pack,
            positions,
            radii,
            where.get("contacts"),
            where.get("box"),
            where.get("periodic"),
            where.get("cylinder_radius"),
            where.get("container"),
            where.get("lid"),
        )

    def branches(self) -> np.ndarray:
        """(M, D) branch vectors of every contact: x_j - x_i by minimum image for a pair,
        (r_i - overlap/2) n from the centre to the contact point for a wall."""
        c = self.contacts
        wall = c.j < 0
        jj = np.where(wall, c.i, c.j)
        pair = self.container.minimum_image(self.x[jj] - self.x[c.i])
        to_wall = c.normal * (self.r[c.i] - 0.5 * c.overlap)[:, None]
        return np.where(wall[:, None], to_wall, pair)

    def contact_points(self) -> np.ndarray:
        """(M, D) contact points: x_i + l/2 for a pair (the midpoint of the branch), the
        wall contact point x_i + l for a wall."""
        c = self.contacts
        b = self.branches()
        half = np.where(c.j < 0, 1.0, 0.5)
        return self.x[c.i] + b * half[:, None]


def _container_of(pack, container, periodic, cylinder_radius, d: int):
    """(kind, periodic flags, cylinder radius, source) of the container to analyse in.

    The caller's arguments come first (source "argument"), then what the pack says: a
    generated pack's scene ("scene"), or what a file said (ParticleFile.container and
    .periodic: "file"). Where nothing says, a box is assumed ("assumed")."""
    told_kind, told_source, told_flags, told_radius = "box", "assumed", None, None
    if pack is not None:
        scene = getattr(pack, "scene", None)
        if scene is not None:
            of_scene = Container.from_scene(scene)
            told_kind, told_source, told_radius = of_scene.kind, "scene", of_scene.radius
        else:
            flags = getattr(pack, "periodic", None)
            # another code's periodic horizontal axes (a dump's BOX BOUNDS pp); a periodic
            # vertical axis (LAMMPS' 2D z) is not one of the pack's
            horizontal = None if flags is None else tuple(bool(f) for f in flags[: d - 1])
            told = getattr(pack, "container", None)
            if told is not None:
                told_kind, told_source = told, "file"
                told_radius = getattr(pack, "cylinder_radius", None)
            elif horizontal is not None and any(horizontal):
                told_kind, told_source = "periodic", "file"
            if told_kind == "periodic" and horizontal is not None and any(horizontal):
                told_flags = horizontal
    given_flags = None if periodic is None else tuple(bool(p) for p in periodic)
    if container is not None:
        if container not in CONTAINERS:
            raise InvalidParameterError(
                f"invalid container = {container!r}: must be one of {', '.join(CONTAINERS)}",
                parameter="container",
            )
        kind, source = container, "argument"
    elif cylinder_radius is not None and told_kind in ("box", "cylinder"):
        kind, source = "cylinder", ("argument" if told_kind == "box" else told_source)
    elif given_flags is not None and any(given_flags):
        if told_kind == "cylinder":
            raise InvalidParameterError(
                "invalid periodic: a cylinder has no periodic axis", parameter="periodic"
            )
        kind, source = "periodic", ("argument" if told_kind == "box" else told_source)
    else:
        kind, source = told_kind, told_source
    flags = None
    if kind == "periodic":
        flags = given_flags if given_flags is not None and any(given_flags) else told_flags
        if flags is None:
            flags = (True,) * (d - 1)
    elif given_flags is not None and any(given_flags):
        raise InvalidParameterError(
            f"invalid periodic = {list(given_flags)}: container = {kind!r} has no periodic axis",
            parameter="periodic",
        )
    radius = None
    if kind == "cylinder":
        radius = cylinder_radius if cylinder_radius is not None else told_radius
        if radius is None:
            raise InvalidParameterError(
                "invalid cylinder_radius = None: a cylinder container needs its radius (m)",
                parameter="cylinder_radius",
            )
        radius = as_real("cylinder_radius", radius, 0.0, unit="m")
        if not radius > 0.0:
            raise InvalidParameterError(
                f"invalid cylinder_radius = {radius}: must be > 0 (m)",
                parameter="cylinder_radius",
            )
    elif cylinder_radius is not None:
        raise InvalidParameterError(
            f"invalid cylinder_radius = {cylinder_radius!r}: only a cylinder has one "
            f"(container is {kind!r})",
            parameter="cylinder_radius",
        )
    return kind, flags, radius, source


def _prepare(
    pack,
    positions,
    radii,
    contacts,
    box,
    periodic=None,
    cylinder_radius=None,
    container=None,
    lid=None,
    *,
    until_container: bool = False,
):
    """The System of a pack or of arrays (the work of `System.from_any`, in the order of
    the former analysis signature); with `until_container`, only (its container, whether
    its walls are known), as the analysis would find them."""
    if pack is not None:
        given = [
            name
            for name, a in (("positions", positions), ("radii", radii))
            + (("contacts", contacts), ("box", box))
            if a is not None
        ]
        if given:
            raise InvalidParameterError(
                "give either pack or positions/radii/contacts/box, not both",
                parameter=given[0],
            )
        try:
            positions, radii, contacts, box = pack.positions, pack.radii, pack.contacts, pack.box
        except AttributeError:
            raise InvalidParameterError(
                f"invalid pack = {type(pack).__name__}: expected a granpack.Pack or the "
                "result of granpack.read_particles",
                parameter="pack",
            ) from None
    elif positions is None or radii is None:
        raise GranpackError("give a pack, or positions and radii")
    x, r = _as_particles(positions, radii)
    n, d = x.shape
    kind, periodic, cylinder_radius, source = _container_of(
        pack, container, periodic, cylinder_radius, d
    )

    with np.errstate(over="ignore", under="ignore"):
        vol = math.pi * r * r if d == 2 else 4.0 / 3.0 * math.pi * r * r * r
        solid = float(np.sum(vol))
        h_top = float(np.max(x[:, -1] + r))
    if not (np.all(np.isfinite(vol)) and np.all(vol > 0.0) and math.isfinite(solid)):
        k = int(np.argmax(~(np.isfinite(vol) & (vol > 0.0))))
        raise InvalidParameterError(
            f"invalid radii[{k}] = {r[k]}: the particle volume is {vol[k]:.3g} and the total "
            f"{solid:.3g}; volumes must be finite and > 0 (radii within about 1e-100 to "
            "1e100 m)",
            parameter=f"radii[{k}]",
        )
    if not math.isfinite(h_top):
        raise InvalidParameterError(
            "invalid positions: the pack's top max(z + r) overflows", parameter="positions"
        )
    walls_known = box is not None
    if box is None and kind == "cylinder":
        # no box given: the cylinder stands on the lowest particle, its axis through the
        # middle of the particles' lateral extent
        assert cylinder_radius is not None
        mid = 0.5 * (np.min(x[:, :2] - r[:, None], axis=0) + np.max(x[:, :2] + r[:, None], axis=0))
        floor = float(np.min(x[:, -1] - r))
        box = (np.array([*(mid - cylinder_radius), floor]), mid + cylinder_radius)
    if box is None:
        if kind != "box":
            raise InvalidParameterError(
                f"invalid box = None: a {kind} container needs box = (lo, hi) (the periods, "
                "or the square that holds the cylinder)",
                parameter="box",
            )
        lo = np.min(x - r[:, None], axis=0)
        hi_h = np.max(x[:, :-1] + r[:, None], axis=0)
        walls = None
    else:
        lo, hi_h = _as_box(box, d)
        if h_top <= lo[-1]:
            raise InvalidParameterError(
                f"invalid box: floor at {lo[-1]} m is at or above the top of the pack {h_top} m",
                parameter="box",
            )
        walls = (lo.tolist(), [*hi_h.tolist(), h_top])
    # a consolidated pack's sample ends at its lid, not at the top of its highest sphere
    lid = _lid_of(pack, float(lo[-1]), lid, x, r)
    if lid is not None:
        h_top = lid
        if walls is not None:
            walls = (walls[0], [*walls[1][:-1], h_top])
    hi = np.array([*hi_h, h_top])
    cont = make_container(kind, lo, hi, periodic, cylinder_radius, lid=lid is not None)
    if until_container:
        return cont, walls_known
    x_given = x  # as given: the contact check counts their printed digits
    if cont.any_periodic:
        x = cont.wrap(x)
    if cont.radius is not None:
        with np.errstate(over="ignore", under="ignore"):
            box_volume = float(cont.volume)
    else:
        with np.errstate(over="ignore", under="ignore"):
            box_volume = float(np.prod(hi - lo))
    if not (math.isfinite(box_volume) and box_volume > 0.0):
        raise InvalidParameterError(
            f"invalid positions: the box from {lo.tolist()} to {hi.tolist()} m has volume "
            f"{box_volume:.3g}; coordinates must span a finite box of volume > 0",
            parameter="positions",
        )

    if contacts is None:
        c = (
            _find_contacts(x, r, walls)
            if cont.kind == "box"
            else find_container_contacts(x, r, cont)
        )
        if cont.lid:
            c = _with_lid_contacts(c, x, r, h_top)
        contacts_given = False
        geometric = c
    else:
        c = _as_contacts(contacts, n, d)
        # contacts stored in a pack file name the file; others are arrays
        from_file = pack is not None and getattr(pack, "format", None) == "npz"
        check_contacts_touch(
            c.i,
            c.j,
            x_given,
            r,
            container=cont,
            walls=walls_known,
            box=box,
            path=getattr(pack, "path", None) if from_file else None,
            what="pack.contacts" if pack is not None else "contacts",
            force=(c.force_normal != 0.0) | np.any(c.force_tangential != 0.0, axis=1),
            digits=getattr(pack, "digits", None),
        )
        contacts_given = True
        geometric = _find_contacts(x, r, None)
    _check_overlaps(geometric.particle_pairs(), r)
    return System(
        x,
        r,
        n,
        d,
        lo,
        hi,
        cont,
        c,
        contacts_given,
        solid,
        vol,
        h_top,
        box_volume,
        source,
        _body_forces(pack, r, d),
        pack,
    )


def _lid_of(pack, floor: float, given, x: np.ndarray, r: np.ndarray) -> float | None:
    """The height (m) of the lid that closes the sample: `given` (the caller's ``lid=``),
    else a consolidated Pack's lid as its last stage left it (`lid_record`: its height
    above the floor at `floor`), else what a file said (``ParticleFile.lid``, the
    container tag's ``lid=``); None for an open top. A lid that is not a finite height
    above the floor, or that lies below a particle's centre, is refused."""
    record = lid_record(pack)
    if given is not None:
        lid = as_real("lid", given, unit="m")
    elif record is not None:
        # where the last stage left the lid: the consolidation, or an element test after it
        walls = record["walls"]
        height = record["height"] if "height" in record else walls["lid"] - walls["floor"]
        return floor + float(height)
    elif pack is not None and getattr(pack, "lid", None) is not None:
        lid = float(pack.lid)
    else:
        return None
    if not (math.isfinite(lid) and lid > floor):
        raise InvalidParameterError(
            f"invalid lid = {lid!r}: must be a finite height above the floor at {floor!r} (m)",
            parameter="lid",
        )
    above = x[:, -1] > lid
    if np.any(above):
        k = int(np.argmax(above))
        raise InvalidParameterError(
            f"invalid lid = {lid!r}: particle {k}'s centre lies above it, at "
            f"{float(x[k, -1])!r} m (radius {float(r[k])!r} m); the lid must lie above "
            "every centre (m)",
            parameter="lid",
        )
    return lid


def _with_lid_contacts(c: Contacts, x: np.ndarray, r: np.ndarray, lid: float) -> Contacts:
    """Geometric contacts `c` with those of the lid at height `lid` added: every particle
    whose top z + r lies above it, as the engine lists a lid contact (wall id -6, normal
    +z from the particle to the lid, overlap z + r - lid, branch (r - overlap/2) n to the
    contact point, forces zero). The engine lists wall contacts after the pairs, by
    particle; the lid's go last, which no quantity of the analysis depends on."""
    top = x[:, -1] + r - lid
    k = np.flatnonzero(top > 0.0)
    if k.size == 0:
        return c
    d = x.shape[1]
    normal = np.zeros((k.size, d))
    normal[:, -1] = 1.0
    overlap = top[k]
    lid_rows = {
        "i": k.astype(np.int64),
        "j": np.full(k.size, LID_ID, dtype=np.int64),
        "normal": normal,
        "overlap": overlap,
        "force_normal": np.zeros(k.size),
        "force_tangential": np.zeros((k.size, d)),
        "branch": normal * (r[k] - 0.5 * overlap)[:, None],
    }
    old = c.to_dict()
    return Contacts.from_dict(
        {key: np.concatenate([np.asarray(old[key]), lid_rows[key]]) for key in lid_rows}
    )


def _body_forces(pack, r: np.ndarray, d: int) -> np.ndarray | None:
    """(N, D) weight of each particle of a granpack Pack (N): the scene's gravity on the
    scene's material, as the engine had it (sphere or disc mass in 2D; none where a
    consolidation ran without gravity). None for anything else (another code's file
    says nothing of its masses or gravity)."""
    scene = getattr(pack, "scene", None) if pack is not None else None
    if scene is None:
        return None
    record = lid_record(pack)
    g = 0.0 if record is not None and not record.get("gravity", True) else float(scene.gravity)
    disc = d == 2 and getattr(scene, "inertia_2d", "disc") == "disc"
    vol = np.pi * r * r if disc else 4.0 / 3.0 * np.pi * r**3
    body = np.zeros((r.shape[0], d))
    body[:, -1] = -scene.material.density * vol * g
    return body


def analysis_container(pack) -> tuple[Container, bool]:
    """The container ``gp.microstructure(pack)`` analyses `pack` (a Pack or a
    ParticleFile) in, and whether its walls are known (a box given or read)."""
    return _prepare(pack, None, None, None, None, until_container=True)
