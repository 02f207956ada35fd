"""Pack generation (the paper's Algorithm 1) and pack files."""

from __future__ import annotations

import errno
import json
import lzma
import math
import os
import re
import stat
import struct
import tempfile
import time
import tomllib
import warnings
import zipfile
import zlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from . import _core
from ._memory import memory_limit
from ._validate import FileFormatError, GranpackError, InvalidParameterError, short_repr
from .contacts import Contacts
from .history import STAGE_NAMES, TABLE_NAMES, StageRecord
from .scene import PackScene

__all__ = [
    "Pack",
    "deposit",
    "load_pack",
    "atomic_write",
    "UnsettledPackWarning",
    "settling_issue",
    "fall_time",
    "remove_stale_temporaries",
]

#: The pack file's format: 2 keeps the stages' records as one ``history`` list; 1
#: (granpack 0.1.0) kept them as the tables ``trim``, ``rest``, ``consolidation``,
#: ``density`` and ``tiled``, which `load_pack` still reads into the history.
FORMAT_VERSION = 2
#: The oldest format `load_pack` reads.
OLDEST_FORMAT_VERSION = 1

#: Said by `load_pack` of a pack written in a newer format (and only then), so that
#: callers can tell "a pack this version cannot read" from a damaged file.
NEWER_FORMAT = "upgrade granpack to read it"

#: A pack counts as unsettled when its particles' mean translational kinetic energy
#: exceeds this fraction of m g r (each particle's own): settled packs of the presets
#: end near 1e-8, and a last layer still landing above 0.05.
UNSETTLED_KE_RATIO = 0.05

#: The speed scale of a pack at rest, as a fraction of sqrt(g r_mean), the speed a
#: particle gains falling through a quarter of its radius; 1 cm/s for the 3D presets
#: (r = 0.02 m, g = 2 m/s^2), 0.7 cm/s for the 2D ones. A particle faster than this
#: counts as still moving. Settled preset packs end below 1e-3 sqrt(g r_mean), those of
#: the fast settings with 99 % of their particles below 0.04.
UNSETTLED_SPEED_RATIO = 0.05

#: A pack counts as unsettled when more than this fraction of its particles still move
#: (speed above `UNSETTLED_SPEED_RATIO` sqrt(g r_mean)): a moving minority, which the
#: mean kinetic energy of the whole pack hides. The fast settings' packs of the presets
#: end with about 1 % above the speed.
UNSETTLED_MOVING_FRACTION = 0.05


class UnsettledPackWarning(UserWarning):
    """`generate` returned a pack that has not come to rest. Any of:

    * its last layer had less settle_time than it needs to fall through its slab
      (`fall_time`);
    * more than `UNSETTLED_MOVING_FRACTION` (5 %) of its particles still move faster
      than `UNSETTLED_SPEED_RATIO` sqrt(g r_mean) (0.05 sqrt(g r_mean): 1 cm/s for the
      3D presets), a moving minority that the mean hides;
    * its particles' mean kinetic energy is above `UNSETTLED_KE_RATIO` m g r (a few
      fast ones).

    Its microstructure is then that of a pack in motion; give a longer settle_time."""


