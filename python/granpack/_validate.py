"""Input checks shared by every entry point: one clear ValueError naming the field."""

from __future__ import annotations

import difflib
import math
import os
import reprlib
from collections.abc import Iterable
from numbers import Integral, Real
from pathlib import Path

import numpy as np

from .errors import FileFormatError, GranpackError, InvalidParameterError

__all__ = [
    "GranpackError",
    "InvalidParameterError",
    "FileFormatError",
    "as_real",
    "as_int",
    "as_bool",
    "as_array",
    "unknown_keys",
    "short_repr",
    "is_number",
    "check_outputs",
]

# Error messages quote the value they refuse; a huge or deeply nested value (a list of
# millions of numbers in a scene file) is shown cut down, never echoed whole.
_SHORT = reprlib.Repr()
_SHORT.maxlevel = 3
_SHORT.maxlist = _SHORT.maxtuple = _SHORT.maxdict = _SHORT.maxset = 6
_SHORT.maxstring = 60
_SHORT.maxother = 60
_SHORT.maxlong = 40


def short_repr(value: object) -> str:
    """repr(value) cut to about 80 characters, for error messages."""
    try:
        text = _SHORT.repr(value)
    except Exception:  # a repr that fails (or recurses) still gets a name
        text = f"<{type(value).__name__}>"
    return text if len(text) <= 100 else text[:60] + "..." + text[-20:]


def as_real(
    name: str,
    value: object,
    lo: float = -math.inf,
    hi: float = math.inf,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    allow_inf: bool = False,
    unit: str = "",
) -> float:
    """Returns `value` as a float in the given range or raises GranpackError naming it."""
    if isinstance(value, bool) or not isinstance(value, Real | np.floating | np.integer):
        raise InvalidParameterError(
            f"invalid {name} = {short_repr(value)}: must be a real number{unit_txt(unit)}",
            parameter=name,
        )
    try:
        v = float(value)
    except OverflowError:  # an integer beyond any float
        v = math.inf if value > 0 else -math.inf  # type: ignore[operator]
    if math.isnan(v) or (math.isinf(v) and not allow_inf):
        raise InvalidParameterError(
            f"invalid {name} = {v}: must be finite{unit_txt(unit)}", parameter=name
        )
    bad_lo = v <= lo if lo_open else v < lo
    bad_hi = v >= hi if hi_open else v > hi
    if bad_lo or bad_hi:
        lb = "(" if lo_open else "["
        hb = ")" if hi_open else "]"
        raise InvalidParameterError(
            f"invalid {name} = {v}: must lie in {lb}{lo}, {hi}{hb}{unit_txt(unit)}", parameter=name
        )
    return v


def is_number(s: str) -> bool:
    """Whether the text `s` is a number as `float` reads it (file readers use this to
    name the first field that is not)."""
    try:
        float(s)
    except ValueError:
        return False
    return True


def unit_txt(unit: str) -> str:
    return f" ({unit})" if unit else ""


def as_int(name: str, value: object, lo: int, hi: int | None = None) -> int:
    """Returns `value` as an int in [lo, hi] or raises GranpackError naming it."""
    if isinstance(value, bool) or not isinstance(value, Integral | np.integer):
        raise InvalidParameterError(
            f"invalid {name} = {short_repr(value)}: must be an integer", parameter=name
        )
    v = int(value)
    if v < lo or (hi is not None and v > hi):
        upper = "inf" if hi is None else str(hi)
        raise InvalidParameterError(
            f"invalid {name} = {short_repr(v)}: must lie in [{lo}, {upper}]", parameter=name
        )
    return v


def as_bool(name: str, value: object) -> bool:
    """Accepts True/False (and numpy bools) only."""
    if isinstance(value, bool | np.bool_):
        return bool(value)
    raise InvalidParameterError(
        f"invalid {name} = {short_repr(value)}: must be true or false", parameter=name
    )


def as_array(name: str, value: object, shape: tuple[int | None, ...]) -> np.ndarray:
    """A float64 C-contiguous copy-at-most-once of `value` with the given shape
    (None: any length). Rejects non-numeric input and non-finite values."""
    try:
        a = np.asarray(value)
    except Exception as exc:  # ragged lists and the like
        raise InvalidParameterError(
            f"invalid {name}: not an array ({exc})", parameter=name
        ) from None
    if (
        a.dtype == object
        or not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer))
        or a.dtype == np.bool_
    ):
        raise InvalidParameterError(
            f"invalid {name}: dtype {a.dtype}, expected a real (float64) array", parameter=name
        )
    a = np.ascontiguousarray(a, dtype=np.float64)
    want = "(" + ", ".join("N" if s is None else str(s) for s in shape) + ")"
    # zip is safe: a.ndim == len(shape) is checked first
    if a.ndim != len(shape) or any(
        s is not None and s != n for s, n in zip(shape, a.shape, strict=False)
    ):
        raise InvalidParameterError(
            f"invalid {name}: shape {a.shape}, expected {want}", parameter=name
        )
    if not np.all(np.isfinite(a)):
        bad = np.argwhere(~np.isfinite(a))[0]
        where = tuple(int(b) for b in bad)
        raise InvalidParameterError(
            f"invalid {name}: non-finite value at index {where}", parameter=name
        )
    return a


