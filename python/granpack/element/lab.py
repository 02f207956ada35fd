"""What a lab report derives from an element test's table: pure functions, no DEM.

Every function takes the table an element test records (`granpack.element_table`: a
`polars.DataFrame`, one row per check, rows in path order, SI units, strains and
stresses compression-positive; see docs/element_tests.md) and returns a plain dict of
floats, ints, bools, lists and None, ready for JSON: a quantity the path does not define
(no unloading, a path too short for the dilatancy window) is None, never NaN.

* `triaxial_report`: the peak and critical-state friction angles and stress ratios,
  the maximum dilatancy angle, the secant modulus E50 and whether the test shows a
  marked peak.
* `eps_v_at`: the volumetric strain at an axial strain (interpolated).
* `compression_report`: the compression and swelling indices Cc and Cs (and lambda,
  kappa in ln), and K0 per row, of an oedometer or isotropic compression table.

Definitions follow Wood (1990), *Soil behaviour and critical state soil mechanics*
(p, q, eta, Cc, Cs) and Bolton (1986), *The strength and dilatancy of sands*
(Geotechnique 36(1)) for the angles.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import as_int, as_real
from ..errors import InvalidParameterError

if TYPE_CHECKING:  # polars is imported on first use: a stage list that runs no test
    import polars as pl  # (generate) does not pay for it

__all__ = [
    "CS_SHARE",
    "DILATANCY_WINDOW",
    "PEAK_MARGIN",
    "TRIAXIAL_COLUMNS",
    "triaxial_report",
    "eps_v_at",
    "compression_report",
]

#: The share of the axial strain range at the end of the path whose rows give the
#: critical state: rows with eps_a >= eps_a_start + (1 - CS_SHARE) (eps_a_end - eps_a_start).
CS_SHARE = 0.2
#: The axial strain (-) over which the dilatancy's increments are taken: a centred
#: difference from eps_a - w/2 to eps_a + w/2. Over 2 % axial strain the servo's and the
#: packing's row-to-row noise averages out and cannot make a spurious maximum.
DILATANCY_WINDOW = 0.02
#: A test shows a marked peak where its peak stress ratio q/p exceeds the critical-state
#: mean ratio by more than this share (-). The ratio of a sample of a thousand spheres
#: fluctuates by a few % about its critical-state mean, and a loose one's hardening ends
#: in a rise of about 7 % (tests/element/test_triaxial_physics.py): neither is a peak.
PEAK_MARGIN = 0.10

#: The columns `triaxial_report` reads.
TRIAXIAL_COLUMNS = ("eps_a", "eps_v", "sigma_1", "sigma_3")


def _number(x: float) -> float | None:
    """A finite float, or None where the quantity is undefined (JSON has no NaN)."""
    v = float(x)
    return v if math.isfinite(v) else None


def _frame(table: object) -> pl.DataFrame:
    """`table`, checked to be a polars DataFrame."""
    import polars as pl

    if not isinstance(table, pl.DataFrame):
        raise InvalidParameterError(
            f"invalid table: a polars.DataFrame expected (granpack.element_table), "
            f"got {type(table).__name__}",
            parameter="table",
        )
    return table


def _columns(table: object, names: Sequence[str], *, what: str) -> dict[str, np.ndarray]:
    """The named columns of `table` as float64 arrays, checked: a DataFrame, every column
    present, at least 2 rows, every value finite."""
    table = _frame(table)
    missing = [c for c in names if c not in table.columns]
    if missing:
        raise InvalidParameterError(
            f"invalid table: {what} needs the column(s) {', '.join(map(repr, missing))}; "
            f"the table has {', '.join(map(repr, table.columns)) or 'none'}",
            parameter="table",
            expected=f"the columns {', '.join(names)}",
        )
    if table.height < 2:
        raise InvalidParameterError(
            f"invalid table: {table.height} row(s); {what} needs at least 2",
            parameter="table",
            expected="at least 2 rows",
        )
    import polars as pl

    out = {}
    for c in names:
        try:
            a = table[c].cast(pl.Float64).to_numpy()
        except Exception as exc:  # a text column and the like
            raise InvalidParameterError(
                f"invalid table: column {c!r} is not numeric ({table[c].dtype}): {exc}",
                parameter="table",
            ) from None
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise InvalidParameterError(
                f"invalid table: column {c!r} holds a missing or non-finite value "
                f"at row {int(bad[0])}",
                parameter="table",
            )
        out[c] = np.ascontiguousarray(a, dtype=np.float64)
    return out


def _p_q(s1: np.ndarray, s3: np.ndarray, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """Mean stress p and deviator q (Pa; N/m in 2D) of the axisymmetric (3D) or biaxial
    (2D) state s1, s3: 3D p = (s1 + 2 s3)/3, 2D p = (s1 + s3)/2; q = s1 - s3."""
    p = (s1 + 2.0 * s3) / 3.0 if dim == 3 else (s1 + s3) / 2.0
    return p, s1 - s3


def _sin_mobilised(s1: np.ndarray, s3: np.ndarray) -> np.ndarray:
    """(s1 - s3) / (s1 + s3) per row: the sine of the mobilised friction angle (Mohr's
    circle through s1, s3 tangent to a line through the origin)."""
    # clip: a row with one tensile stress would leave [-1, 1] (no angle; the nearest one)
    return np.clip((s1 - s3) / (s1 + s3), -1.0, 1.0)


def _strain_path(eps_a: np.ndarray) -> None:
    """An axial strain that never decreases and grows along the path (the lid moves
    down at a constant speed), so the path can be read as a function of eps_a."""
    if np.any(np.diff(eps_a) < 0):
        i = int(np.flatnonzero(np.diff(eps_a) < 0)[0]) + 1
        raise InvalidParameterError(
            f"invalid table: eps_a decreases at row {i} ({eps_a[i - 1]} -> {eps_a[i]}); a "
            "triaxial path's axial strain never decreases (rows in path order)",
            parameter="table",
        )
    if eps_a[-1] <= eps_a[0]:
        raise InvalidParameterError(
            f"invalid table: eps_a does not grow along the path (stays at {eps_a[0]}); "
            "there is no shearing to read",
            parameter="table",
        )


def _dilatancy(
    eps_a: np.ndarray, eps_v: np.ndarray, window: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centred increments over `window` of axial strain at the rows that have the whole
    window inside the path: (the rows' eps_a, d eps_a, d eps_v), eps_v interpolated
    linearly between rows at eps_a -/+ window/2."""
    h = 0.5 * window
    inside = (eps_a - h >= eps_a[0]) & (eps_a + h <= eps_a[-1])
    centres = eps_a[inside]
    dv = np.interp(centres + h, eps_a, eps_v) - np.interp(centres - h, eps_a, eps_v)
    da = (centres + h) - (centres - h)
    return centres, da, dv