@dataclass(frozen=True, eq=False)
class Pack:
    """A finished pack and where it came from.

    Attributes
    ----------
    scene : PackScene
        The scene (seed and stream included) that produced it.
    positions : (N, D) float64
        Centres (m); vertical axis last.
    radii : (N,) float64
        Radii (m).
    velocities : (N, D) float64
        Velocities at the end (m/s).
    spins : (N,) or (N, 3) float64
        Angular velocities at the end (rad/s).
    layer : (N,) int64
        Layer (0-based) in which each particle was placed.
    contacts : Contacts
        Contacts in force at the end (particle-particle and wall).
    height : float
        Final height H_top = max(z + r) (m).
    layers : list of dict
        One report per layer: added, total, phi_rsa, height, steps, kinetic_energy,
        wall_seconds.
    wall_time : float
        Seconds spent generating.
    history : tuple of StageRecord
        One record per stage run after the layer loop, in order (`granpack.history`):
        the flat top ("trim"), the settling to rest ("rest"), the consolidation
        ("consolidate"), the density target ("density"), the tiling ("tile"). Each
        holds the settings the stage ran with, what it measured, its seconds and its
        time steps; `record` finds one by its stage. Empty for a plain deposit.
    """

    scene: PackScene
    positions: np.ndarray
    radii: np.ndarray
    velocities: np.ndarray
    spins: np.ndarray
    layer: np.ndarray
    contacts: Contacts
    height: float
    layers: list[dict] = field(default_factory=list)
    wall_time: float = 0.0
    history: tuple[StageRecord, ...] = ()

    def record(self, stage: str) -> StageRecord | None:
        """The last record of `stage` ("trim", "rest", "consolidate", "density",
        "tile") in the pack's history, or None where that stage did not run."""
        if stage not in STAGE_NAMES:
            raise InvalidParameterError(
                f"invalid stage = {stage!r}: expected one of {', '.join(STAGE_NAMES)}",
                parameter="stage",
                value=stage,
                expected=f"one of {STAGE_NAMES}",
            )
        for rec in reversed(self.history):
            if rec.stage == stage:
                return rec
        return None

    def with_record(self, record: StageRecord, **changes: Any) -> Pack:
        """A copy of the pack with `changes` (`dataclasses.replace`'s) and `record`
        added to its history."""
        return replace(self, history=(*self.history, record), **changes)

    def _table(self, stage: str) -> dict | None:
        warnings.warn(
            f"Pack.{TABLE_NAMES[stage]} is deprecated and will be removed in the next "
            f"release: use Pack.record({stage!r}) (a StageRecord: settings, report, "
            "seconds, steps), or its .table() for this table",
            DeprecationWarning,
            stacklevel=3,
        )
        rec = self.record(stage)
        return None if rec is None else rec.table()

    @property
    def trim(self) -> dict | None:
        """Deprecated: ``record("trim").table()``, the flat top's table (``removed``,
        ``top``, ``phi_hd``, ``steps``), or None."""
        return self._table("trim")

    @property
    def tiled(self) -> dict | None:
        """Deprecated: ``record("tile").table()``, the tiling's table, or None."""
        return self._table("tile")

    @property
    def consolidation(self) -> dict | None:
        """Deprecated: ``record("consolidate").table()``, the consolidation's table, or
        None."""
        return self._table("consolidate")

    @property
    def rest(self) -> dict | None:
        """Deprecated: ``record("rest").table()``, the settling's table, or None."""
        return self._table("rest")

    @property
    def density(self) -> dict | None:
        """Deprecated: ``record("density").table()``, the density target's table, or
        None."""
        return self._table("density")

    @property
    def dim(self) -> int:
        return self.scene.dim

    @property
    def n_layers(self) -> int:
        """Number of layers placed."""
        return len(self.layers)

    def __len__(self) -> int:
        return int(self.radii.shape[0])

    @property
    def box(self) -> tuple[np.ndarray, np.ndarray]:
        """Box corners (lo, hi) up to H_top: lo = 0, hi = (base..., height)."""
        lo = np.zeros(self.dim)
        hi = np.array([*self.scene.base, self.height])
        return lo, hi

    @property
    def phi(self) -> float:
        """Solid fraction of the box up to H_top (-)."""
        vol = (
            np.sum(np.pi * self.radii**2)
            if self.dim == 2
            else np.sum(4 / 3 * np.pi * self.radii**3)
        )
        return float(vol / (self.scene.base_area * self.height))

    # -- files ------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Writes the pack to a `.npz` file atomically (temporary file, then rename)."""
        arrays = {
            "positions": self.positions,
            "radii": self.radii,
            "velocities": self.velocities,
            "spins": self.spins,
            "layer": self.layer,
        }
        arrays.update({f"contacts.{k}": v for k, v in self.contacts.to_dict().items()})
        meta = {
            "format": "granpack-pack",
            "version": FORMAT_VERSION,
            "height": self.height,
            "layers": self.layers,
            "wall_time": self.wall_time,
        }
        if self.history:
            meta["history"] = [rec.to_json() for rec in self.history]
        arrays["meta.json"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
        arrays["scene.toml"] = np.frombuffer(self.scene.to_toml().encode(), dtype=np.uint8)
        # Stored, not deflated: float64 positions and forces barely compress (a 1e6-sphere
        # pack: 300 MB deflated at 14 MB/s), while a stored zip is written and read at
        # disk speed. np.load reads both, so older files still load. The zip goes
        # straight into the temporary file: built in memory first, it held a second
        # copy of the pack (336 MB at 922 075 spheres) at the generation's peak.
        # (numpy's stub types the keyword arrays as its allow_pickle flag)
        return atomic_write(path, lambda f: np.savez(f, **arrays))  # type: ignore[arg-type]


#: The temporary files of `atomic_write`: ``.<name>.<8 random characters>.tmp`` beside
#: the file written (the characters are those of `tempfile.mkstemp`).
TEMP_SUFFIX = ".tmp"
_TEMP_NAME = re.compile(r"^\.(.+)\.[a-z0-9_]{8}\.tmp$")


def is_temporary(name: str) -> bool:
    """Whether a file name is that of an `atomic_write` temporary."""
    return _TEMP_NAME.match(name) is not None


def remove_stale_temporaries(folder: str | Path, of: Iterable[str] | None = None) -> list[Path]:
    """Removes the temporaries that writes cut off by a kill left under `folder` (only
    files named as `atomic_write` names them; nothing else is touched) and returns them.
    With `of` (file names), only the temporaries of those files directly in `folder`.
    Call it only where no other write of those files is under way (the command line
    holds the output folder's lock)."""
    removed = []
    targets = None if of is None else set(of)
    if targets is None:
        walk = os.walk(folder)
    else:  # that folder alone, not what lies below it
        walk = iter([(str(folder), [], os.listdir(folder))])
    for dirpath, _dirs, files in walk:
        for name in files:
            p = Path(dirpath) / name
            m = _TEMP_NAME.match(name)
            if m is None or (targets is not None and m.group(1) not in targets):
                continue
            if p.is_file() and not p.is_symlink():
                try:
                    p.unlink()
                except FileNotFoundError:
                    continue
                removed.append(p)
    return sorted(removed)


def scene_record_error(path: str | Path) -> str | None:
    """Why this version cannot read the scene of a granpack pack file, or None: a file
    that is a granpack pack (its record says so) and whose scene record is whole TOML,
    but names a key or value this version does not know (a newer granpack wrote it).
    None too for a file that is not a pack or is damaged."""
    try:
        with zipfile.ZipFile(path) as z:
            meta = json.loads(_member_text(z, "meta.json"))
            text = _member_text(z, "scene.toml")
    except Exception:  # not a pack archive, or damaged: not this case
        return None
    if not isinstance(meta, dict) or meta.get("format") != "granpack-pack":
        return None
    try:
        doc = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError):
        return None  # a damaged record
    try:
        PackScene.from_dict(doc)
    except GranpackError as exc:
        return str(exc)
    return None


