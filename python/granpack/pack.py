"""Pack generation (the paper's Algorithm 1) and pack files."""

from __future__ import annotations

import io
import json
import lzma
import os
import struct
import tempfile
import time
import zipfile
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from . import _core
from ._validate import FileFormatError, GranpackError, InvalidParameterError
from .contacts import Contacts
from .scene import PackScene

__all__ = ["Pack", "generate", "load_pack", "atomic_write"]

FORMAT_VERSION = 1


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
        arrays["meta.json"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
        arrays["scene.toml"] = np.frombuffer(self.scene.to_toml().encode(), dtype=np.uint8)
        buf = io.BytesIO()
        # (numpy's stub types the keyword arrays as its allow_pickle flag)
        np.savez_compressed(buf, **arrays)  # type: ignore[arg-type]
        return atomic_write(path, buf.getvalue())


def atomic_write(path: str | Path, data: bytes) -> Path:
    """Writes bytes to `path` through a temporary file in the same folder and a rename,
    so a reader never sees a half-written file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def load_pack(path: str | Path) -> Pack:
    """Reads a pack written by `Pack.save`; a truncated or foreign file is a
    GranpackError, never a crash."""
    if not isinstance(path, str | os.PathLike):
        raise InvalidParameterError(f"invalid path = {path!r}: expected a file name")
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise GranpackError(f"cannot read pack {path}: no such file") from None
    except OSError as exc:
        raise GranpackError(f"cannot read pack {path}: {exc.strerror}") from None
    try:
        # Parse from memory: a corrupt archive then leaves no file handle open.
        z = np.load(io.BytesIO(raw), allow_pickle=False)
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
        # array header can announce an absurd shape (MemoryError).
        reason = f"corrupt or truncated ({type(exc).__name__}: {exc})"
        raise FileFormatError(
            f"cannot read pack {path}: {reason}", path=path, reason=reason
        ) from None
    try:
        meta = json.loads(_text(data, "meta.json"))
        if not isinstance(meta, dict) or meta.get("format") != "granpack-pack":
            raise ValueError("not a granpack pack file")
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
            height=float(meta["height"]),
            layers=list(meta["layers"]),
            wall_time=float(meta["wall_time"]),
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


#: Bytes per particle to budget: the engine's peak is about 1.2 kB per sphere
#: (`cargo run --release --example memory`), plus the arrays handed to Python.
BYTES_PER_PARTICLE = 1500


def check_memory(scene: PackScene, total_bytes: float | None = None) -> None:
    """Refuses a scene whose particles would not fit in 80 % of this machine's memory
    (or of `total_bytes`), before any work is done."""
    if total_bytes is None:
        try:
            total_bytes = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
        except (ValueError, OSError, AttributeError):  # not POSIX: cannot tell
            return
    n = scene.estimated_particles()
    need = n * BYTES_PER_PARTICLE
    if need > 0.8 * total_bytes:
        raise InvalidParameterError(
            f"invalid scene: about {n:.3g} particles (~{need / 2**30:.1f} GiB) would not fit "
            f"in this machine's memory ({total_bytes / 2**30:.1f} GiB); shrink base or "
            "height, or grow r_mean"
        )


def _packer(scene: PackScene) -> _core.LayerPacker:
    s = scene
    gravity = [0.0] * s.dim
    gravity[s.vertical] = -s.gravity
    law: tuple[Literal["constant", "gaussian"], float, float, float, float]
    law = ("constant", s.r_mean, 0.0, s.r_mean, s.r_mean)
    if s.radius_law == "gaussian":
        assert s.r_min is not None and s.r_max is not None  # set by __post_init__
        law = ("gaussian", s.r_mean, s.r_std, s.r_min, s.r_max)
    return _core.LayerPacker(
        s.dim,
        s.material.as_tuple(),
        s.dt,
        gravity,
        s.drag,
        s.rotations,
        list(s.base),
        s.height,
        law,
        s.h_layer,
        s.phi_layer,
        s.settle_time,
        s.seed,
        stream=s.stream,
        max_attempts=s.max_attempts,
        max_layers=s.max_layers,
        skin_ratio=s.skin_ratio,
        max_overlap_ratio=s.max_overlap_ratio,
        inertia_2d=s.inertia_2d,
        adaptive_settle=s.settle_tol,
        freeze_depth=s.freeze_depth,
        freeze_speed=s.freeze_speed,
        freeze_force=s.freeze_force,
        settle_dt=s.settle_dt,
    )


def generate(
    scene: PackScene,
    progress: bool | Callable[[dict], None] = False,
) -> Pack:
    """Builds one pack layer by layer (RSA layer, DEM jamming run, new height) until the
    height reaches `scene.height`.

    Parameters
    ----------
    scene : PackScene
    progress : bool or callable
        False (default): silent. True: a tqdm bar per layer on stderr. A callable gets
        each layer's report dict (layer, added, total, phi_rsa, height, steps,
        kinetic_energy, wall_seconds).
    """
    if not isinstance(scene, PackScene):
        raise InvalidParameterError(f"invalid scene = {scene!r}: must be a granpack.PackScene")
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
                progress(rep)
    finally:
        if bar is not None:
            bar.close()
    state = packer.state()
    contacts = Contacts.from_dict(packer.contacts())
    return Pack(
        scene=scene,
        positions=state["positions"],
        radii=state["radii"],
        velocities=state["velocities"],
        spins=state["spins"],
        layer=state["layer"],
        contacts=contacts,
        height=float(packer.height),
        layers=reports,
        wall_time=time.perf_counter() - t0,
    )
