"""The parts of a ``report.md`` page that both reports share: `granpack.report`'s
(``granpack generate``) and `granpack.paper.report`'s (``granpack paper``). Links are
relative to the report, so the output folder can be moved or published as it is."""

from __future__ import annotations

import datetime as _dt
import os
import platform
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

__all__ = [
    "column",
    "dev_banner",
    "duration",
    "environment_line",
    "grouped_links",
    "mean_sd",
    "rel_link",
]


def rel_link(path: Path, base: Path) -> str:
    """`path` relative to the folder `base`, with forward slashes."""
    return Path(os.path.relpath(Path(path).resolve(), Path(base).resolve())).as_posix()


def mean_sd(values: Sequence[float], digits: int = 3) -> str:
    """The mean ± sample sd of the finite values (one value alone, "n/a" for none)."""
    v = np.asarray([x for x in values if x is not None], dtype=np.float64)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return "n/a"
    if v.size == 1:
        return f"{v[0]:.{digits}f}"
    return f"{v.mean():.{digits}f} ± {v.std(ddof=1):.{digits}f}"


def column(records: Sequence[Mapping], key: str) -> list[float]:
    """The records' values of `key` as floats, NaN where a record has none."""
    return [float(r[key]) if r.get(key) is not None else float("nan") for r in records]


def grouped_links(files: Sequence[Path], base: Path) -> dict[str, list[tuple[str, str]]]:
    """{stem: [(suffix, relative link)]} for files that share a stem (x.md, x.csv)."""
    groups: dict[str, list[tuple[str, str]]] = {}
    for f in files:
        f = Path(f)
        groups.setdefault(f.stem, []).append((f.suffix.lstrip("."), rel_link(f, base)))
    for v in groups.values():
        v.sort(key=lambda s: (s[0] != "md", s[0]))
    return groups


def environment_line(wall_time: float) -> str:
    """The version, date, machine and wall time (s) of a run, in one line."""
    from ._core import __version__

    when = _dt.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z")
    return (
        f"granpack {__version__}, {when}, {platform.node() or 'this machine'} "
        f"({os.cpu_count()} cores), wall time {duration(wall_time)}"
    )


def duration(seconds: float) -> str:
    """`seconds` in s, min or h, whichever reads best."""
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


def dev_banner(dev_changes: Mapping) -> list[str]:
    """The warning that heads a report of a run with development options (none without)."""
    if not dev_changes:
        return []
    parts = ", ".join(f"{k} {v}" for k, v in dev_changes.items())
    return [
        f"> **Development run, not the paper's scenes:** {parts}. "
        "Do not compare these numbers with the paper.",
        "",
    ]
