"""Scalar relations of the packing fraction: void ratio and the empirical Z(e) of the paper's
eqs. 16-19."""

from __future__ import annotations

import numpy as np

__all__ = ["void_ratio", "phi_from_void_ratio", "empirical_z"]


def void_ratio(phi):
    """Void ratio e = (1 - phi)/phi (-), float or array like `phi` (phi > 0)."""
    phi = np.asarray(phi, dtype=float)
    out = (1.0 - phi) / phi
    return float(out) if out.ndim == 0 else out


def phi_from_void_ratio(e):
    """Packing fraction phi = 1/(1 + e) (-), the inverse of :func:`void_ratio`."""
    e = np.asarray(e, dtype=float)
    out = 1.0 / (1.0 + e)
    return float(out) if out.ndim == 0 else out


def empirical_z(e) -> dict:
    """The paper's empirical coordination numbers Z(e), eqs. 16-19.

    Parameters
    ----------
    e : float or array
        Void ratio (-), > 0.

    Returns
    -------
    dict
        ``"field"``: 12/(1 + e) (Field 1963); ``"athanasiou"``: 3(1 + e)/e
        (Athanasiou-Grivas & Harr 1982; eq. 17 is garbled in print, this form reproduces the
        paper's tables); ``"yanagisawa"``: 3.183^(2.469 - e) (Yanagisawa 1983);
        ``"chang"``: 13.28 - 8 e (Chang, Misra & Sundaram 1990). Floats for a float `e`.

    Examples
    --------
    >>> {k: round(v, 3) for k, v in empirical_z(0.171).items()}
    {'field': 10.248, 'athanasiou': 20.544, 'yanagisawa': 14.306, 'chang': 11.912}
    """
    e_arr = np.asarray(e, dtype=float)
    # e = 0 (no voids) is the formula's pole: +inf, not an error.
    with np.errstate(divide="ignore"):
        out = {
            "field": 12.0 / (1.0 + e_arr),
            "athanasiou": 3.0 * (1.0 + e_arr) / e_arr,
            "yanagisawa": 3.183 ** (2.469 - e_arr),
            "chang": 13.28 - 8.0 * e_arr,
        }
    if e_arr.ndim == 0:
        return {k: float(v) for k, v in out.items()}
    return out