def _member_text(z: zipfile.ZipFile, key: str) -> str:
    """A text member of a pack archive (UTF-8 bytes stored as a 1-D uint8 array)."""
    with z.open(f"{key}.npy") as f:
        a = np.lib.format.read_array(f, allow_pickle=False)
    if a.dtype != np.uint8 or a.ndim != 1:
        raise ValueError(f"{key!r} is not a byte string")
    return a.tobytes().decode()


def atomic_write(path: str | Path, data: bytes | Callable[[BinaryIO], object]) -> Path:
    """Writes `data` to `path` through a temporary file in the same folder and a rename,
    so a reader never sees a half-written file. `data` is the bytes, or a function that
    writes them to the open (binary, seekable) temporary file."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except FileExistsError:  # a file where a folder of the path should be
        raise OSError(errno.ENOTDIR, "a folder of the path is a file", str(path)) from None
    except OSError as exc:
        raise _naming(exc, path) from None
    try:
        mode = path.stat().st_mode
    except OSError:  # missing (the usual case) or unreadable: the rename decides
        mode = None
    if mode is not None and not stat.S_ISREG(mode):
        # a rename would replace a device (/dev/null), a pipe or a folder, not write to it
        raise GranpackError(f"cannot write {path}: not a regular file")
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=TEMP_SUFFIX)
    except OSError as exc:
        raise _naming(exc, path) from None
    try:
        with os.fdopen(fd, "wb") as f:
            if callable(data):
                data(f)
            else:
                f.write(data)
            f.flush()
            # mkstemp creates the file 0600; the result gets the mode any other new
            # file would, 0666 less the umask
            os.fchmod(f.fileno(), 0o666 & ~_umask())
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise _naming(exc, path) from exc
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _naming(exc: OSError, path: Path) -> OSError:
    """`exc` as it concerns the file the caller asked for: the same kind of OSError
    (errno and message), naming `path`, not the temporary file that the write went
    through (which is gone) nor nothing at all (a full disk's ENOSPC names no file)."""
    if exc.errno is None:
        return OSError(f"cannot write {path}: {exc}")
    return OSError(exc.errno, exc.strerror or os.strerror(exc.errno), str(path))


def _umask() -> int:
    """The process's umask, read without changing it where the system tells it."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)  # elsewhere: set and restore (not thread-safe, but brief)
    os.umask(mask)
    return mask


def load_pack(path: str | Path) -> Pack:
    """Reads a pack written by `Pack.save`; a truncated or foreign file is a
    GranpackError, never a crash."""
    if not isinstance(path, str | os.PathLike):
        raise InvalidParameterError(
            f"invalid path = {path!r}: expected a file name", parameter="path"
        )
    path = Path(path)
    try:
        f = path.open("rb")
    except FileNotFoundError:
        raise FileFormatError(
            f"cannot read pack {path}: no such file", path=path, reason="no such file"
        ) from None
    except OSError as exc:
        raise FileFormatError(
            f"cannot read pack {path}: {exc.strerror or exc}", path=path
        ) from None
    try:
        # Each array is read from the open file in turn (the `with` closes it whatever
        # happens): read whole into memory first, the file stood beside its arrays, twice
        # the pack at the peak of a load.
        with f:
            z = np.load(f, allow_pickle=False)
            if not isinstance(z, np.lib.npyio.NpzFile):
                raise ValueError("a single .npy array, not a pack archive")
            with z:
                data = {k: z[k] for k in z.files}
    except (
        zipfile.BadZipFile,
        zlib.error,
        lzma.LZMAError,
        struct.error,
        NotImplementedError,
        RuntimeError,
        ValueError,
        OSError,
        EOFError,
        KeyError,
        MemoryError,
    ) as exc:
        # A corrupt zip header can name an unknown compression method or zip version
        # (NotImplementedError) or set the encryption flag (RuntimeError); a corrupt
        # array header can announce an absurd shape (MemoryError). numpy's own words
        # for pickled data advise allow_pickle, which no granpack pack needs and which
        # would run code from the file: they are not passed on.
        detail = f"{type(exc).__name__}: {exc}"
        if "pickle" in str(exc):
            detail = "it holds pickled Python objects, which a granpack pack never does"
        reason = f"the file is damaged (corrupt or truncated) or not a granpack pack ({detail})"
        raise FileFormatError(
            f"cannot read pack {path}: {reason}", path=path, reason=reason
        ) from None
    if "meta.json" not in data:
        raise FileFormatError(
            f"cannot read pack {path}: not a granpack pack (an .npz archive without the "
            f"pack record meta.json; members: {short_repr(sorted(data))})",
            path=path,
        )
    try:
        meta = json.loads(_text(data, "meta.json"))
    except (ValueError, UnicodeDecodeError, RecursionError) as exc:
        raise FileFormatError(
            f"cannot read pack {path}: damaged pack record ({exc})", path=path
        ) from None
    if not isinstance(meta, dict) or meta.get("format") != "granpack-pack":
        raise FileFormatError(
            f"cannot read pack {path}: not a granpack pack (its meta.json does not say "
            "format = granpack-pack)",
            path=path,
        )
    version = meta.get("version")
    if isinstance(version, int) and not isinstance(version, bool) and version > FORMAT_VERSION:
        raise FileFormatError(
            f"cannot read pack {path}: written in pack format version {version}; this "
            f"granpack reads versions up to {FORMAT_VERSION}: {NEWER_FORMAT}",
            path=path,
        )
    if not (
        isinstance(version, int)
        and not isinstance(version, bool)
        and OLDEST_FORMAT_VERSION <= version <= FORMAT_VERSION
    ):
        raise FileFormatError(
            f"cannot read pack {path}: damaged pack record (format version "
            f"{short_repr(version)}; expected {OLDEST_FORMAT_VERSION} to {FORMAT_VERSION})",
            path=path,
        )
    try:
        scene = PackScene.from_toml_string(_text(data, "scene.toml"))
        contacts = Contacts.from_dict(
            {k.split(".", 1)[1]: v for k, v in data.items() if k.startswith("contacts.")}
        )
        _check_arrays(data, scene.dim, contacts)
        return Pack(
            scene=scene,
            positions=data["positions"],
            radii=data["radii"],
            velocities=data["velocities"],
            spins=data["spins"],
            layer=data["layer"],
            contacts=contacts,
            height=_finite_field(meta, "height"),
            layers=list(meta["layers"]),
            wall_time=float(meta["wall_time"]),
            history=_history(meta, version, scene.dim, len(data["radii"])),
        )
    except (
        KeyError,
        ValueError,
        UnicodeDecodeError,
        TypeError,
        OverflowError,
        RecursionError,
    ) as exc:
        reason = f"missing or invalid field ({exc})"
        raise FileFormatError(
            f"cannot read pack {path}: {reason}", path=path, reason=reason
        ) from None


def _finite_field(meta: dict, key: str) -> float:
    """A number of the pack record that must be finite (a ValueError naming it if not)."""
    value = meta[key]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{key!r} is {short_repr(value)}, expected a number")
    try:
        v = float(value)
    except OverflowError:  # an integer beyond any float
        v = math.inf
    if not math.isfinite(v):
        raise ValueError(f"{key!r} is {v}, expected a finite number")
    return v


def _history(meta: dict, version: int, dim: int, n: int) -> tuple[StageRecord, ...]:
    """The stages' records of a pack record: its ``history`` list (format 2), or the
    five tables of a 0.1.0 file (format 1) read into records, in the order `generate`
    runs them. Each stage's table is checked as 0.1.0 checked it, in either format."""
    checks = {
        "trim": _trim_record,
        "rest": _rest_record,
        "consolidate": _consolidation_record,
        "density": _density_record,
        "tile": lambda table: _tiled_record(table, dim, n),
    }
    if version >= 2:
        history = meta.get("history", [])
        if not isinstance(history, list):
            raise ValueError(f"'history' is {type(history).__name__}, expected a list")
        records = tuple(StageRecord.from_json(rec) for rec in history)
        for rec in records:
            checks[rec.stage](rec.table())
        return records
    tables = {stage: check(meta.get(TABLE_NAMES[stage])) for stage, check in checks.items()}
    return tuple(
        StageRecord.from_table(stage, table) for stage, table in tables.items() if table is not None
    )


def _trim_record(value) -> dict | None:
    """The flat top's record of a pack file (None when it has none)."""
    if value is None:
        return None
    if not isinstance(value, dict):
        raise ValueError(f"'trim' is {type(value).__name__}, expected a table")
    return {
        "removed": int(value["removed"]),
        "top": float(value["top"]),
        "phi_hd": float(value["phi_hd"]),
        "steps": int(value["steps"]),
    }


def _consolidation_record(value) -> dict | None:
    """The consolidation record of a pack file (absent in deposits and older files)."""
    if value is None:
        return None
    if not isinstance(value, dict) or not isinstance(value.get("walls"), dict):
        raise ValueError("consolidation record: expected a table with the walls")
    for key in ("phi", "k0", "height"):
        if not math.isfinite(float(value[key])):
            raise ValueError(f"consolidation record: {key} is not finite")
    return value


def _rest_record(value) -> dict | None:
    """The settling record of a pack file (absent unless `settle` ran)."""
    return _checked_record(value, "rest", "unbalanced", "unbalanced ratio")


def _density_record(value) -> dict | None:
    """The density target's record of a pack file (absent unless the scene had one)."""
    return _checked_record(value, "density", "phi", "phi")


def _checked_record(value, name: str, key: str, what: str) -> dict | None:
    """A stage's record of a pack file: None where absent, else a table whose `key` is
    finite (a damaged file otherwise)."""
    if value is None:
        return None
    if not isinstance(value, dict) or not math.isfinite(float(value[key])):
        raise ValueError(f"{name} record: expected a table with a finite {what}")
    return value


def _tiled_record(value, dim: int, n: int) -> dict | None:
    """The tiling record of a pack file (None when it has none, as in files written
    before tiling existed); its counts times its particles must give the pack's N."""
    if value is None:
        return None
    if not isinstance(value, dict):
        raise ValueError(f"'tiled' is {type(value).__name__}, expected a table")
    counts = [int(c) for c in value["counts"]]
    base = [float(b) for b in value["base"]]
    particles = int(value["particles"])
    record = {
        "counts": counts,
        "particles": particles,
        "base": base,
        "seed": int(value["seed"]),
        "stream": int(value["stream"]),
        "scene_sha256": str(value["scene_sha256"]),
    }
    if len(counts) != dim - 1 or len(base) != dim - 1 or min(counts) < 1:
        raise ValueError(f"'tiled' has counts {counts} and base {base} for dim = {dim}")
    if particles * math.prod(counts) != n:
        raise ValueError(
            f"'tiled' says {particles} particles times {counts}, but the pack holds {n}"
        )
    return record


def _text(data: dict, key: str) -> str:
    """A text member (UTF-8 bytes stored as a 1-D uint8 array)."""
    a = data[key]
    if a.dtype != np.uint8 or a.ndim != 1:
        raise ValueError(f"{key!r} is not a byte string")
    return a.tobytes().decode()


def _check_arrays(data: dict, dim: int, contacts: Contacts) -> None:
    """Shapes and values of a pack's arrays: a damaged file fails here, not later."""
    x = data["positions"]
    n = x.shape[0] if x.ndim == 2 else -1
    spin = (n,) if dim == 2 else (n, 3)
    for key, shape in (
        ("positions", (n, dim)),
        ("radii", (n,)),
        ("velocities", (n, dim)),
        ("spins", spin),
        ("layer", (n,)),
    ):
        a = data[key]
        if a.shape != shape or a.dtype.kind not in ("f" if key != "layer" else "iu"):
            raise ValueError(f"{key!r} has shape {a.shape} and dtype {a.dtype}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{key!r} holds non-finite values")
    if np.any(data["radii"] <= 0):
        raise ValueError("'radii' holds values <= 0")
    m = len(contacts.i)
    for key, shape in (
        ("i", (m,)),
        ("j", (m,)),
        ("normal", (m, dim)),
        ("overlap", (m,)),
        ("force_normal", (m,)),
        ("force_tangential", (m, dim)),
        ("branch", (m, dim)),
    ):
        a = getattr(contacts, key)
        if a.shape != shape or a.dtype.kind not in ("iu" if key in "ij" else "f"):
            raise ValueError(f"'contacts.{key}' has shape {a.shape} and dtype {a.dtype}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"'contacts.{key}' holds non-finite values")
    i, j = contacts.i, contacts.j
    if m and (i.min() < 0 or i.max() >= n or j.min() < -6 or j.max() >= n):
        raise ValueError(f"'contacts.i' or 'contacts.j' names a particle outside [0, {n - 1}]")
    if np.any(i == j):
        k = int(np.argmax(i == j))
        raise ValueError(f"contact {k} joins particle {int(i[k])} to itself")


#: Bytes per particle to budget: the engine's peak is about 1.2 kB per sphere
#: (`cargo run --release --example memory`), plus the arrays handed to Python.
BYTES_PER_PARTICLE = 1500


def check_memory(scene: PackScene, total_bytes: float | None = None) -> None:
    """Refuses a scene whose particles would not fit in 80 % of the memory this process
    may use (`granpack._memory.memory_limit`: the machine's, RLIMIT_AS's or the control
    group's, the smallest), or of `total_bytes`, before any work is done."""
    source = "this machine's memory"
    if total_bytes is None:
        limit = memory_limit()
        if limit is None:  # cannot tell
            return
        total_bytes, source = limit.bytes, limit.source
    n = scene.estimated_particles()
    need = n * BYTES_PER_PARTICLE
    if need > 0.8 * total_bytes:
        raise InvalidParameterError(
            f"invalid scene: about {n:.3g} particles (~{need / 2**30:.1f} GiB) would not fit "
            f"in {source} ({total_bytes / 2**30:.1f} GiB); shrink base or height, or grow "
            "r_mean",
            parameter="scene",
        )


def _packer(scene: PackScene) -> _core.LayerPacker:
    """The engine's layer loop for `scene` (which the engine reads by attribute)."""
    return _core.LayerPacker(scene)


def fall_time(scene: PackScene) -> float:
    """Time (s) a particle at the top of a layer's slab needs to reach its bottom: free
    fall sqrt(2 h_layer / g), or, when drag is strong, h_layer over the terminal speed
    m g / c_D of the lightest particle, whichever is longer."""
    t = math.sqrt(2.0 * scene.h_layer / scene.gravity)
    if scene.drag > 0.0:
        r = scene.r_min
        assert r is not None  # set by PackScene.__post_init__
        disc = scene.dim == 2 and scene.inertia_2d == "disc"
        vol = math.pi * r * r if disc else 4.0 / 3.0 * math.pi * r * r * r
        v_terminal = scene.material.density * vol * scene.gravity / scene.drag
        t = max(t, scene.h_layer / v_terminal) if v_terminal > 0 else math.inf
    return t


def settling_issue(pack: Pack) -> str | None:
    """Why `pack` has not come to rest (see `UnsettledPackWarning`), or None."""
    scene = pack.scene
    t_fall = fall_time(scene)
    if scene.settle_time < t_fall:
        return (
            f"settle_time = {scene.settle_time:g} s is shorter than the {t_fall:.3g} s a "
            f"layer needs to fall through its slab (h_layer = {scene.h_layer:g} m, gravity = "
            f"{scene.gravity:g} m/s^2, drag = {scene.drag:g} N s/m): the last layer is still "
            "in the air; give settle_time >= the fall time"
        )
    if len(pack) == 0:
        return None
    with np.errstate(over="ignore", invalid="ignore"):
        v2 = np.sum(np.asarray(pack.velocities, dtype=float) ** 2, axis=1)
        ratio = float(np.mean(0.5 * v2 / (scene.gravity * pack.radii)))
        speed = np.sqrt(v2)
    vmax = float(np.max(speed))
    # the speed of a pack at rest, from the scene (r_mean: the mean radius by number)
    r_mean = float(scene.r_mean) if scene.r_mean else float(np.mean(pack.radii))
    v_rest = UNSETTLED_SPEED_RATIO * math.sqrt(scene.gravity * r_mean)
    moving = int(np.count_nonzero(~(speed <= v_rest)))  # NaN counts as moving
    if moving > UNSETTLED_MOVING_FRACTION * len(pack):
        # (the numbers in one pair of parentheses: the command line groups its notes
        # by the words outside them)
        return (
            f"more than {UNSETTLED_MOVING_FRACTION:.0%} of the particles still move at the "
            f"end, faster than {UNSETTLED_SPEED_RATIO} sqrt(g r_mean) ({moving} of "
            f"{len(pack)} faster than {v_rest:.3g} m/s; fastest {vmax:.3g} m/s): the pack "
            f"has not settled in settle_time = {scene.settle_time:g} s; give a longer "
            "settle_time"
        )
    if not ratio <= UNSETTLED_KE_RATIO:
        return (
            f"the particles still move at the end (mean kinetic energy {ratio:.3g} m g r, "
            f"above {UNSETTLED_KE_RATIO} m g r; fastest {vmax:.3g} m/s): the pack has not "
            f"settled in settle_time = {scene.settle_time:g} s; give a longer settle_time"
        )
    return None


def _check_trim_keeps_particles(packer: _core.LayerPacker, scene: PackScene) -> None:
    """Refuses a flat top that would remove every particle (an empty pack), naming the
    trim height `height` and the heights that keep particles."""
    state = packer.state()
    x = np.asarray(state["positions"], dtype=np.float64)
    r = np.asarray(state["radii"], dtype=np.float64)
    tops = x[:, scene.vertical] + r if len(r) else np.array([math.inf])
    lowest = float(np.min(tops))
    if not lowest <= scene.height:
        raise InvalidParameterError(
            f"invalid height = {scene.height:g} m with trim = true: the flat top would "
            "remove every particle (each one's top z + r lies above height; the lowest "
            f"reaches {lowest!r} m) and leave an empty pack; give height >= "
            f"{lowest!r} m, or trim = false",
            parameter="height",
            value=scene.height,
            expected=f">= {lowest!r} m with trim = true",
        )


def deposit(
    scene: PackScene,
    progress: bool | Callable[[dict], None] = False,
    *,
    _stacklevel: int = 2,
) -> Pack:
    """The layer loop alone: one pack built layer by layer (RSA layer, DEM jamming run,
    new height) until the height reaches `scene.height`, then the flat top if the scene
    asks. The stages after it (a density target, `rest_tol`, `[consolidate]`) are
    `granpack.generate`'s; this runs none of them.

    Parameters
    ----------
    scene : PackScene
    progress : bool or callable
        As `granpack.generate`; a callable's report also holds ``memory``, the
        engine's bytes by group (`_core.LayerPacker.memory`).

    Warns
    -----
    UnsettledPackWarning
        The pack has not come to rest (see `settling_issue`).
    """
    check_memory(scene)
    t0 = time.perf_counter()
    packer = _packer(scene)
    reports: list[dict] = []
    bar = None
    if progress is True:
        from tqdm.auto import tqdm

        bar = tqdm(total=round(scene.height, 6), unit="m", desc="layers", leave=False)
    try:
        while not packer.done:
            rep: dict[str, Any] = dict(packer.next_layer())
            reports.append(rep)
            if bar is not None:
                bar.n = round(min(rep["height"], scene.height), 6)
                bar.set_postfix(layer=rep["layer"], N=rep["total"], s=f"{rep['wall_seconds']:.1f}")
                bar.refresh()
            elif callable(progress):
                # the engine's memory with the report, for the callback only (the pack
                # keeps the reports as the engine gave them)
                progress({**rep, "memory": dict(packer.memory())})
    finally:
        if bar is not None:
            bar.close()
    trim = None
    if scene.trim:
        _check_trim_keeps_particles(packer, scene)
        done = packer.trim(scene.height)
        trim = {
            "removed": int(done["removed"]),
            "top": float(done["height"]),
            "steps": done["steps"],
        }
    height = float(packer.height)
    # The engine is spent to build the pack: its pair state is freed as the contact
    # table is written, so the two are never held whole at once (at a million spheres
    # that is the generation's peak).
    state, table = packer.finish()
    del packer
    contacts = Contacts.from_dict(table)
    del table
    if trim is not None:
        r = np.asarray(state["radii"])
        solid = float(np.sum(np.pi * r**2 if scene.dim == 2 else 4 / 3 * np.pi * r**3))
        trim["phi_hd"] = solid / (scene.base_area * scene.height)
    pack = Pack(
        scene=scene,
        positions=state["positions"],
        radii=state["radii"],
        velocities=state["velocities"],
        spins=state["spins"],
        layer=state["layer"],
        contacts=contacts,
        height=height,
        layers=reports,
        wall_time=time.perf_counter() - t0,
        history=() if trim is None else (StageRecord.from_table("trim", trim),),
    )
    issue = settling_issue(pack)
    if issue is not None:
        warnings.warn(issue, UnsettledPackWarning, stacklevel=_stacklevel)
    return pack
