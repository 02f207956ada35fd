"""gsd files in HOOMD-blue's schema, as HOOMD-blue, OVITO and freud read them:
:func:`write_gsd` and :func:`read_gsd` (format ``"gsd"``).

Needs the ``gsd`` package (``pip install gsd``); granpack imports it only when a gsd file
is written or read.

What granpack writes (one frame, schema ``hoomd`` 1.4)
    * ``particles/N``, ``particles/types`` = ``['A']``, ``particles/typeid`` = 0;
    * ``particles/position`` (float32): HOOMD's box is centred on the origin, so the
      centres are shifted by -(lo + hi)/2 of the pack's box (lo = 0, hi = (base..., H_top));
      a periodic pack's centres are first wrapped into [0, L), as in the LAMMPS export;
    * ``particles/diameter`` = 2 r (float32), ``particles/velocity`` (float32);
    * ``configuration/box`` = [Lx, Ly, Lz, 0, 0, 0] and ``configuration/dimensions``;
      a 2D pack lies in the plane z = 0 with Lz = 0 and dimensions 2 (HOOMD's 2D), its
      vertical axis y as in granpack;
    * log data that only granpack reads (OVITO shows it as global attributes):
      ``log/granpack/container`` (text: ``dim=.. container=.. lo=.. hi=..``, the
      container tag of `granpack.analysis.container`), ``log/granpack/lo`` and
      ``log/granpack/hi`` (the box corners, float64) and ``log/granpack/shift`` (the
      float64 vector added back to the positions on reading, (lo + hi)/2 padded to 3).

    Every chunk is written explicitly, even where it equals HOOMD's default (a diameter
    of 1), so that the file says what it holds.

Precision
    Positions, diameters and velocities are float32 (HOOMD's single precision): a pack
    read back has its centres and radii to about 6e-8 of the box, not bit for bit. The
    box and the container come back exactly (from the float64 log data).

Periodic boundaries
    A HOOMD box is periodic on every axis by nature, and OVITO takes a gsd cell as
    periodic on all three. granpack's own file says its container in the log data: a
    box or a cylinder is read back walled, a periodic cell periodic on the horizontal
    axes. A gsd file without granpack's log data (written by HOOMD-blue or another
    program) is read as a periodic cell on its horizontal axes (x, y in 3D, x in 2D),
    the vertical axis (z in 3D, y in 2D) bounded by the floor and the open top, as the
    analysis takes any periodic file; a note says so. Analyse it walled with
    ``container="box"`` (``granpack analyze FILE --container box``).

Integrity
    gsd has no checksum. granpack's export adds one chunk, ``granpack/digest`` (16 bytes
    of SHA-256 over the names and bytes of every other chunk it writes; outside ``log/``,
    so HOOMD-blue does not copy it into a frame it appends), and reading refuses a frame
    whose chunks do not give it: a changed byte anywhere in granpack's data is found.
    Before the gsd library opens a file, its header is checked (the index and the name
    list must lie inside the file: the library trusts their sizes, and a changed byte
    there crashed the process). What cannot be found: a changed value in a file without
    the digest (HOOMD-blue's, OVITO's, granpack's before the digest), which reads as
    the value it now holds where it is finite and in range.

Reading
    Frames are read like a dump's snapshots: the last by default, ``snapshot=`` another.
    A chunk a frame lacks is taken from frame 0 (HOOMD's rule: writers skip what did not
    change; per-particle chunks only where frame 0 has as many particles), else from the
    schema's default for the box (1 1 1), the dimensions (2 where Lz = 0, else 3) and the
    step (0), never for the particles: a frame without positions or diameters is refused
    (HOOMD-blue's writers leave the diameters out where all are 1; such a file cannot be
    read as a pack). Boxes with tilt factors are refused (only orthogonal boxes are read).
"""

from __future__ import annotations

import importlib
import math
import os
import struct
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._files import atomic_write
from .._validate import FileFormatError, GranpackError
from ..analysis.container import Container
from ._text import _frame_index, _read_args
from .particle_file import ParticleFile

if TYPE_CHECKING:
    from ..pack import Pack

__all__ = ["write_gsd", "read_gsd", "GSD_MAGIC", "FORMAT"]

#: The format name `granpack.read_particles` gives gsd files.
FORMAT = "gsd"

#: The first 8 bytes of every gsd file (the magic number 0x65DF65DF65DF65DF,
#: little-endian).
GSD_MAGIC = bytes.fromhex("df65df65df65df65")

