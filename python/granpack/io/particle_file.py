"""ParticleFile: the particles of one file, as `granpack.read_particles` returns them."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._validate import (
    InvalidParameterError,
)
from ..contacts import Contacts

if TYPE_CHECKING:
    from ..analysis.container import Container
    from ..pack import Pack


class ParticleFile:
    """The particles of one file (one snapshot of a dump), as :func:`read_particles`
    returns them. ``gp.microstructure(p)`` analyses it as it does a pack.

    Attributes
    ----------
    path : Path
        The file read.
    format : str
        The format found (or given), one of `FORMATS`.
    dim : int
        2 or 3.
    positions : (N, D) float64, read-only
        Centres (m), sorted by id where the file has ids; vertical axis last (y in 2D).
    radii : (N,) float64, read-only
        Radii (m).
    ids : (N,) int64 or None
        The file's particle ids, in the order of `positions` (None: the file has none).
    box : (lo, hi) or None
        The box corners (D each, m) where the file gives one (a dump's ``BOX BOUNDS``, a
        data file's header, a pack's scene); the analysis puts its walls there. None: the
        analysis uses the particles' bounding box, with no walls.
    periodic : tuple of D bool, or None
        Periodic axes from a dump's ``BOX BOUNDS`` flags (``pp``) or an XYZ file's pbc.
        The analysis takes periodic horizontal axes as a periodic cell (no walls there,
        contacts across the seam by minimum image); the vertical axis is always bounded
        by the floor and the open top.
    container : str or None
        The container the file says the pack lies in (one of
        `granpack.scene.CONTAINERS`): a granpack pack's scene, the
        container tag of granpack's text exports (`Container.read_tag`), or periodic
        horizontal axes in `periodic`. None: the file does not say; the analysis then
        assumes a box (walls at `box`, or none without one) and says so
        (``Microstructure.container_source``). `to_container` gives the whole container.
    cylinder_radius : float or None
        R (m) of a cylinder container.
    lid : float or None
        The height (m) of the lid that closes a consolidated sample, where the file says
        so (the container tag's ``lid=``, a pack file's consolidation record). The
        analysis then takes the sample from the floor up to the lid (H_top is the lid,
        not max(z + r)) and counts the particles that reach above it as contacts with
        the lid (wall id -6). None: an open top.
    timestep : int or None
        A dump snapshot's ``TIMESTEP``.
    snapshot : int
        Which snapshot (a dump's snapshot, an XYZ file's frame) was read (0-based,
        counted from the start).
    n_snapshots : int
        How many the file holds (1 for every format but a dump and extended XYZ).
    contacts : granpack.Contacts or None
        The contacts with forces of a granpack pack (npz); None otherwise (the analysis
        then finds the contacts from the geometry and has no forces).
    pack : granpack.Pack or None
        The pack itself for a ``.npz`` file.
    notes : tuple of str
        What the reader left out or assumed (periodic flags, a dimension it inferred).
    digits : int or None
        The most significant digits the file's text writes a position or radius with
        (the precision of its format, as its text shows it), which the check of a
        contact list takes; None for binary files and files read without counting
        (the check then counts the digits the values need).
    """

    def __init__(
        self,
        *,
        path: Path,
        format: str,
        positions: np.ndarray,
        radii: np.ndarray,
        ids: np.ndarray | None = None,
        box: tuple[np.ndarray, np.ndarray] | None = None,
        periodic: tuple[bool, ...] | None = None,
        container: str | None = None,
        cylinder_radius: float | None = None,
        lid: float | None = None,
        timestep: int | None = None,
        snapshot: int = 0,
        n_snapshots: int = 1,
        contacts: Contacts | None = None,
        pack: Pack | None = None,
        notes: tuple[str, ...] = (),
        digits: int | None = None,
    ) -> None:
        self.path = path
        self.format = format
        self.positions = _frozen(np.asarray(positions, dtype=np.float64))
        self.radii = _frozen(np.asarray(radii, dtype=np.float64))
        self.dim = int(self.positions.shape[1])
        self.ids = None if ids is None else _frozen(np.asarray(ids, dtype=np.int64))
        self.box = None if box is None else (_frozen(box[0]), _frozen(box[1]))
        self.periodic = periodic
        if container is None and periodic is not None and any(periodic[: self.dim - 1]):
            container = "periodic"
        self.container = container
        self.digits = digits
        self.cylinder_radius = cylinder_radius
        self.lid = None if lid is None else float(lid)
        self.timestep = timestep
        self.snapshot = snapshot
        self.n_snapshots = n_snapshots
        self.contacts = contacts
        self.pack = pack
        self.notes = notes

    def __len__(self) -> int:
        return int(self.radii.shape[0])

    def to_container(self) -> Container:
        """The `granpack.analysis.Container` this file is analysed in: the one it says
        (`container`, `cylinder_radius`, `periodic`, `lid`) at its `box`, or the box that
        the analysis assumes where it says none (``gp.microstructure(p).container``)."""
        from ..analysis.system import analysis_container

        return analysis_container(self)[0]

    def with_contacts(self, contacts) -> ParticleFile:
        """The same particles with `contacts` (a granpack.Contacts, or what
        :func:`granpack.read_contacts` returns), so that ``gp.microstructure`` takes its
        forces: ``gp.microstructure(p.with_contacts(gp.read_contacts(f, p)))``."""
        c = getattr(contacts, "contacts", contacts)
        if not isinstance(c, Contacts):
            raise InvalidParameterError(
                f"invalid contacts = {type(contacts).__name__}: expected granpack.Contacts or "
                "the result of granpack.read_contacts",
                parameter="contacts",
            )
        from ..analysis.inputs import _as_contacts, check_contacts_touch, verge_note
        from ..analysis.system import analysis_container

        # the contacts must touch in the container the analysis will see
        _as_contacts(c, len(self), self.dim)
        container, walls = analysis_container(self)
        source = getattr(contacts, "path", None)
        ids = self.ids if self.ids is not None else np.arange(1, len(self) + 1)
        file_periods = None
        if self.periodic is not None and self.box is not None:
            size = np.asarray(self.box[1], dtype=float) - np.asarray(self.box[0], dtype=float)
            flags = list(self.periodic)[: self.dim] + [False] * self.dim
            file_periods = np.where(flags[: self.dim], size, np.inf)
        carries = getattr(contacts, "carries_force", None)
        if carries is None:
            carries = (np.asarray(c.force_normal) != 0.0) | np.any(
                np.asarray(c.force_tangential).reshape(len(c), -1) != 0.0, axis=1
            )
        n_verge, widest = check_contacts_touch(
            c.i,
            c.j,
            self.positions,
            self.radii,
            container=container,
            walls=walls,
            box=self.box,
            path=source,
            ids=ids if source is not None else None,
            file_periods=file_periods,
            force=carries,
            digits=self.digits,
        )
        notes = self.notes + tuple(getattr(contacts, "notes", ()))
        if n_verge and not any("without force" in v for v in notes):
            notes += (verge_note(n_verge, widest),)
        return ParticleFile(
            path=self.path,
            format=self.format,
            positions=self.positions,
            radii=self.radii,
            ids=self.ids,
            box=self.box,
            periodic=self.periodic,
            container=self.container,
            cylinder_radius=self.cylinder_radius,
            lid=self.lid,
            timestep=self.timestep,
            snapshot=self.snapshot,
            n_snapshots=self.n_snapshots,
            contacts=c,
            pack=self.pack,
            notes=notes,
            digits=self.digits,
        )

    def __repr__(self) -> str:
        where = f", snapshot {self.snapshot} of {self.n_snapshots}" if self.n_snapshots > 1 else ""
        return (
            f"ParticleFile({str(self.path)!r}, format={self.format!r}, dim={self.dim}, "
            f"n={len(self)}{where})"
        )


def _frozen(a) -> np.ndarray:
    # a copy, so that freezing it never freezes the caller's array (a pack's own)
    a = np.array(a, copy=True, order="C")
    a.setflags(write=False)
    return a
