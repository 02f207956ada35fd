"""YADE's text format (``#format x_y_z_r``): ``export.text`` / ``ymport.text``."""

from __future__ import annotations

import io
import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._files import atomic_write
from .._validate import (
    FileFormatError,
    is_number,
)

if TYPE_CHECKING:
    from ..pack import Pack

from .._numbers import _number_table
from ._text import (
    _check_values,
    _choose_dim,
    _comment_tag,
    _integer_ids,
    _pad3,
    _read_text,
    _rows_text,
    _sorted_by_id,
    _tag,
    _tag_fields,
    _text_digits,
)
from .particle_file import ParticleFile

# YADE's text export: "#format x_y_z_r" (export.text), or another textExt layout
_YADE_HEADER = re.compile(r"^#\s*format\s+(\S+)\s*$")


#: The YADE layouts read, as their header names them; columns other than x y z r id are
#: skipped (matId, the material).
YADE_LAYOUTS = ("x_y_z_r", "x_y_z_r_matId", "id_x_y_z_r_matId")


def read_yade(path: Path, dim: int | None) -> ParticleFile:
    """YADE's text export: the ``#format`` header names the columns."""
    lines = _read_text(path).splitlines()
    k0 = next((k for k, ln in enumerate(lines) if ln.strip()), None)
    head = _YADE_HEADER.match(lines[k0].strip()) if k0 is not None else None
    if head is None or head.group(1) not in YADE_LAYOUTS:
        found = repr(lines[k0].strip()[:60]) if k0 is not None else "an empty file"
        raise FileFormatError(
            f"{path}:{(k0 or 0) + 1}: expected a YADE header '#format <layout>' with a layout "
            f"of {', '.join(YADE_LAYOUTS)}, found {found}",
            path=path,
        )
    assert k0 is not None  # a header was matched
    layout = head.group(1)
    names = layout.split("_")
    ncol = len(names)
    fast = _number_table(lines, k0 + 1, (ncol,), commas=False)
    if fast is not None:
        return _yade_particles(path, lines, k0, names, fast, dim)
    rows: list[list[float]] = []
    row_line: list[int] = []
    for k in range(k0 + 1, len(lines)):
        body = lines[k].split("#", 1)[0].split()
        if not body:
            continue
        if len(body) != ncol:
            raise FileFormatError(
                f"{path}:{k + 1}: expected {ncol} numbers ({' '.join(names)}, as the header "
                f"'#format {layout}' says), found {len(body)} fields",
                path=path,
            )
        bad = next((v for v in body if not is_number(v)), None)
        if bad is not None:
            raise FileFormatError(f"{path}:{k + 1}: {bad!r} is not a number", path=path)
        rows.append([float(v) for v in body])
        row_line.append(k + 1)
    if not rows:
        raise FileFormatError(f"{path}: no spheres after the header '#format {layout}'", path=path)
    return _yade_particles(path, lines, k0, names, np.array(rows, dtype=np.float64), dim, row_line)


def _yade_particles(
    path: Path,
    lines: list[str],
    k0: int,
    names: list[str],
    a: np.ndarray,
    dim: int | None,
    row_line: list[int] | None = None,
) -> ParticleFile:
    """The ParticleFile of YADE's rows `a` (columns `names`); `row_line` the line of each
    row, found from `lines` only where an error needs it."""
    found: list[list[int]] = [] if row_line is None else [row_line]

    def line_of(k: int) -> int:
        if not found:  # the rows' lines, counted only when a message needs one
            found.append(
                [j + 1 for j in range(k0 + 1, len(lines)) if lines[j].split("#", 1)[0].strip()]
            )
        return found[0][k]

    x3 = a[:, [names.index(c) for c in ("x", "y", "z")]]
    r = a[:, names.index("r")]
    ids = None
    order = np.arange(a.shape[0])
    if "id" in names:
        at = names.index("id")
        ids = _integer_ids(
            path,
            a[:, at],
            line_of,
            lambda: [lines[line_of(k) - 1].split("#", 1)[0].split()[at] for k in range(len(a))],
        )
        order = _sorted_by_id(path, ids, line_of)
        ids, x3, r = ids[order], x3[order], r[order]
    _check_values(path, x3, r, lambda k: line_of(int(order[k])))
    d = _choose_dim(path, x3, True, dim)
    tag = _comment_tag(path, lines, d)
    cols = [names.index(c) for c in ("x", "y", "z", "r")]
    digits = _text_digits(lines[k0 + 1 :], cols, comment="#")
    return ParticleFile(
        path=path,
        format="yade",
        positions=x3[:, :d],
        radii=r,
        ids=ids,
        digits=digits,
        **_tag_fields(tag, d),
    )


def write_yade(pack: Pack, path: str | Path) -> Path:
    """Writes YADE's text format (``#format x_y_z_r``, then ``x y z r`` a line at full
    precision), which ``yade.ymport.text`` reads. Returns the path."""
    x = _pad3(pack.positions)
    r = np.asarray(pack.radii, dtype=np.float64)
    out = io.StringIO()
    out.write("#format x_y_z_r\n")
    # ymport.text skips comment lines; read_particles takes the container from this one
    out.write(f"# granpack: dim={pack.dim} {_tag(pack)}\n")
    out.write(_rows_text(x[:, 0], x[:, 1], x[:, 2], r))
    return atomic_write(Path(path), out.getvalue().encode())
