"""What every analysis of a pack starts from: its particles, container and contacts, checked
once; and the quantities beyond the paper that :func:`granpack.microstructure` adds."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._validate import GranpackError, InvalidParameterError, as_real
from ..contacts import Contacts
from .container import CONTAINERS, Container, make_container
from .coordination import coordination_distribution, degrees, rattlers_iterative
from .inputs import (
    _as_box,
    _as_contacts,
    _as_particles,
    _check_overlaps,
    _find_contacts,
    check_contacts_touch,
    find_container_contacts,
)
from .order import bond_order
from .stress import contact_forces, k0, love_weber
from .tensors import ANISOTROPY_FACTOR, anisotropy_magnitude, fabric_tensor

#: Most slices of a depth profile.
MAX_SLICES = 10_000
#: Width of the bins of force_distribution, in units of the mean normal force.
FORCE_BIN = 0.1


@dataclass(frozen=True)
class Prepared:
    """A pack ready for analysis (arrays read-only by convention)."""

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
            told_kind, told_source = getattr(scene, "container", "box"), "scene"
            told_radius = getattr(scene, "cylinder_radius", None)
            if told_kind == "cylinder" and told_radius is None:
                told_radius = float(scene.base[0]) / 2.0
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
    *,
    until_container: bool = False,
):
    """The pack made ready for analysis; with `until_container`, only (its container,
    whether its walls are known), as the analysis would find them."""
    if pack is not None:
        if any(a is not None for a in (positions, radii, contacts, box)):
            raise GranpackError("give either pack or positions/radii/contacts/box, not both")
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
    record = getattr(pack, "consolidation", None) if pack is not None else None
    if record is not None:
        h_top = float(lo[-1]) + float(record["height"])
        if walls is not None:
            walls = (walls[0], [*walls[1][:-1], h_top])
    hi = np.array([*hi_h, h_top])
    cont = make_container(kind, lo, hi, periodic, cylinder_radius, lid=record is not None)
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
        )
        contacts_given = True
        geometric = _find_contacts(x, r, None)
    _check_overlaps(geometric.particle_pairs(), r)
    return Prepared(
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
    )


def _body_forces(pack, r: np.ndarray, d: int) -> np.ndarray | None:
    """(N, D) weight of each particle of a granpack Pack (N): the scene's gravity on the
    scene's material, as the engine had it (sphere or disc mass in 2D; none where a
    consolidation ran without gravity). None for anything else (another code's file
    says nothing of its masses or gravity)."""
    scene = getattr(pack, "scene", None) if pack is not None else None
    if scene is None:
        return None
    record = getattr(pack, "consolidation", None)
    g = 0.0 if record is not None and not record.get("gravity", True) else float(scene.gravity)
    disc = d == 2 and getattr(scene, "inertia_2d", "disc") == "disc"
    vol = np.pi * r * r if disc else 4.0 / 3.0 * np.pi * r**3
    body = np.zeros((r.shape[0], d))
    body[:, -1] = -scene.material.density * vol * g
    return body


def force_balance(prep: Prepared, forces: np.ndarray) -> tuple[float, float]:
    """(YADE's unbalanced ratio, PFC's maximum ratio) of the contact forces `forces`
    (M, D; on the second body) and the body forces: mean and largest |net force| over
    particles, each over the mean |contact force| (-). NaN without body forces or
    contacts."""
    c = prep.contacts
    if prep.body is None or len(c) == 0:
        return math.nan, math.nan
    net = prep.body.copy()
    np.add.at(net, c.i, -forces)
    pair = c.j >= 0
    np.add.at(net, c.j[pair], forces[pair])
    mean_c = float(np.mean(np.linalg.norm(forces, axis=1)))
    if not mean_c > 0.0:
        return math.nan, math.nan
    mag = np.linalg.norm(net, axis=1)
    return float(np.mean(mag)) / mean_c, float(np.max(mag)) / mean_c


def analysis_container(pack) -> tuple[Container, bool]:
    """The container ``gp.microstructure(pack)`` analyses `pack` (a Pack or a
    ParticleFile) in, and whether its walls are known (a box given or read)."""
    return _prepare(pack, None, None, None, None, until_container=True)


def _force_edges(ratio: np.ndarray) -> np.ndarray:
    top = max(1.0, math.ceil(float(np.max(ratio)) / FORCE_BIN) * FORCE_BIN) if ratio.size else 1.0
    return np.arange(0.0, top + 0.5 * FORCE_BIN, FORCE_BIN)


def stress_slices(prep: Prepared, edges: np.ndarray, forces, branches) -> np.ndarray:
    """(S, D, D) Love-Weber stress of each horizontal slice (Pa): every contact is given to
    the slice of its contact point, over the slice's volume (cross-section x thickness), so
    that the thickness-weighted mean of the slices is the pack's stress."""
    d = prep.d
    s_count = edges.shape[0] - 1
    pts = prep.contact_points()[:, -1]
    k = np.clip(np.searchsorted(edges, pts, side="right") - 1, 0, s_count - 1)
    out = np.zeros((s_count, d, d))
    prod = forces[:, :, None] * branches[:, None, :]
    for a in range(d):
        for b in range(d):
            out[:, a, b] = np.bincount(k, weights=prod[:, a, b], minlength=s_count)
    dv = prep.container.base_area * np.diff(edges)
    out /= dv[:, None, None]
    return 0.5 * (out + np.transpose(out, (0, 2, 1)))