#: The schema and version granpack writes (HOOMD-blue 4 writes 1.4).
SCHEMA = "hoomd"
SCHEMA_VERSION = (1, 4)

#: granpack's log chunks.
LOG = "log/granpack/"


#: The chunk that holds a digest of every other chunk granpack writes: gsd itself has no
#: checksum, so a changed byte in a position would otherwise read as another position.
#: Outside ``log/``: HOOMD-blue's reader does not copy it into a frame it appends, so a
#: later frame that a program changed does not carry a digest of frame 0.
DIGEST = "granpack/digest"
# the chunks the digest covers, in this order (those a frame has)
_DIGESTED = (
    "configuration/step",
    "configuration/dimensions",
    "configuration/box",
    "particles/N",
    "particles/types",
    "particles/typeid",
    "particles/position",
    "particles/diameter",
    "particles/velocity",
    LOG + "container",
    LOG + "lo",
    LOG + "hi",
    LOG + "shift",
)


def _chunk_bytes(data: Any) -> bytes:
    """The bytes a chunk's digest takes: text as UTF-8 (gsd stores it as a NUL-ended
    int8 array), an array as its dtype, shape and values."""
    if isinstance(data, str):
        return data.encode()
    a = np.ascontiguousarray(data)
    if a.dtype == np.int8 and a.ndim == 1:  # text as gsd gives it back
        return a.tobytes().split(b"\0", 1)[0]
    return f"{a.dtype.str}{a.shape}".encode() + a.tobytes()


def _digest(chunks: list[tuple[str, Any]]) -> np.ndarray:
    """16 bytes (uint8) of SHA-256 over the names and bytes of `chunks` that the digest
    covers, in `_DIGESTED`'s order."""
    import hashlib

    have = dict(chunks)
    h = hashlib.sha256()
    for name in _DIGESTED:
        if name in have:
            h.update(name.encode() + b"\0" + _chunk_bytes(have[name]))
    return np.frombuffer(h.digest()[:16], dtype=np.uint8).copy()


def _gsd_fl() -> Any:
    """The ``gsd`` package with its file layer (``gsd.fl``) and version loaded."""
    try:
        # imported by name: gsd is optional, and ships no type information
        importlib.import_module("gsd.fl")
        importlib.import_module("gsd.version")
    except ImportError:
        raise GranpackError("gsd files need the optional package gsd: pip install gsd") from None
    return importlib.import_module("gsd")


def _centre(pack: Pack) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lo, hi, shift): the pack's box corners (D each) and (lo + hi)/2 padded to 3."""
    lo, hi = (np.asarray(a, dtype=np.float64) for a in pack.box)
    shift = np.zeros(3)
    shift[: pack.dim] = (lo + hi) / 2.0
    return lo, hi, shift


def _wrapped_positions(pack: Pack) -> np.ndarray:
    """(N, 3) float64 centres, 2D at z = 0, a periodic pack's wrapped into [0, L)."""
    x = np.zeros((len(pack), 3))
    x[:, : pack.dim] = np.asarray(pack.positions, dtype=np.float64)
    kind = Container.of_pack(pack).kind
    if kind == "periodic":
        for ax, length in enumerate(pack.scene.base):
            x[:, ax] = np.mod(x[:, ax], length)
            x[x[:, ax] >= length, ax] = 0.0  # mod can round a tiny negative up to L
    return x