def _same_path(a: Path, b: Path) -> bool:
    """Whether two paths name one file: the same path once symbolic links, ``..`` and
    case (where the system ignores it) are resolved, or one file under two names (hard
    links, bind mounts)."""
    try:
        if os.path.normcase(a.resolve()) == os.path.normcase(b.resolve()):
            return True
    except (OSError, RuntimeError):  # a symlink loop: compare as written
        if os.path.normcase(os.path.abspath(a)) == os.path.normcase(os.path.abspath(b)):
            return True
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def _check_writable(out: Path, flag: str, parameter: str) -> None:
    """Refuses an output file that cannot be written where it is named: an existing
    folder (or device) of that name, a parent that is a file, or a folder (or, when
    it does not exist yet, the nearest folder above it, where it would be made) without
    write permission or on a read-only file system. The write itself may still fail
    (a full disk), but not for a reason known before the work."""

    def refuse(why: str) -> InvalidParameterError:
        return InvalidParameterError(
            f"invalid {flag} = {short_repr(str(out))}: cannot write {out}: {why}",
            parameter=parameter,
            value=str(out),
            expected="a file in a folder this user can write",
        )

    if out.exists() and not out.is_file():
        raise refuse("it exists and is not a regular file")
    folder = out.parent
    while True:
        try:
            os.stat(folder)
        except (FileNotFoundError, NotADirectoryError):  # to be made: its nearest folder
            if folder.parent == folder:
                break
            folder = folder.parent
            continue
        except OSError as exc:  # a file in the middle of the path, a loop
            raise refuse(f"{folder}: {exc.strerror}") from None
        break
    if not folder.is_dir():
        raise refuse(f"{folder} is not a folder")
    # access(2) also answers EROFS for a read-only file system, for root too
    if not os.access(folder, os.W_OK | os.X_OK):
        raise refuse(f"the folder {folder} is not writable")


def check_outputs(
    outputs: Iterable[str | os.PathLike], inputs: Iterable[str | os.PathLike], parameter: str
) -> None:
    """Refuses, before anything is written, a set of output files of which two are one
    file, or one is an input file, or one that cannot be written there (an existing
    folder of that name, a folder that is not writable): an InvalidParameterError
    naming `parameter` (the option or argument that chose the outputs' names) and the
    output's own path."""
    outs = [Path(p) for p in outputs]
    ins = [Path(p) for p in inputs if p is not None]
    flag = parameter  # as the user spells it: "--out", or a function's "path"
    for k, out in enumerate(outs):
        for src in ins:
            if _same_path(out, src):
                raise InvalidParameterError(
                    f"invalid {flag} = {short_repr(str(out))}: the input file {src} would "
                    f"be overwritten (the output {out} is that file); choose another name",
                    parameter=parameter.lstrip("-").replace("-", "_"),
                    value=str(out),
                    expected="a name that is none of the inputs",
                )
        for other in outs[:k]:
            if _same_path(out, other):
                raise InvalidParameterError(
                    f"invalid {flag} = {short_repr(str(out))}: two outputs of this command "
                    f"would be one file ({other} and {out}), the first overwritten by the "
                    "second; choose another name",
                    parameter=parameter.lstrip("-").replace("-", "_"),
                    value=str(out),
                    expected="a name whose outputs are distinct files",
                )
        _check_writable(out, flag, parameter.lstrip("-").replace("-", "_"))


def unknown_keys(where: str, given: Iterable[str], known: Iterable[str]) -> None:
    """Raises on the first key not in `known`, suggesting the closest one."""
    known = list(known)
    for key in given:
        if not isinstance(key, str):
            raise InvalidParameterError(
                f"unknown {where} key {short_repr(key)}: keys are names (strings)",
                parameter=where,
            )
        if key not in known:
            close = difflib.get_close_matches(key, known, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise InvalidParameterError(
                f"unknown {where} key {short_repr(key)}{hint} (known: {', '.join(sorted(known))})",
                # the key as it is written: a scene key alone, another table's after its name
                parameter=key if where == "scene" else f"{where}.{key}",
            )