def _beyond_the_paper(prep: Prepared, values: dict, n_slices: int, has_forces: bool) -> dict:
    """Coordination distribution and rattlers, stress and K0, the strong and weak networks
    and the force distribution, bond order."""
    n, d = prep.n, prep.d
    c = prep.contacts
    pp = c.particle_pairs()
    n_c = len(pp)
    deg = degrees(pp.i, pp.j, n)
    p_z = coordination_distribution(deg)
    k = np.arange(p_z.shape[0])
    z_std = float(math.sqrt(max(0.0, float(np.sum(p_z * k * k)) - (2.0 * n_c / n) ** 2)))
    ratt, n_live = rattlers_iterative(c.i, c.j, n, d)
    n_ratt = int(np.sum(ratt))
    # every particle a rattler: Z_m is the mean over no particle, NaN (as z_mech)
    z_iter = 2.0 * n_live / (n - n_ratt) if n > n_ratt else math.nan
    ratt_f, n_live_f = rattlers_iterative(c.i, c.j, n, d, d)
    n_ratt_f = int(np.sum(ratt_f))
    z_iter_f = 2.0 * n_live_f / (n - n_ratt_f) if n > n_ratt_f else math.nan
    nan_t = np.full((d, d), np.nan)
    out: dict = {
        "container": prep.container.kind,
        "container_source": prep.container_source,
        "container_volume": float(prep.volume),
        "coordination_distribution": p_z,
        "z_std": z_std,
        "n_rattlers_iterative": n_ratt,
        "z_mech_iterative": float(z_iter),
        "n_rattlers_frictional": n_ratt_f,
        "z_mech_frictional": float(z_iter_f),
    }
    # -- stress ---------------------------------------------------------------------------
    edges = np.linspace(prep.lo[-1], prep.hi[-1], n_slices + 1)
    if has_forces:
        forces = contact_forces(c.normal, c.force_normal, c.force_tangential)
        branches = prep.branches()
        sigma = love_weber(forces, branches, prep.volume)
        prof = stress_slices(prep, edges, forces, branches)[:, d - 1, d - 1]
        unbalanced, max_ratio = force_balance(prep, forces)
    else:
        sigma = nan_t
        prof = np.full(n_slices, np.nan)
        unbalanced = max_ratio = math.nan
    out.update(
        stress=sigma,
        k0=k0(sigma),
        stress_profile=(edges, prof),
        unbalanced=unbalanced,
        unbalanced_max=max_ratio,
    )
    # -- strong and weak networks ---------------------------------------------------------
    if has_forces and n_c > 0:
        fn = pp.force_normal
        mean = float(np.mean(fn))
        strong = fn > mean
        n_s = int(np.sum(strong))
        fab_s = fabric_tensor(pp.normal[strong]) if n_s else nan_t
        fab_w = fabric_tensor(pp.normal[~strong]) if n_c - n_s else nan_t
        ratio = fn / mean
        f_edges = _force_edges(ratio)
        hist, _ = np.histogram(ratio, bins=f_edges)
        pdf = hist / (n_c * FORCE_BIN)
        fn_mean, s_frac = mean, n_s / n_c
    else:
        fab_s = fab_w = nan_t
        f_edges, pdf = np.array([0.0, FORCE_BIN]), np.array([np.nan])
        fn_mean = s_frac = math.nan
        n_s = 0
    a_s = ANISOTROPY_FACTOR[d] * (fab_s - np.eye(d) / d)
    a_w = ANISOTROPY_FACTOR[d] * (fab_w - np.eye(d) / d)
    out.update(
        force_normal_mean=fn_mean,
        n_strong=n_s,
        strong_fraction=float(s_frac),
        fabric_strong=fab_s,
        fabric_weak=fab_w,
        a_r_strong=a_s,
        a_r_weak=a_w,
        a_r_strong_mag=anisotropy_magnitude(a_s),
        a_r_weak_mag=anisotropy_magnitude(a_w),
        force_distribution=(f_edges, pdf),
    )
    # -- bond order -----------------------------------------------------------------------
    bo = bond_order(pp.i, pp.j, pp.normal, n, d, 6)
    q = bo.q[np.isfinite(bo.q)]
    out.update(
        q6=bo.q,
        q6_mean=float(np.mean(q)) if q.size else math.nan,
        q6_global=bo.global_q,
        crystal_fraction=bo.crystal_fraction,
    )
    return out