def write_gsd(pack: Pack, path: str | Path) -> Path:
    """Writes `pack` as a one-frame gsd file (HOOMD-blue's schema) that HOOMD-blue, OVITO
    and freud read, and `read_gsd` reads back in the pack's container. Returns the path.

    The layout, the float32 precision and how the periodic flags are carried are in the
    module docstring. The file is written whole to a temporary file and renamed
    (`granpack._files.atomic_write`): an interrupted write leaves no partial file.

    Raises
    ------
    GranpackError
        The ``gsd`` package is not installed, or `path` cannot be written.
    """
    gsd = _gsd_fl()
    path = Path(path)
    n = len(pack)
    dim = pack.dim
    lo, hi, shift = _centre(pack)
    lengths = np.zeros(3)
    lengths[:dim] = hi - lo
    position = np.ascontiguousarray(_wrapped_positions(pack) - shift, dtype=np.float32)
    if dim == 2:
        position[:, 2] = 0.0
    diameter = np.ascontiguousarray(2.0 * np.asarray(pack.radii, np.float64), dtype=np.float32)
    container = Container.of_pack(pack)
    tag = f"dim={dim} " + container.tag_words()
    chunks: list[tuple[str, Any]] = [
        ("configuration/step", np.array([0], dtype=np.uint64)),
        ("configuration/dimensions", np.array([dim], dtype=np.uint8)),
        ("configuration/box", np.array([*lengths, 0.0, 0.0, 0.0], dtype=np.float32)),
        ("particles/N", np.array([n], dtype=np.uint32)),
        ("particles/types", np.array([[ord("A"), 0]], dtype=np.int8)),
        ("particles/typeid", np.zeros(n, dtype=np.uint32)),
        ("particles/position", position.reshape(n, 3)),
        ("particles/diameter", diameter),
    ]
    velocities = getattr(pack, "velocities", None)
    if velocities is not None:
        v = np.zeros((n, 3), dtype=np.float32)
        v[:, :dim] = np.asarray(velocities, dtype=np.float64).reshape(n, dim)
        chunks.append(("particles/velocity", v))
    chunks += [
        (LOG + "container", tag),
        (LOG + "lo", np.ascontiguousarray(lo)),
        (LOG + "hi", np.ascontiguousarray(hi)),
        (LOG + "shift", np.ascontiguousarray(shift)),
    ]
    chunks.append((DIGEST, _digest(chunks)))
    # gsd writes to a named file: build it in a private folder, then put its bytes in
    # place through the same atomic write as every other export
    with tempfile.TemporaryDirectory(prefix="granpack-gsd-") as tmp:
        scratch = os.path.join(tmp, "pack.gsd")
        with gsd.fl.open(
            name=scratch,
            mode="w",
            application=f"granpack (gsd {gsd.version.version})",
            schema=SCHEMA,
            schema_version=list(SCHEMA_VERSION),
        ) as f:
            for name, data in chunks:
                f.write_chunk(name, data)
            f.end_frame()
        data = Path(scratch).read_bytes()
    return atomic_write(path, data)


# --------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------


class _Frame:
    """Chunk access for one frame, with HOOMD's fall-back on frame 0, and messages that
    name the file, the frame and the chunk."""

    def __init__(self, f: Any, path: Path, index: int) -> None:
        self.f = f
        self.path = path
        self.index = index

    def fail(self, chunk: str, what: str) -> FileFormatError:
        return FileFormatError(
            f"{self.path}: frame {self.index}, chunk {chunk}: {what}",
            path=self.path,
            reason=f"frame {self.index}, chunk {chunk}: {what}",
        )

    def exists(self, name: str, frame: int) -> bool:
        try:
            return bool(self.f.chunk_exists(frame=frame, name=name))
        except (RuntimeError, OSError, ValueError) as exc:
            raise self.fail(name, f"cannot be read ({exc})") from None

    def read(self, name: str, n_particles: int | None = None) -> np.ndarray | str | None:
        """The chunk of this frame, else of frame 0 (for a per-particle chunk, given
        `n_particles`, only where frame 0 has as many), else None."""
        frames = [self.index]
        if self.index != 0:
            if n_particles is None or self.n0() == n_particles:
                frames.append(0)
        for k in frames:
            if self.exists(name, k):
                try:
                    return self.f.read_chunk(frame=k, name=name)
                except (RuntimeError, OSError, ValueError, KeyError, MemoryError) as exc:
                    raise self.fail(name, f"cannot be read ({exc}): a damaged file") from None
        return None

    def n0(self) -> int | None:
        if not self.exists("particles/N", 0):
            return 0
        try:
            a = np.asarray(self.f.read_chunk(frame=0, name="particles/N"))
        except (RuntimeError, OSError, ValueError, KeyError, MemoryError):
            return None
        return int(a.ravel()[0]) if a.size == 1 else None

    def array(
        self, name: str, shape: tuple[int, ...], n_particles: int | None = None
    ) -> np.ndarray | None:
        """A numeric chunk of `shape` as float64 (None where absent)."""
        a = self.read(name, n_particles)
        if a is None:
            return None
        if isinstance(a, str) or not isinstance(a, np.ndarray) or a.dtype.kind not in "fiu":
            raise self.fail(name, f"expected numbers, found {type(a).__name__}")
        if a.size != math.prod(shape):
            raise self.fail(
                name,
                f"expected {' x '.join(map(str, shape))} values, found {a.size} "
                f"(shape {' x '.join(map(str, a.shape))})",
            )
        return a.astype(np.float64).reshape(shape)

    def text(self, name: str) -> str | None:
        a = self.read(name)
        if a is None or isinstance(a, str):
            return a
        if isinstance(a, np.ndarray) and a.dtype.kind in "iu":
            raw = np.asarray(a).astype(np.uint8).tobytes().split(b"\0", 1)[0]
            try:
                return raw.decode("utf-8")
            except UnicodeDecodeError:
                raise self.fail(name, "is not UTF-8 text") from None
        raise self.fail(name, f"expected text, found {type(a).__name__}")