def triaxial_report(
    table: pl.DataFrame,
    dim: int,
    *,
    cs_share: float = CS_SHARE,
    dilatancy_window: float = DILATANCY_WINDOW,
    peak_margin: float = PEAK_MARGIN,
) -> dict[str, Any]:
    """The quantities of a drained triaxial (3D) or biaxial (2D) compression test.

    Parameters
    ----------
    table
        The test's table (`granpack.element_table`): the columns eps_a, eps_v (-,
        compression-positive), sigma_1 and sigma_3 (Pa; N/m in 2D) are read, at least 2
        rows, eps_a never decreasing and growing along the path.
    dim
        2 or 3: p = (s1 + s3)/2 in 2D, (s1 + 2 s3)/3 in 3D; q = s1 - s3 (from the wall
        stresses sigma_1, sigma_3, as the table's own p and q).
    cs_share
        The share of the axial strain range at the end of the path that gives the
        critical state (-), in (0, 1]; default 0.2 (the last 20 %).
    dilatancy_window
        The axial strain (-) over which the dilatancy's centred increments are taken,
        > 0; default 0.02 (2 %).
    peak_margin
        A marked peak: the peak stress ratio eta = q/p above the critical-state mean
        eta by more than this share (-), >= 0; default 0.10 (10 %).

    Returns
    -------
    dict
        ``phi_peak`` (degrees) the largest mobilised friction angle asin((s1 - s3) /
        (s1 + s3)) over the rows, with ``eps_a_peak`` (-), ``eta_peak`` (q/p, -),
        ``q_peak`` and ``p_peak`` (Pa) at that row; ``phi_cs`` (degrees) asin of the
        mean of (s1 - s3)/(s1 + s3) over the critical-state rows, ``eta_cs`` (-) the
        mean q/p there, ``q_cs`` and ``p_cs`` (Pa) the mean q and p there, ``cs_rows``
        their count; ``psi_max`` (degrees) the largest dilatancy angle, sin psi =
        -d eps_v / (2 d eps_a - d eps_v) over the centred window, at
        ``eps_a_psi_max`` (-), and ``dilatancy_max`` (-) the largest -d eps_v / d eps_a
        (both None where no row has the whole window inside the path); ``E_50`` (Pa) the
        secant modulus to half the peak deviator, measured from the first row, with
        ``eps_a_50`` (-) where it is reached (None where q never rises above its first
        value); ``peak`` (bool) eta_peak > (1 + peak_margin) eta_cs; ``eps_a_end`` and
        ``eps_v_end`` (-) the last row's strains; and the settings used, ``dim``,
        ``cs_share``, ``dilatancy_window``, ``peak_margin``.

    Raises
    ------
    InvalidParameterError
        ``table`` not a DataFrame, lacking a column, with fewer than 2 rows, a
        non-finite value, sigma_1 + sigma_3 <= 0 in a row, or eps_a decreasing or not
        growing; ``dim`` not 2 or 3; a setting out of its range.
    """
    dim = as_int("dim", dim, 2, 3)
    cs_share = as_real("cs_share", cs_share, 0.0, 1.0, lo_open=True)
    dilatancy_window = as_real("dilatancy_window", dilatancy_window, 0.0, lo_open=True)
    peak_margin = as_real("peak_margin", peak_margin, 0.0)
    cols = _columns(table, TRIAXIAL_COLUMNS, what="a triaxial report")
    eps_a, eps_v = cols["eps_a"], cols["eps_v"]
    s1, s3 = cols["sigma_1"], cols["sigma_3"]
    _strain_path(eps_a)
    if np.any(s1 + s3 <= 0.0):
        i = int(np.flatnonzero(s1 + s3 <= 0.0)[0])
        raise InvalidParameterError(
            f"invalid table: sigma_1 + sigma_3 = {s1[i] + s3[i]} <= 0 at row {i}; the "
            "friction angle needs a compressive mean stress",
            parameter="table",
        )
    p, q = _p_q(s1, s3, dim)
    sin_phi = _sin_mobilised(s1, s3)

    # the peak: the row of the largest mobilised friction (the first, on a plateau)
    k = int(np.argmax(sin_phi))
    eta_peak = q[k] / p[k] if p[k] > 0 else math.nan

    # the critical state: the last cs_share of the axial strain range
    start, end = eps_a[0], eps_a[-1]
    cs = eps_a >= start + (1.0 - cs_share) * (end - start)
    with np.errstate(divide="ignore", invalid="ignore"):
        eta = np.where(p > 0, q / np.where(p > 0, p, 1.0), np.nan)
    q_cs = float(np.mean(q[cs]))

    # dilatancy, over the centred window
    centres, da, dv = _dilatancy(eps_a, eps_v, dilatancy_window)
    psi_max = eps_a_psi = dil_max = None
    if centres.size:
        with np.errstate(divide="ignore"):  # dv = 2 da: sin psi = -inf, clipped to -1
            sin_psi = np.clip(-dv / (2.0 * da - dv), -1.0, 1.0)
        j = int(np.argmax(sin_psi))
        psi_max = math.degrees(math.asin(sin_psi[j]))
        eps_a_psi = float(centres[j])
        dil_max = float(np.max(-dv / da))

    # E50: secant from the first row to half the largest deviator rise
    dq = q - q[0]
    half = 0.5 * float(np.max(dq))
    e50 = eps50 = None
    if half > 0:
        i = int(np.argmax(dq >= half))  # the first row at or past half (i >= 1: dq[0] = 0)
        t = (half - dq[i - 1]) / (dq[i] - dq[i - 1])
        strain = float((eps_a[i - 1] + t * (eps_a[i] - eps_a[i - 1])) - eps_a[0])
        if strain > 0:
            e50 = half / strain
            eps50 = strain + float(eps_a[0])

    return {
        "phi_peak": math.degrees(math.asin(sin_phi[k])),
        "eps_a_peak": float(eps_a[k]),
        "eta_peak": _number(eta_peak),
        "q_peak": float(q[k]),
        "p_peak": float(p[k]),
        "phi_cs": math.degrees(math.asin(float(np.mean(sin_phi[cs])))),
        "eta_cs": _number(np.mean(eta[cs])),
        "q_cs": q_cs,
        "p_cs": float(np.mean(p[cs])),
        "cs_rows": int(np.count_nonzero(cs)),
        "psi_max": psi_max,
        "eps_a_psi_max": eps_a_psi,
        "dilatancy_max": dil_max,
        "E_50": e50,
        "eps_a_50": eps50,
        "peak": bool(eta_peak > (1.0 + peak_margin) * float(np.mean(eta[cs]))),
        "eps_a_end": float(eps_a[-1]),
        "eps_v_end": float(eps_v[-1]),
        "dim": dim,
        "cs_share": cs_share,
        "dilatancy_window": dilatancy_window,
        "peak_margin": peak_margin,
    }


