"""Extended XYZ (OVITO, ASE): one frame or several."""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._files import atomic_write
from .._validate import (
    FileFormatError,
    is_number,
)
from ..analysis.container import Container

if TYPE_CHECKING:
    from ..pack import Pack

from ._text import (
    _check_values,
    _choose_dim,
    _column_table,
    _frame_index,
    _read_text,
    _rows_text,
)
from .lammps import lammps_positions
from .particle_file import ParticleFile


def _xyz_frames(path: Path, lines: list[str]) -> list[int]:
    """The count line (0-based) of every frame of an extended XYZ file: a count, a comment
    line, then that many rows, repeated. Every frame's structure is checked, so that a
    truncated file is refused whichever frame is asked for."""
    starts: list[int] = []
    i = 0
    while i < len(lines):
        count = lines[i].strip()
        if not count:  # blank lines between frames and at the end
            i += 1
            continue
        if not (count.isascii() and count.isdigit()):
            what = (
                "the particle count (an integer)"
                if not starts
                else f"the particle count of frame {len(starts)} (an integer) or the end of "
                f"the file after the {int(lines[starts[-1]])} rows of the frame at line "
                f"{starts[-1] + 1}"
            )
            raise FileFormatError(
                f"{path}:{i + 1}: expected {what}, found {count[:60]!r}", path=path
            )
        n = int(count)
        if i + 1 >= len(lines):
            raise FileFormatError(
                f"{path}:{i + 2}: expected the comment line with Properties=, found the end of "
                "the file",
                path=path,
            )
        if i + 2 + n > len(lines):
            raise FileFormatError(
                f"{path}:{len(lines) + 1}: expected {n} particle rows after line {i + 2} (line "
                f"{i + 1} says {n}), found {len(lines) - i - 2}: a truncated file",
                path=path,
            )
        starts.append(i)
        i += 2 + n
    if not starts:
        raise FileFormatError(
            f"{path}:1: expected the particle count (an integer), found an empty file", path=path
        )
    return starts