def read_gsd(path: str | Path, dim: int | None = None, snapshot: int = -1) -> ParticleFile:
    """Reads one frame of a gsd file (HOOMD-blue's schema) as a `granpack.ParticleFile`
    (format ``"gsd"``), for ``gp.microstructure`` and ``granpack analyze``.

    Parameters
    ----------
    path : str or Path
    dim : {None, 2, 3}
        None (default): the frame's ``configuration/dimensions`` (else 2 where Lz = 0,
        3 otherwise). 2 also reads a 3D frame whose particles all have the same z (not
        one of granpack's 3D files); 3 refuses a 2D frame.
    snapshot : int
        Which frame: 0 the first, -1 (default) the last.

    Returns
    -------
    ParticleFile
        Positions (float64 of the file's float32 values; shifted back to granpack's
        frame where granpack's log data is there), radii = diameter / 2, the box (exact
        from granpack's log data, else [-L/2, L/2] per axis), the container and periodic
        flags (module docstring), ``timestep`` from ``configuration/step``, and
        ``snapshot``/``n_snapshots``. No ids: a gsd frame's order is its particles'
        identity.

    Raises
    ------
    FileFormatError
        Naming the file, and the frame and chunk where one is at fault: not a gsd file,
        a damaged or truncated one, another schema than ``hoomd``, no frames, a frame
        without ``particles/position`` or ``particles/diameter``, a chunk of the wrong
        size, a non-finite value, a diameter <= 0, a tilted box, a 2D frame with z != 0,
        granpack's log data that does not hold together, a `snapshot` out of range.
    InvalidParameterError
        `snapshot` not an integer, `dim` not None, 2 or 3.
    GranpackError
        The ``gsd`` package is not installed.
    """
    path = Path(path)
    snapshot = _read_args(snapshot, dim)
    gsd = _gsd_fl()
    _check_head(path)
    try:
        f = gsd.fl.open(name=str(path), mode="r")
    except FileNotFoundError:
        raise FileFormatError(f"cannot read {path}: no such file", path=path) from None
    except OSError as exc:
        raise FileFormatError(f"cannot read {path}: {exc.strerror or exc}", path=path) from None
    except (RuntimeError, ValueError, MemoryError) as exc:
        raise FileFormatError(
            f"{path}: not a readable gsd file ({exc}): a damaged or truncated file, or "
            "not a gsd file",
            path=path,
        ) from None
    with f:
        return _read_open(f, path, dim, int(snapshot))


# gsd's file header (gsd.h, file layer 1.0 and 2.x): magic, index location, index
# entries, name list location, name list entries (uint64 each), schema and gsd versions
# (uint32 each), then the application, schema and reserved text: 256 bytes
_HEADER = struct.Struct("<QQQQQII")
_HEADER_SIZE = 256
_INDEX_ENTRY = 32  # frame, N, location (8 bytes each), M (4), id (2), type, flags (1 each)
_NAME_ENTRY = 64  # one name, NUL-padded


