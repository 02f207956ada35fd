"""The pack file (``Pack.save``, `granpack.load_pack`): a stored (not deflated) ``.npz``
archive of the pack's arrays (``positions``, ``radii``, ``velocities``, ``spins``,
``layer``, ``contacts.*``), its scene (``scene.toml``) and its record (``meta.json``:
the format and its version, the height, the layer reports, the wall time and the
stages' history).

Format 2 keeps the history as one list of `granpack.history.StageRecord`; format 1
(granpack 0.1.0) kept five tables (``trim``, ``rest``, ``consolidation``, ``density``,
``tiled``), which `read` reads into the history. Either way each stage's table is
checked as 0.1.0 checked it. This module sits below `granpack.pack` (which builds the
`Pack` and writes through `atomic_write`), so that `Pack.save` and `load_pack` reach it
without an import circle; `granpack.io.npz` reads it as particles.
"""

from __future__ import annotations

import json
import lzma
import math
import os
import struct
import tomllib
import zipfile
import zlib
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from ._validate import FileFormatError, GranpackError, InvalidParameterError, short_repr
from .contacts import Contacts
from .history import TABLE_NAMES, StageRecord
from .scene import PackScene

__all__ = [
    "FORMAT_VERSION",
    "OLDEST_FORMAT_VERSION",
    "NEWER_FORMAT",
    "read",
    "write",
    "scene_record_error",
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


def write(f: BinaryIO, pack: Any) -> None:
    """Writes `pack` (a `granpack.Pack`) to the open binary file `f` in this version's
    format: its arrays, ``contacts.*``, ``scene.toml`` and the record ``meta.json``
    (height, layer reports, wall time, the stages' history and, for a pack another
    engine made, that engine's record)."""
    arrays = {
        "positions": pack.positions,
        "radii": pack.radii,
        "velocities": pack.velocities,
        "spins": pack.spins,
        "layer": pack.layer,
    }
    arrays.update({f"contacts.{k}": v for k, v in pack.contacts.to_dict().items()})
    meta = {
        "format": "granpack-pack",
        "version": FORMAT_VERSION,
        "height": pack.height,
        "layers": pack.layers,
        "wall_time": pack.wall_time,
    }
    if pack.history:
        meta["history"] = [rec.to_json() for rec in pack.history]
    if pack.engine is not None:
        meta["engine"] = pack.engine
    arrays["meta.json"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    arrays["scene.toml"] = np.frombuffer(pack.scene.to_toml().encode(), dtype=np.uint8)
    # Stored, not deflated: float64 positions and forces barely compress (a 1e6-sphere
    # pack: 300 MB deflated at 14 MB/s), while a stored zip is written and read at
    # disk speed. np.load reads both, so older files still load. The zip goes
    # straight into the temporary file: built in memory first, it held a second
    # copy of the pack (336 MB at 922 075 spheres) at the generation's peak.
    np.savez(f, **arrays)


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


def read(path: str | Path) -> dict[str, Any]:
    """The fields of a `granpack.Pack` (its keyword arguments) read from a pack file; a
    truncated or foreign file is a GranpackError, never a crash."""
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
        return dict(
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
            engine=_engine(meta),
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


def _engine(meta: dict) -> dict | None:
    """The record of the engine that made the pack (``name``, ``version``, ``ranks``),
    None for granpack's own (files without it)."""
    value = meta.get("engine")
    if value is None:
        return None
    if not (
        isinstance(value, dict)
        and isinstance(value.get("name"), str)
        and all(isinstance(value.get(k), int) for k in ("version", "ranks"))
    ):
        raise ValueError(f"engine record {short_repr(value)}")
    return {"name": value["name"], "version": value["version"], "ranks": value["ranks"]}


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
        "triaxial": _element_record,
        "oedometer": _element_record,
        "isotropic": _element_record,
    }
    if version >= 2:
        history = meta.get("history", [])
        if not isinstance(history, list):
            raise ValueError(f"'history' is {type(history).__name__}, expected a list")
        records = tuple(StageRecord.from_json(rec) for rec in history)
        for rec in records:
            checks[rec.stage](rec.table())
        return records
    tables = {
        stage: check(meta.get(TABLE_NAMES[stage]))
        for stage, check in checks.items()
        if stage in TABLE_NAMES  # the stages that 0.1.0 had
    }
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


def _element_record(value) -> dict:
    """An element test's record of a pack file: its table must be columns of one length."""
    if not isinstance(value, dict):
        raise ValueError(f"an element test's record is {type(value).__name__}, expected a table")
    table = value.get("table")
    if not isinstance(table, dict) or not table:
        raise ValueError("an element test's record holds no 'table' of columns")
    lengths = {k: len(v) if isinstance(v, list) else -1 for k, v in table.items()}
    if len(set(lengths.values())) != 1 or min(lengths.values()) < 1:
        raise ValueError(f"an element test's table has columns of lengths {lengths}")
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