def _xyz_numbers(path: Path, line: int, key: str, value: str, count: int) -> np.ndarray:
    """The `count` finite numbers of the comment line's ``key="..."``, or a
    FileFormatError naming the key (the comment is line `line`)."""
    words = value.split()
    if len(words) != count or not all(is_number(w) for w in words):
        raise FileFormatError(
            f'{path}:{line}: expected {key}="..." with {count} numbers, found {value!r}',
            path=path,
        )
    a = np.array(words, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        raise FileFormatError(
            f'{path}:{line}: expected {key}="..." with {count} finite numbers, found {value!r}',
            path=path,
        )
    return a


#: The extended XYZ booleans (pbc)
_XYZ_TRUE = ("T", "TRUE")


_XYZ_FALSE = ("F", "FALSE")


def read_xyz(path: Path, snapshot: int, dim: int | None) -> ParticleFile:
    """Extended XYZ, one or more frames, each: the count, the comment line with
    ``Properties=`` (and optionally an orthogonal ``Lattice``, ``Origin``, ``pbc``), then
    the rows. Frame `snapshot` is read (-1: the last), as a dump's snapshot."""
    import shlex

    lines = _read_text(path).splitlines()
    starts = _xyz_frames(path, lines)
    n_frames = len(starts)
    k_frame = _frame_index(path, snapshot, n_frames, "file", "frame")
    b = starts[k_frame]  # the frame's count line (0-based); its comment is line b + 2
    n = int(lines[b])
    if n == 0:
        raise FileFormatError(
            f"{path}:{b + 1}: frame {k_frame} holds no particles (count 0)", path=path
        )
    c = b + 2
    try:
        words = shlex.split(lines[b + 1])
    except ValueError as exc:
        raise FileFormatError(
            f"{path}:{c}: cannot read the comment line: {exc}", path=path
        ) from None
    info = {}
    for w in words:
        if "=" in w:
            key, value = w.split("=", 1)
            info[key.lower()] = value
    spec = info.get("properties", "").split(":")
    if len(spec) % 3 or not spec[0]:
        raise FileFormatError(
            f"{path}:{c}: expected Properties=name:type:count:..., found "
            f"{info.get('properties', 'none')!r}",
            path=path,
        )
    cols: dict[str, tuple[int, int]] = {}
    at = 0
    for k in range(0, len(spec), 3):
        name, kind, count = spec[k].lower(), spec[k + 1], spec[k + 2]
        if not (count.isascii() and count.isdigit() and int(count) >= 1):
            raise FileFormatError(
                f"{path}:{c}: property {spec[k]!r} has count {count!r} (expected an integer >= 1)",
                path=path,
            )
        if kind.upper() not in ("S", "R", "I", "L"):
            raise FileFormatError(
                f"{path}:{c}: property {spec[k]!r} has type {kind!r} (expected S, R, I or L)",
                path=path,
            )
        if name in cols:
            raise FileFormatError(
                f"{path}:{c}: property {spec[k]!r} named twice in Properties", path=path
            )
        cols[name] = (at, int(count))
        at += int(count)
    missing = [name for name in ("pos", "radius") if name not in cols]
    if missing or cols["pos"][1] not in (2, 3) or cols["radius"][1] != 1:
        raise FileFormatError(
            f"{path}:{c}: missing propert{'ies' if len(missing) > 1 else 'y'} "
            f"{' and '.join(missing) or 'pos with 2 or 3 components and radius with 1'} in "
            "Properties (expected pos:R:3 and radius:R:1)",
            path=path,
            reason="missing columns",
        )
    p0, pn = cols["pos"]
    r0 = cols["radius"][0]
    used = [*range(p0, p0 + pn), r0]
    a = _column_table(lines[b + 2 : b + 2 + n], at, used)
    if a is None:  # row by row, naming the row at fault
        rows = [ln.split() for ln in lines[b + 2 : b + 2 + n]]
        for k, t in enumerate(rows):
            if len(t) != at:
                raise FileFormatError(
                    f"{path}:{c + k + 1}: expected {at} values (Properties), found {len(t)}",
                    path=path,
                )
        num = [[t[j] for j in used] for t in rows]
        for k, t in enumerate(num):
            bad = next((v for v in t if not is_number(v)), None)
            if bad is not None:
                raise FileFormatError(f"{path}:{c + k + 1}: {bad!r} is not a number", path=path)
        a = np.array(num, dtype=np.float64).reshape(n, pn + 1)
    x3 = np.zeros((n, 3))
    x3[:, :pn] = a[:, :pn]
    r = a[:, pn]
    _check_values(path, x3, r, lambda k: c + k + 1)
    d = _choose_dim(path, x3, pn == 3, dim)
    box = None
    if "origin" in info:
        o = _xyz_numbers(path, c, "Origin", info["origin"], 3)
    else:
        o = np.zeros(3)
    if "lattice" in info:
        m = _xyz_numbers(path, c, "Lattice", info["lattice"], 9).reshape(3, 3)
        if np.any(m != np.diag(np.diag(m))):
            raise FileFormatError(
                f'{path}:{c}: a non-orthogonal cell (Lattice="{info["lattice"]}"); only '
                "orthogonal cells are read",
                path=path,
            )
        if np.any(np.diag(m)[:d] <= 0.0):
            raise FileFormatError(
                f'{path}:{c}: expected Lattice="..." with cell lengths > 0 along the '
                f"{d} axes of the particles, found {info['lattice']!r}",
                path=path,
            )
        box = (o[:d], (o + np.diag(m))[:d])
    periodic = None
    if "pbc" in info:
        pbc = info["pbc"].upper().split()
        if len(pbc) != 3 or not all(v in _XYZ_TRUE + _XYZ_FALSE for v in pbc):
            raise FileFormatError(
                f'{path}:{c}: expected pbc="..." with three of T, F (or True, False), '
                f"found {info['pbc']!r}",
                path=path,
            )
        periodic = tuple(v in _XYZ_TRUE for v in pbc[:d])
    notes: tuple[str, ...] = ()
    if n_frames > 1:
        notes = (f"frame {k_frame} of {n_frames} read (counted from 0)",)
    # the lattice and pbc say the box and the periodic axes; granpack's tag adds a cylinder
    tag = Container.read_tag(info.get("granpack", ""), path, c, d)
    extra: dict = {}
    if tag is not None:
        extra = {"container": tag.kind, "cylinder_radius": tag.cylinder_radius, "lid": tag.lid}
        if tag.kind == "periodic" and not (periodic and any(periodic[: d - 1])):
            periodic = (True,) * (d - 1)
    return ParticleFile(
        path=path,
        format="xyz",
        positions=x3[:, :d],
        radii=r,
        box=box,
        periodic=periodic,
        snapshot=k_frame,
        n_snapshots=n_frames,
        notes=notes,
        **extra,
    )


def _cell(pack: Pack) -> tuple[list[float], list[bool]]:
    """Lattice lengths (3) and periodic flags (3) of the pack's cell up to H_top."""
    s = pack.scene
    kind = Container.of_pack(pack).kind
    periodic = kind == "periodic"
    if s.dim == 3:
        return [s.base[0], s.base[1], pack.height], [periodic, periodic, False]
    half = float(np.max(pack.radii)) if len(pack) else float(s.r_max or 0.0)
    return [s.base[0], pack.height, 2.0 * half], [periodic, False, False]


def write_xyz(pack: Pack, path: str | Path) -> Path:
    """Writes extended XYZ with a radius column, as OVITO and ASE read it (layout in the
    module docstring). Returns the path."""
    s = pack.scene
    x = lammps_positions(pack)
    r = np.asarray(pack.radii, dtype=np.float64)
    lengths, pbc = _cell(pack)
    origin = [0.0, 0.0, 0.0 if s.dim == 3 else -lengths[2] / 2.0]
    lattice = " ".join(
        repr(float(lengths[a])) if a == b else "0.0" for a in range(3) for b in range(3)
    )
    comment = (
        f'Lattice="{lattice}" Origin="{" ".join(repr(float(o)) for o in origin)}" '
        "Properties=species:S:1:pos:R:3:radius:R:1 "
        f'pbc="{" ".join("T" if p else "F" for p in pbc)}" '
        f'granpack="dim={s.dim} seed={s.seed} stream={s.stream} H_top={pack.height!r} '
        f'{Container.of_pack(pack).tag_words(corners=False)}"'
    )
    out = io.StringIO()
    out.write(f"{len(pack)}\n{comment}\n")
    out.write(_rows_text(x[:, 0], x[:, 1], x[:, 2], r, prefix="X"))
    return atomic_write(Path(path), out.getvalue().encode())