def eps_v_at(table: pl.DataFrame, eps_a: float) -> float | None:
    """The volumetric strain (-) at the axial strain `eps_a` (-), interpolated linearly
    between the rows (e.g. eps_v at 10 % axial strain: ``eps_v_at(table, 0.10)``); None
    where `eps_a` lies outside the path's axial strains.

    Raises
    ------
    InvalidParameterError
        ``table`` lacking eps_a or eps_v, with fewer than 2 rows, eps_a decreasing or
        not growing; ``eps_a`` not a finite number.
    """
    at = as_real("eps_a", eps_a)
    cols = _columns(table, ("eps_a", "eps_v"), what="eps_v_at")
    a, v = cols["eps_a"], cols["eps_v"]
    _strain_path(a)
    if not a[0] <= at <= a[-1]:
        return None
    return float(np.interp(at, a, v))


def _slope(x: np.ndarray, y: np.ndarray) -> float | None:
    """The least-squares slope of y against x; None with fewer than 2 distinct x."""
    if x.size < 2:
        return None
    dx = x - x.mean()
    sxx = float(dx @ dx)
    if sxx <= 0:
        return None
    return float(dx @ (y - y.mean())) / sxx


def compression_report(table: pl.DataFrame, test: str | None = None) -> dict[str, Any]:
    """The compression quantities of an oedometer or isotropic compression table.

    Parameters
    ----------
    table
        One row per stress level at equilibrium, in path order, at least 2 rows. Read:
        ``target`` (Pa), ``e`` (-) and the stress: sigma_1 (Pa; the lid's measured
        stress, sigma_v) for the oedometer, p (Pa) for the isotropic test; K0 from the
        ``k0`` column, or sigma_3 / sigma_1 where the table has none (oedometer).
    test
        ``"oedometer"`` or ``"isotropic"``; default None: ``"oedometer"`` where the
        table has a ``k0`` column, else ``"isotropic"``.

    The loading branch is the rows up to and including the first row of the largest
    target; the unloading branch the rows from that row on while the target does not
    rise (a reloading after it is left out). ``Cc`` is minus the least-squares slope of e
    against log10(stress) over the loading branch's virgin part: its rows from the
    second on (the first row is the sample as consolidated, where a stiffer
    recompression begins) whose target is at or above every earlier row's (a reloading
    to a stress held before is a recompression too), where at least 2 such rows exist;
    otherwise its rows from the second on where it has at least 3 rows, both rows where
    it has 2.
    ``Cs`` is minus the least-squares slope over the unloading branch.

    Returns
    -------
    dict
        ``test``; ``stress`` (the column used); ``Cc`` and ``Cs`` (-), ``lambda_ln`` =
        Cc / ln 10 and ``kappa_ln`` = Cs / ln 10 (-, the slopes against ln(stress)),
        None where the branch has fewer than 2 rows (no unloading: ``Cs`` None);
        ``loading_rows`` and ``unloading_rows`` (row indices), ``virgin_rows`` (the rows
        of the Cc fit); ``stress_max`` (Pa) and ``e_at_max`` (-) at the largest target;
        ``k0`` (-) one value per row and ``k0_virgin`` (-) its mean over the virgin
        rows (oedometer; None for the isotropic test).

    Raises
    ------
    InvalidParameterError
        ``table`` not a DataFrame, lacking a column, with fewer than 2 rows, a
        non-finite value or a stress <= 0; ``test`` not one of the two names.
    """
    table = _frame(table)
    if test is None:
        test = "oedometer" if "k0" in table.columns else "isotropic"
    if test not in ("oedometer", "isotropic"):
        raise InvalidParameterError(
            f"invalid test = {test!r}: must be 'oedometer' or 'isotropic'",
            parameter="test",
        )
    stress = "sigma_1" if test == "oedometer" else "p"
    names = ["target", stress, "e"]
    if test == "oedometer":
        names += ["k0"] if "k0" in table.columns else ["sigma_3"]
    cols = _columns(table, names, what=f"a {test} report")
    s = cols[stress]
    if np.any(s <= 0):
        i = int(np.flatnonzero(s <= 0)[0])
        raise InvalidParameterError(
            f"invalid table: {stress} = {s[i]} <= 0 at row {i}; log10 of the stress "
            "needs a compressive stress",
            parameter="table",
        )
    target, e = cols["target"], cols["e"]
    top = int(np.argmax(target))
    loading = np.arange(top + 1)
    rise = np.flatnonzero(np.diff(target[top:]) > 0)
    unloading = np.arange(top, top + 1 + (int(rise[0]) if rise.size else target.size - 1 - top))
    # the virgin rows: beyond the first, those at or above every stress the sample held
    # before (a reloading up to an earlier stress recompresses, stiffer, and is left out)
    beyond = np.array([k for k in loading[1:] if target[k] >= np.max(target[:k])], dtype=np.int64)
    if beyond.size >= 2:
        virgin = beyond
    else:
        virgin = loading[1:] if loading.size >= 3 else loading
    logs = np.log10(s)
    cc = _slope(logs[virgin], e[virgin]) if virgin.size >= 2 else None
    cs = _slope(logs[unloading], e[unloading]) if unloading.size >= 2 else None
    cc = None if cc is None else -cc
    cs = None if cs is None else -cs
    k0 = k0_virgin = None
    if test == "oedometer":
        k0a = cols["k0"] if "k0" in cols else cols["sigma_3"] / s
        k0 = [float(x) for x in k0a]
        k0_virgin = float(np.mean(k0a[virgin]))
    ln10 = math.log(10.0)
    return {
        "test": test,
        "stress": stress,
        "Cc": cc,
        "Cs": cs,
        "lambda_ln": None if cc is None else cc / ln10,
        "kappa_ln": None if cs is None else cs / ln10,
        "loading_rows": [int(i) for i in loading],
        "unloading_rows": [int(i) for i in unloading] if unloading.size >= 2 else [],
        "virgin_rows": [int(i) for i in virgin],
        "stress_max": float(s[top]),
        "e_at_max": float(e[top]),
        "k0": k0,
        "k0_virgin": k0_virgin,
    }