def _check_head(path: Path) -> None:
    """Refuses what is not a gsd file, and a header whose index or name list lies beyond
    the end of the file: the gsd library takes the header's sizes on trust (a changed
    byte in the index's size crashes the process), so they are checked first."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(_HEADER_SIZE)
            size = os.fstat(fh.fileno()).st_size
    except FileNotFoundError:
        raise FileFormatError(
            f"cannot read {path}: no such file", path=path, reason="no such file"
        ) from None
    except OSError as exc:
        raise FileFormatError(f"cannot read {path}: {exc.strerror or exc}", path=path) from None
    if head[: len(GSD_MAGIC)] != GSD_MAGIC:
        raise FileFormatError(
            f"{path}: not a gsd file (its first bytes are not gsd's magic number)",
            path=path,
            reason="not a gsd file",
        )
    if len(head) < _HEADER_SIZE:
        raise FileFormatError(
            f"{path}: not a readable gsd file: {size} bytes, shorter than gsd's "
            f"{_HEADER_SIZE}-byte header (a truncated file)",
            path=path,
            reason="truncated",
        )
    _, index_at, index_n, names_at, names_n, _, version = _HEADER.unpack(head[: _HEADER.size])
    parts = (
        ("index", index_at, index_n, _INDEX_ENTRY),
        ("name list", names_at, names_n, _NAME_ENTRY),
    )
    for what, at, count, entry in parts:
        if at < _HEADER_SIZE or count > size // entry or at + count * entry > size:
            raise FileFormatError(
                f"{path}: not a readable gsd file: its header puts the {what} ({count} "
                f"entries at byte {at}) outside the file's {size} bytes (a damaged or "
                "truncated file)",
                path=path,
                reason="damaged header",
            )
    if version >> 16 not in (1, 2):
        raise FileFormatError(
            f"{path}: not a readable gsd file: gsd file layer version {version >> 16}."
            f"{version & 0xFFFF} (this gsd package reads 1.x and 2.x)",
            path=path,
            reason="damaged header",
        )


def _read_open(f: Any, path: Path, dim: int | None, snapshot: int) -> ParticleFile:
    if f.schema != SCHEMA:
        raise FileFormatError(
            f"{path}: a gsd file of schema {f.schema!r}; expected {SCHEMA!r} (HOOMD-blue's)",
            path=path,
        )
    major = tuple(f.schema_version)[0]
    if not 1 <= major < 3:
        raise FileFormatError(
            f"{path}: hoomd schema version {'.'.join(map(str, f.schema_version))}; this "
            "version of granpack reads 1.x and 2.x",
            path=path,
        )
    n_frames = int(f.nframes)
    if n_frames == 0:
        raise FileFormatError(f"{path}: the file holds no frames", path=path)
    k = _frame_index(path, snapshot, n_frames, "file", "frame")
    fr = _Frame(f, path, k)

    count = fr.array("particles/N", (1,))
    n = 0 if count is None else int(count[0])
    if n == 0:
        raise FileFormatError(
            f"{path}: frame {k} holds no particles (particles/N "
            f"{'is 0' if count is not None else 'is missing'})",
            path=path,
        )

    box6 = fr.array("configuration/box", (6,))
    if box6 is None:  # HOOMD's writers leave out a box equal to the schema's default
        box6 = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
    if not np.all(np.isfinite(box6)):
        raise fr.fail("configuration/box", f"non-finite value in {box6.tolist()}")
    if np.any(box6[3:] != 0.0):
        tilts = " ".join(repr(float(t)) for t in box6[3:])
        raise fr.fail(
            "configuration/box",
            f"a triclinic box (tilt factors xy xz yz = {tilts}); only orthogonal boxes are read",
        )
    dims = fr.array("configuration/dimensions", (1,))
    file_dim = (2 if box6[2] == 0.0 else 3) if dims is None else int(dims[0])
    if file_dim not in (2, 3):
        raise fr.fail("configuration/dimensions", f"{file_dim} (expected 2 or 3)")
    if np.any(box6[:file_dim] <= 0.0):
        raise fr.fail(
            "configuration/box",
            f"box lengths {box6[:3].tolist()}: expected > 0 on the {file_dim} axes",
        )

    x = fr.array("particles/position", (n, 3), n)
    if x is None:
        raise fr.fail("particles/position", "missing: the frame has no particle positions")
    bad = ~np.all(np.isfinite(x), axis=1)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise fr.fail(
            "particles/position", f"particle {i} has a non-finite coordinate {x[i].tolist()}"
        )
    d = fr.array("particles/diameter", (n,), n)
    if d is None:
        raise fr.fail(
            "particles/diameter",
            "missing, in this frame and in frame 0: the file gives no diameters (HOOMD's "
            "writers leave them out where all are 1, the schema's default; granpack takes "
            "no default for a radius)",
        )
    bad = ~(np.isfinite(d) & (d > 0.0))
    if np.any(bad):
        i = int(np.argmax(bad))
        raise fr.fail(
            "particles/diameter", f"particle {i} has diameter {d[i]!r}: must be finite and > 0"
        )
    if file_dim == 2 and np.any(x[:, 2] != 0.0):
        i = int(np.argmax(x[:, 2] != 0.0))
        raise fr.fail(
            "particles/position",
            f"a 2D frame (dimensions 2) with z = {x[i, 2]!r} at particle {i}: HOOMD's 2D "
            "particles lie at z = 0",
        )

    text = fr.text(LOG + "container")
    _check_digest(fr)
    notes: list[str] = []
    if n_frames > 1:
        notes.append(f"frame {k} of {n_frames} read (counted from 0)")
    if text is not None:
        out_dim = file_dim
        if dim is not None and dim != file_dim:
            raise FileFormatError(
                f"{path}: dim = {dim}, but frame {k} is a granpack {file_dim}D pack "
                f"(configuration/dimensions = {file_dim})",
                path=path,
            )
        fields = _granpack_fields(fr, text, out_dim)
        x[:, :] += fields.pop("shift")
    else:
        out_dim = file_dim if dim is None else dim
        if out_dim == 3 and file_dim == 2:
            raise FileFormatError(
                f"{path}: dim = 3, but frame {k} is 2D (configuration/dimensions = 2, "
                f"Lz = {box6[2]!r})",
                path=path,
            )
        if out_dim == 2 and file_dim == 3 and np.any(x[:, 2] != x[0, 2]):
            raise FileFormatError(
                f"{path}: dim = 2 needs the same z for every particle; z runs from "
                f"{float(np.min(x[:, 2]))} to {float(np.max(x[:, 2]))} in frame {k}",
                path=path,
            )
        half = box6[:out_dim] / 2.0
        fields = {"box": (-half, half), "periodic": (True,) * out_dim}
        notes.append(
            "a gsd box is periodic on every axis (HOOMD-blue): read as a periodic cell on "
            "the horizontal axes, the vertical axis bounded by the floor and the open top; "
            'container="box" (--container box) analyses it walled'
        )
    step = fr.array("configuration/step", (1,))
    return ParticleFile(
        path=path,
        format=FORMAT,
        positions=x[:, :out_dim],
        radii=d / 2.0,
        timestep=None if step is None else int(step[0]),
        snapshot=k,
        n_snapshots=n_frames,
        notes=tuple(notes),
        **fields,
    )


def _check_digest(fr: _Frame) -> None:
    """Refuses a frame whose chunks do not give the digest granpack wrote with them (a
    changed byte). Frames without one (other programs', older granpack files) pass:
    gsd has no checksum of its own."""
    if not fr.exists(DIGEST, fr.index):
        return
    stored = fr.read(DIGEST)
    chunks = []
    for name in _DIGESTED:
        if fr.exists(name, fr.index):
            chunks.append((name, fr.read(name)))
    if not isinstance(stored, np.ndarray) or not np.array_equal(
        stored.ravel().astype(np.uint8, copy=False), _digest(chunks)
    ):
        raise fr.fail(
            DIGEST,
            "the chunks do not give the digest written with them: the file was changed or "
            "damaged after granpack wrote it",
        )


def _granpack_fields(fr: _Frame, text: str, d: int) -> dict:
    """ParticleFile keywords (and ``shift``) from granpack's log chunks."""
    name = LOG + "container"
    try:
        tag = Container.read_tag(text, fr.path, 0, d)
    except FileFormatError as exc:
        # the tag parser names a line; here the place is the chunk
        reason = str(exc).split(": ", 1)[-1]
        raise fr.fail(name, reason) from None
    if tag is None:
        raise fr.fail(name, f"no container=... word in {text[:80]!r}")
    corners = []
    for key, from_tag in (("lo", tag.lo), ("hi", tag.hi)):
        v = fr.array(LOG + key, (d,))
        if v is None:
            v = from_tag
        if v is None:
            raise fr.fail(LOG + key, "missing, and the container tag gives no corner either")
        if not np.all(np.isfinite(v)):
            raise fr.fail(LOG + key, f"non-finite value in {v.tolist()}")
        corners.append(v)
    lo, hi = corners
    if not np.all(hi > lo):
        raise fr.fail(
            LOG + "hi", f"the box corners lo={lo.tolist()} and hi={hi.tolist()} need hi > lo"
        )
    shift = fr.array(LOG + "shift", (3,))
    if shift is None:
        shift = np.zeros(3)
        shift[:d] = (lo + hi) / 2.0
    elif not np.all(np.isfinite(shift)):
        raise fr.fail(LOG + "shift", f"non-finite value in {shift.tolist()}")
    return {
        "box": (lo, hi),
        "container": tag.kind,
        "cylinder_radius": tag.cylinder_radius,
        "periodic": (tag.kind == "periodic",) * (d - 1),
        "lid": tag.lid,
        "shift": shift,
    }
