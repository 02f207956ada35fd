"""Pictures of packs and of their microstructure (matplotlib, PNG).

Figures are built on `matplotlib.figure.Figure` with the Agg canvas, never through
pyplot: nothing opens a window, nothing touches global state, and the functions are safe
in worker processes and tests. `save` writes a PNG atomically.

* `pack_figure`: 2D packs as discs coloured by layer (the paper's figs. 2-5); 3D packs
  as an orthographic rendered view (spheres drawn back to front, coloured by layer,
  shaded by depth) beside a vertical mid-plane slice (figs. 6-9). A cylinder pack is
  drawn in its cylinder (the view's outline, a slice through the axis) with a
  horizontal slice at mid-height; a periodic pack with the images of the particles
  that cross the seam (paler, the periodic sides dashed), and in 3D a horizontal slice.
* `packs_figure`: several packs of an ensemble in a grid.
* `normals_figure`: contact-normal rose diagram (2D) with the fabric's second-order
  approximation E(theta) = (1 + a^r_ij n_i n_j) / (2 pi); orientation density (3D) on an
  equal-area (Lambert) projection of the upper hemisphere, 1 = isotropic.
* `force_chain_figure`: contacts as lines whose width grows with the normal force (2D;
  in 3D the contacts of a vertical slab at mid-depth).
* `phi_histogram_figure`: histograms of phi over ensembles, with reference values
  (e.g. the paper's) as markers.
* `grading_figure`: the grading curve, percentage passing by mass against the diameter
  on a log axis, realised and target.
"""

from __future__ import annotations

import io
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib
import matplotlib.ticker
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import EllipseCollection, LineCollection
from matplotlib.figure import Figure

from ._files import atomic_write
from ._validate import InvalidParameterError
from .analysis.container import Container

__all__ = [
    "analysis_figure",
    "save",
    "periodic_images",
    "pack_figure",
    "packs_figure",
    "normals_figure",
    "force_chain_figure",
    "phi_histogram_figure",
]

#: Layer colours: a qualitative map, cycled, so that neighbouring layers differ.
LAYER_CMAP = "tab10"


def _figure(width: float, height: float) -> Figure:
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save(fig: Figure, path: str | Path, dpi: int = 150) -> Path:
    """Writes `fig` as a PNG (atomically) and returns the path."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return atomic_write(path, buf.getvalue())


def _layer_colors(layer: np.ndarray | None, n: int) -> np.ndarray:
    cmap = matplotlib.colormaps[LAYER_CMAP]
    if layer is None:
        return np.tile(np.array(cmap(0)), (n, 1))
    return cmap(np.asarray(layer) % cmap.N)


def _parts(pack):
    """(dim, positions, radii, layer or None, base, height) of a Pack or of an object
    with the same attributes (layer may be missing)."""
    x = np.asarray(pack.positions, dtype=np.float64)
    r = np.asarray(pack.radii, dtype=np.float64)
    dim = x.shape[1]
    layer = getattr(pack, "layer", None)
    scene = getattr(pack, "scene", None)
    if scene is not None:
        base = tuple(scene.base)
    else:
        base = tuple(float(np.max(x[:, k] + r)) for k in range(dim - 1))
    height = getattr(pack, "height", None)
    if height is None:
        height = float(np.max(x[:, -1] + r)) if len(r) else 0.0
    return dim, x, r, layer, base, float(height)


def _container(pack) -> Container | None:
    """The container of a generated pack (`Container.of_pack`); None for what has no
    scene, drawn as a box."""
    return Container.of_pack(pack) if getattr(pack, "scene", None) is not None else None


def _walls(ax, width: float, height: float, periodic: bool = False) -> None:
    if not periodic:
        ax.plot([0, 0, width, width], [height, 0, 0, height], color="0.2", lw=1.0)
        return
    ax.plot([0, width], [0, 0], color="0.2", lw=1.0)
    for xs in (0, width):  # the seam: periodic sides, not walls
        ax.plot([xs, xs], [0, height], color="0.35", lw=0.8, ls="--")


#: Opacity of the periodic images drawn across the seam.
IMAGE_ALPHA = 0.4


def periodic_images(x: np.ndarray, r: np.ndarray, periods: Sequence[tuple[int, float]]):
    """The images of the particles that cross a periodic side: (centres, radii, index
    of the particle each is an image of). `periods` are (axis, period) pairs; a particle
    within its radius of a side gets the copy shifted by the period across it (and, with
    two periodic axes, the corner copies)."""
    idx = np.arange(len(r))
    cx, cr, ci = x.copy(), r.copy(), idx.copy()
    for axis, length in periods:
        lo = cx[:, axis] < cr
        hi = cx[:, axis] > length - cr
        shift = np.zeros(x.shape[1])
        shift[axis] = length
        cx = np.vstack([cx, cx[lo] + shift, cx[hi] - shift])
        cr = np.concatenate([cr, cr[lo], cr[hi]])
        ci = np.concatenate([ci, ci[lo], ci[hi]])
    n = len(r)
    return cx[n:], cr[n:], ci[n:]


def _draw_images(ax, x, r, layer, periods, cols) -> None:
    xi, ri, ii = periodic_images(x, r, periods)
    if len(ri):
        colors = _layer_colors(None if layer is None else np.asarray(layer)[ii], len(ri))
        colors[:, 3] = IMAGE_ALPHA
        _discs(ax, xi[:, cols], ri, colors, edgecolors="0.5", linewidths=0.2)


def _discs(ax, centres: np.ndarray, radii: np.ndarray, colors, **kw) -> None:
    ax.add_collection(
        EllipseCollection(
            2 * radii,
            2 * radii,
            np.zeros(len(radii)),
            units="xy",
            offsets=centres,
            offset_transform=ax.transData,
            facecolors=colors,
            **kw,
        )
    )


def _draw_2d(ax, x, r, layer, base, height, kind: str = "box") -> None:
    _discs(ax, x, r, _layer_colors(layer, len(r)), edgecolors="0.15", linewidths=0.2)
    if kind == "periodic":
        _draw_images(ax, x, r, layer, [(0, base[0])], [0, 1])
    _walls(ax, base[0], height, periodic=kind == "periodic")
    ax.set_xlim(-0.02 * base[0], 1.02 * base[0])
    ax.set_ylim(-0.02 * height, 1.04 * height)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def _view_basis(azimuth_deg: float, elevation_deg: float):
    """Orthonormal screen axes (right, up) and the viewing direction (towards the
    viewer) for a camera at the given azimuth/elevation, z up."""
    az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
    toward = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    right = np.array([-math.sin(az), math.cos(az), 0.0])
    up = np.cross(toward, right)
    return right, up, toward


def _draw_3d_view(
    ax, x, r, layer, base, height, azimuth=-60.0, elevation=22.0, radius=None
) -> None:
    right, up, toward = _view_basis(azimuth, elevation)
    u, v, depth = x @ right, x @ up, x @ toward
    order = np.argsort(depth)  # far spheres first: the painter's algorithm hides them
    colors = _layer_colors(layer, len(r))[order].copy()
    # Depth cue: farther spheres darker (orthographic views otherwise look flat).
    span = np.ptp(depth) if len(depth) else 1.0
    shade = 0.55 + 0.45 * (depth[order] - depth.min()) / (span or 1.0)
    colors[:, :3] *= shade[:, None]
    _discs(ax, np.column_stack([u, v])[order], r[order], colors, edgecolors="0.1", linewidths=0.15)
    if radius is not None:
        # The cylinder: floor and top circles and the two vertical silhouette lines.
        t = np.linspace(0.0, 2 * np.pi, 97)
        segments = []
        for z in (0.0, height):
            ring = np.column_stack(
                [radius + radius * np.cos(t), radius + radius * np.sin(t), np.full_like(t, z)]
            )
            segments.append(np.column_stack([ring @ right, ring @ up]))
        for sign in (-1.0, 1.0):
            foot = np.array([radius, radius, 0.0]) + sign * radius * right
            top = foot + np.array([0.0, 0.0, height])
            segments.append(np.array([[foot @ right, foot @ up], [top @ right, top @ up]]))
        ax.add_collection(LineCollection(segments, colors="0.4", linewidths=0.6, zorder=0))
    else:
        # Box edges, for orientation.
        b1, b2 = base
        corners = np.array(
            [[i * b1, j * b2, k * height] for i in (0, 1) for j in (0, 1) for k in (0, 1)]
        )
        edges = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]
        cu, cv = corners @ right, corners @ up
        ax.add_collection(
            LineCollection(
                [[(cu[a], cv[a]), (cu[b], cv[b])] for a, b in edges],
                colors="0.4",
                linewidths=0.6,
                zorder=0,
            )
        )
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_axis_off()
    ax.set_title(f"view (azimuth {azimuth:g}°, elevation {elevation:g}°)", fontsize=9)


def _draw_3d_slice(ax, x, r, layer, base, height, kind: str = "box") -> None:
    y0 = 0.5 * base[1]
    d = np.abs(x[:, 1] - y0)
    cut = d < r
    rc = np.sqrt(r[cut] ** 2 - d[cut] ** 2)
    lay = None if layer is None else np.asarray(layer)[cut]
    colors = _layer_colors(lay, int(cut.sum()))
    _discs(ax, x[cut][:, [0, 2]], rc, colors, edgecolors="0.15", linewidths=0.2)
    if kind == "periodic":
        _draw_images(ax, x[cut][:, [0, 2]], rc, lay, [(0, base[0])], [0, 1])
    # a slice through a cylinder's axis meets its wall at x = 0 and x = 2R
    _walls(ax, base[0], height, periodic=kind == "periodic")
    ax.set_xlim(-0.02 * base[0], 1.02 * base[0])
    ax.set_ylim(-0.02 * height, 1.04 * height)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    ax.set_title(f"slice y = {y0:g} m", fontsize=9)


def _draw_horizontal_slice(ax, x, r, layer, base, height, kind: str, radius) -> None:
    """The circles a horizontal plane at mid-height cuts, in the container's outline."""
    z0 = 0.5 * height
    d = np.abs(x[:, 2] - z0)
    cut = d < r
    rc = np.sqrt(r[cut] ** 2 - d[cut] ** 2)
    lay = None if layer is None else np.asarray(layer)[cut]
    _discs(
        ax, x[cut][:, :2], rc, _layer_colors(lay, int(cut.sum())), edgecolors="0.15", linewidths=0.2
    )
    b1, b2 = base
    if kind == "cylinder":
        t = np.linspace(0.0, 2 * np.pi, 181)
        ax.plot(radius + radius * np.cos(t), radius + radius * np.sin(t), color="0.2", lw=1.0)
    elif kind == "periodic":
        _draw_images(ax, x[cut][:, :2], rc, lay, [(0, b1), (1, b2)], [0, 1])
        ax.plot([0, b1, b1, 0, 0], [0, 0, b2, b2, 0], color="0.35", lw=0.8, ls="--")
    else:
        ax.plot([0, b1, b1, 0, 0], [0, 0, b2, b2, 0], color="0.2", lw=1.0)
    ax.set_xlim(-0.04 * b1, 1.04 * b1)
    ax.set_ylim(-0.04 * b2, 1.04 * b2)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"slice z = {z0:.3g} m", fontsize=9)


def pack_figure(pack, title: str | None = None) -> Figure:
    """The pack: discs coloured by layer (2D), or a rendered view and a vertical
    mid-plane slice (3D). `pack` is a `Pack` or any object with ``positions``,
    ``radii`` and optionally ``layer``, ``scene`` and ``height``."""
    dim, x, r, layer, base, height = _parts(pack)
    container = _container(pack)
    kind = "box" if container is None else container.kind
    radius = None if container is None else container.radius
    if dim == 2:
        aspect = height / base[0] if base[0] > 0 else 1.0
        fig = _figure(8.0, max(2.5, 8.0 * aspect + 0.8))
        ax = fig.add_subplot()
        _draw_2d(ax, x, r, layer, base, height, kind)
    elif kind == "box":
        fig = _figure(12.0, 5.0)
        ax1, ax2 = fig.subplots(1, 2, width_ratios=[1.1, 1.0])
        _draw_3d_view(ax1, x, r, layer, base, height)
        _draw_3d_slice(ax2, x, r, layer, base, height)
    else:
        fig = _figure(16.0, 5.0)
        ax1, ax2, ax3 = fig.subplots(1, 3, width_ratios=[1.1, 1.0, 0.8])
        _draw_3d_view(ax1, x, r, layer, base, height, radius=radius)
        _draw_3d_slice(ax2, x, r, layer, base, height, kind)
        _draw_horizontal_slice(ax3, x, r, layer, base, height, kind, radius)
    if title:
        fig.suptitle(title)
    return fig


def packs_figure(packs: Sequence, title: str | None = None, labels: Sequence[str] = ()) -> Figure:
    """Several packs side by side (2 columns; 3D packs as their mid-plane slices, which
    show the structure best at this size)."""
    packs = list(packs)
    if not packs:
        raise InvalidParameterError("invalid packs: nothing to draw", parameter="packs")
    ncol = 2 if len(packs) > 1 else 1
    nrow = math.ceil(len(packs) / ncol)
    dim, _, _, _, base, height = _parts(packs[0])
    aspect = height / base[0] if base[0] > 0 else 1.0
    fig = _figure(5.0 * ncol, max(2.0, 5.0 * aspect + 0.6) * nrow + 0.5)
    axes = np.atleast_1d(fig.subplots(nrow, ncol, squeeze=False)).ravel()
    for k, ax in enumerate(axes):
        if k >= len(packs):
            ax.set_axis_off()
            continue
        d, x, r, layer, b, h = _parts(packs[k])
        (_draw_2d if d == 2 else _draw_3d_slice)(ax, x, r, layer, b, h)
        ax.set_title(labels[k] if k < len(labels) else f"pack {k + 1}", fontsize=9)
        ax.set_xlabel("")
        ax.set_ylabel("")
    if title:
        fig.suptitle(title)
    return fig


# -- contact normals ---------------------------------------------------------------------------


def _rose(ax, normals: np.ndarray, bins: int) -> None:
    theta = np.arctan2(normals[:, 1], normals[:, 0])
    # Every contact counts once with n and once with -n: the distribution is centrally
    # symmetric by construction (the paper's 1/(2 N_c) sum over both particles).
    theta = np.concatenate([theta, theta + np.pi]) % (2 * np.pi)
    edges = np.linspace(0, 2 * np.pi, bins + 1)
    counts, _ = np.histogram(theta, edges)
    width = edges[1] - edges[0]
    density = counts / (len(theta) * width) if len(theta) else counts * 0.0
    ax.bar(
        edges[:-1],
        density,
        width=width,
        align="edge",
        color="tab:blue",
        alpha=0.6,
        edgecolor="white",
        linewidth=0.5,
        label="contacts",
    )
    if len(normals):
        fabric = normals.T @ normals / len(normals)
        a = 4.0 * (fabric - np.eye(2) / 2)  # a^r = 4 R' in 2D
        t = np.linspace(0, 2 * np.pi, 361)
        n = np.column_stack([np.cos(t), np.sin(t)])
        e = (1.0 + np.einsum("ki,ij,kj->k", n, a, n)) / (2 * np.pi)
        ax.plot(t, e, color="tab:red", lw=1.5, label="1 + a^r:nn (fabric)")
        ax.plot(
            t, np.full_like(t, 1 / (2 * np.pi)), color="0.4", lw=0.8, ls="--", label="isotropic"
        )
    ax.set_title(f"contact normals (N_c = {len(normals)})", fontsize=9)
    ax.legend(loc="lower left", bbox_to_anchor=(0.85, -0.1), fontsize=7, frameon=False)


def _orientation_density(ax, fig, normals: np.ndarray, bins: int) -> None:
    n = normals.copy()
    n[n[:, 2] < 0] *= -1  # n and -n are the same orientation: fold onto z >= 0
    # Lambert azimuthal equal-area projection about +z: the hemisphere maps onto the disc
    # of radius sqrt(2) with area preserved, so counts per unit area are a density.
    s = np.sqrt(2.0 / (1.0 + n[:, 2]))
    px, py = s * n[:, 0], s * n[:, 1]
    rmax = math.sqrt(2.0)
    edges = np.linspace(-rmax, rmax, bins + 1)
    counts, _, _ = np.histogram2d(px, py, [edges, edges])
    cell = (edges[1] - edges[0]) ** 2
    iso = len(n) * cell / (2 * np.pi) if len(n) else 1.0
    density = counts / iso
    c = 0.5 * (edges[1:] + edges[:-1])
    cx, cy = np.meshgrid(c, c, indexing="ij")
    # Cells cut by the rim hold less area of the disc; drop them rather than bias them.
    density[
        np.hypot(np.abs(cx) + 0.5 * (edges[1] - edges[0]), np.abs(cy) + 0.5 * (edges[1] - edges[0]))
        > rmax
    ] = np.nan
    im = ax.imshow(
        density.T,
        origin="lower",
        extent=(-rmax, rmax, -rmax, rmax),
        cmap="viridis",
        vmin=0.0,
        vmax=max(2.0, float(np.nanmax(density)) if np.isfinite(density).any() else 2.0),
    )
    t = np.linspace(0, 2 * np.pi, 200)
    ax.plot(rmax * np.cos(t), rmax * np.sin(t), color="k", lw=0.8)
    for polar in (30, 60):  # circles of equal polar angle from the vertical
        rr = 2 * math.sin(math.radians(polar) / 2)
        ax.plot(rr * np.cos(t), rr * np.sin(t), color="w", lw=0.4, ls=":")
    ax.text(rmax * 1.03, 0, "+x", va="center", fontsize=8)
    ax.text(0, rmax * 1.03, "+y", ha="center", va="bottom", fontsize=8)
    ax.set_aspect("equal")
    ax.set_axis_off()
    ax.set_title(
        f"contact-normal density, upper hemisphere, z (vertical) at centre\n"
        f"equal-area projection; 1 = isotropic (N_c = {len(n)})",
        fontsize=9,
        pad=16,
    )
    fig.colorbar(im, ax=ax, shrink=0.8, label="orientation density / isotropic")


def normals_figure(
    normals: np.ndarray, title: str | None = None, bins: int | None = None
) -> Figure:
    """Contact-normal distribution of (M, D) unit normals: a rose diagram in 2D (36
    bins by default), an equal-area orientation-density map in 3D (6 to 30 cells across, by
    the number of normals)."""
    normals = np.asarray(normals, dtype=np.float64)
    if normals.ndim != 2 or normals.shape[1] not in (2, 3):
        raise InvalidParameterError(
            f"invalid normals: shape {normals.shape}, expected (M, 2) or (M, 3)",
            parameter="normals",
        )
    if normals.shape[1] == 2:
        fig = _figure(5.5, 5.0)
        ax = fig.add_subplot(projection="polar")
        _rose(ax, normals, bins or 36)
    else:
        fig = _figure(6.0, 5.2)
        ax = fig.add_subplot()
        # About 5 normals per cell on average, between 6 and 30 cells across.
        auto = int(np.clip(np.sqrt(len(normals) / 5.0), 6, 30))
        _orientation_density(ax, fig, normals, bins or auto)
    if title:
        fig.suptitle(title)
    return fig


# -- forces -------------------------------------------------------------------------------------


def force_chain_figure(pack, title: str | None = None, max_width: float = 3.0) -> Figure:
    """Force chains: each contact a line from centre to centre (to the contact point for
    walls), width proportional to its normal force (`max_width` points at the largest).
    2D: all contacts; 3D: contacts of particles within one mean diameter of the
    mid-plane y = B2/2, projected on x-z."""
    dim, x, r, layer, base, height = _parts(pack)
    c = pack.contacts
    i = np.asarray(c.i, dtype=np.int64)
    branch = np.asarray(c.branch, dtype=np.float64).reshape(len(c), dim)
    fn = np.asarray(c.force_normal, dtype=np.float64)
    start = x[i]
    end = start + branch
    axes2 = [0, 1]
    keep = np.ones(len(c), dtype=bool)
    if dim == 3:
        y0 = 0.5 * base[1]
        half = 2.0 * float(np.mean(r)) if len(r) else 0.0
        keep = (np.abs(start[:, 1] - y0) < half) & (np.abs(end[:, 1] - y0) < half)
        axes2 = [0, 2]
    aspect = height / base[0] if base[0] > 0 else 1.0
    fig = _figure(8.0, max(2.5, 8.0 * aspect + 0.8))
    ax = fig.add_subplot()
    if dim == 2:
        _discs(ax, x, r, "none", edgecolors="0.75", linewidths=0.3)
    else:
        d = np.abs(x[:, 1] - 0.5 * base[1])
        cut = d < r
        _discs(
            ax,
            x[cut][:, [0, 2]],
            np.sqrt(r[cut] ** 2 - d[cut] ** 2),
            "none",
            edgecolors="0.75",
            linewidths=0.3,
        )
    fmax = float(fn[keep].max()) if keep.any() else 0.0
    if fmax > 0:
        segs = np.stack([start[keep][:, axes2], end[keep][:, axes2]], axis=1)
        widths = max_width * fn[keep] / fmax
        order = np.argsort(widths)  # strongest on top
        ax.add_collection(
            LineCollection(
                list(segs[order]), linewidths=widths[order], colors="k", capstyle="round"
            )
        )
    _walls(ax, base[0], height)
    ax.set_xlim(-0.02 * base[0], 1.02 * base[0])
    ax.set_ylim(-0.02 * height, 1.04 * height)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)" if dim == 2 else "z (m)")
    where = "" if dim == 2 else f", slab |y - {0.5 * base[1]:g}| < {2 * np.mean(r):.3g} m"
    ax.set_title(f"normal contact forces (line width ∝ f_n, max {fmax:.3g} N{where})", fontsize=9)
    if title:
        fig.suptitle(title)
    return fig


# -- ensembles ------------------------------------------------------------------------------------


def phi_histogram_figure(
    phis: Mapping[str, Sequence[float]],
    reference: Mapping[str, Sequence[float]] | None = None,
    title: str | None = None,
    xlabel: str = "packing fraction phi",
) -> Figure:
    """Histograms of phi over ensembles (one per label, e.g. rotations ON / OFF), with
    each ensemble's mean as a solid line and the `reference` values (e.g. the paper's
    packs) as ticks and a dashed mean, in the same colour."""
    fig = _figure(6.5, 4.0)
    ax = fig.add_subplot()
    data = {k: np.asarray(v, dtype=np.float64) for k, v in phis.items()}
    ref = {k: np.asarray(v, dtype=np.float64) for k, v in (reference or {}).items()}
    allv = np.concatenate([*data.values(), *ref.values()]) if data or ref else np.zeros(0)
    allv = allv[np.isfinite(allv)]
    if allv.size:
        lo, hi = float(allv.min()), float(allv.max())
        pad = max(0.002, 0.05 * (hi - lo))
        edges = np.linspace(lo - pad, hi + pad, 21)
    else:
        edges = np.linspace(0, 1, 21)
    colors = matplotlib.colormaps["tab10"]
    for k, (label, v) in enumerate(data.items()):
        col = colors(k)
        v = v[np.isfinite(v)]
        sd = f" ± {v.std(ddof=1):.4f}" if v.size > 1 else ""
        ax.hist(
            v,
            bins=edges.tolist(),
            color=col,
            alpha=0.45,
            label=f"{label}: {v.mean():.4f}{sd} (n = {v.size})" if v.size else label,
        )
        if v.size:
            ax.axvline(v.mean(), color=col, lw=1.5)
        if label in ref and ref[label].size:
            rv = ref[label][np.isfinite(ref[label])]
            ax.plot(rv, np.full(rv.shape, -0.15), "|", color=col, ms=12, mew=1.5)
            ax.axvline(
                rv.mean(),
                color=col,
                lw=1.2,
                ls="--",
                label=f"{label}, paper: {rv.mean():.4f} (n = {rv.size})",
            )
    ax.set_xlabel(xlabel)
    ax.set_ylabel("packs")
    ax.yaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    if ref:
        ax.set_ylim(bottom=-0.4)
    ax.legend(fontsize=7)
    if title:
        ax.set_title(title)
    return fig


# -- the analysis beyond the paper ----------------------------------------------------------


def _nanmean_rows(rows: Sequence) -> np.ndarray:
    """Mean over rows ignoring NaN; NaN where every row is NaN (no warning)."""
    a = np.asarray(rows, dtype=float)
    ok = np.isfinite(a)
    cnt = ok.sum(axis=0)
    tot = np.where(ok, a, 0.0).sum(axis=0)
    return np.where(cnt > 0, tot / np.maximum(cnt, 1), np.nan)


def _padded_mean(arrays: Sequence[np.ndarray]) -> np.ndarray:
    k = max(a.shape[0] for a in arrays)
    return np.mean([np.pad(a, (0, k - a.shape[0])) for a in arrays], axis=0)


def analysis_figure(packs: Sequence, micro: Sequence, title: str | None = None) -> Figure:
    """Six panels over an ensemble of packs and their microstructures: the coordination
    distribution P(Z); the normal-force distribution P(f_n/<f_n>) on a log scale; the pair
    correlation g(r) of the first pack; the depth profiles of phi and Z (mean over the packs,
    10 slices); the vertical stress profile with K0; the local bond order q6 (psi6 in 2D)
    with the crystalline threshold and the crystallised fraction. For packs in a cylinder, a
    seventh panel: the radial profiles of phi and of the centres' density (20 shells), which
    show the wall's layering."""
    from .analysis import CRYSTAL_THRESHOLD, profiles, radial_profiles, rdf
    from .errors import GranpackError

    cylinder = micro[0].container == "cylinder"
    fig = _figure(17.0 if cylinder else 13.0, 7.5)
    axs = fig.subplots(2, 4 if cylinder else 3)
    if cylinder:
        ax = axs[0, 3]
        rps = [radial_profiles(p_, shells=20) for p_ in packs]
        rc = 0.5 * (rps[0]["r_lo"].to_numpy() + rps[0]["r_hi"].to_numpy())
        area = rps[0]["r_hi"].to_numpy() ** 2 - rps[0]["r_lo"].to_numpy() ** 2
        ax.plot(rc, _nanmean_rows([rp["phi"].to_numpy() for rp in rps]), "o-", label="phi")
        dens = np.mean([rp["n_particles"].to_numpy() / area for rp in rps], axis=0)
        ax2 = ax.twinx()
        ax2.plot(rc, dens / np.mean(dens), "s--", color="C3", label="centres")
        ax2.set_ylabel("centre density / mean", color="C3")
        ax.set_xlabel("distance from the axis (m)")
        ax.set_ylabel("phi (shell)")
        ax.set_title("radial profiles: phi (o), centres (s)", fontsize=9)
        axs[1, 3].set_axis_off()
    d = micro[0].dim
    # P(Z)
    ax = axs[0, 0]
    p = _padded_mean([m.coordination_distribution for m in micro])
    k = np.arange(p.shape[0])
    zbar = float(np.mean([m.z for m in micro]))
    zsd = float(np.mean([m.z_std for m in micro]))
    ax.bar(k, p, color="C0", alpha=0.8)
    ax.axvline(zbar, color="k", lw=1)
    ax.set_xlabel("contacts per particle k")
    ax.set_ylabel("P(k)")
    ax.set_title(f"P(Z): Z = {zbar:.2f}, width {zsd:.2f}", fontsize=9)
    # P(f)
    ax = axs[0, 1]
    have_forces = all(m.has_forces for m in micro)
    if have_forces:
        ratio = np.concatenate(
            [
                p_.contacts.particle_pairs().force_normal / m.force_normal_mean
                for p_, m in zip(packs, micro, strict=True)
            ]
        )
        edges = np.arange(0.0, max(1.0, float(ratio.max())) + 0.2, 0.2)
        hist, _ = np.histogram(ratio, bins=edges, density=True)
        mid = 0.5 * (edges[1:] + edges[:-1])
        ax.semilogy(mid[hist > 0], hist[hist > 0], "o-", ms=3)
        ax.axvline(1.0, color="k", lw=0.8, ls="--")
        sf = float(np.mean([m.strong_fraction for m in micro]))
        ax.set_title(f"P(f_n/<f_n>): strong fraction {sf:.3f}", fontsize=9)
    else:
        ax.text(0.5, 0.5, "no forces", ha="center", va="center", transform=ax.transAxes)
    ax.set_xlabel("f_n / <f_n>")
    ax.set_ylabel("probability density")
    # g(r)
    ax = axs[0, 2]
    try:
        # the core window of the analysis, or a fifth of the height in a low pack
        margin = min(0.1, 0.2 * float(micro[0].h_top - micro[0].box[0][-1]))
        r, g = rdf(packs[0], bins=120, margin=margin)
        dmean = 2.0 * float(np.mean(packs[0].radii))
        ax.plot(r / dmean, g, lw=1)
        ax.axhline(1.0, color="k", lw=0.6, ls=":")
        ax.set_xlabel("r / mean diameter")
        ax.set_title("g(r), pack 1 (core window)", fontsize=9)
    except GranpackError as exc:
        ax.text(0.5, 0.5, str(exc)[:80], ha="center", va="center", fontsize=6, wrap=True)
    ax.set_ylabel("g(r)")
    # depth profiles
    dfs = [profiles(p_, slices=10) for p_ in packs]
    zc = 0.5 * (dfs[0]["z_lo"].to_numpy() + dfs[0]["z_hi"].to_numpy())
    ax = axs[1, 0]
    phi = _nanmean_rows([df["phi"].to_numpy() for df in dfs])
    ax.plot(phi, zc, "o-", color="C0", label="phi")
    ax.set_xlabel("phi (slice)")
    ax.set_ylabel("height (m)")
    ax2 = ax.twiny()
    zz = _nanmean_rows([df["Z"].to_numpy() for df in dfs])
    ax2.plot(zz, zc, "s--", color="C3", label="Z")
    ax2.set_xlabel("Z (slice)", color="C3")
    ax.set_title("depth profiles: phi (o), Z (s)", fontsize=9)
    # stress profile
    ax = axs[1, 1]
    if have_forces:
        szz = _nanmean_rows([df["stress_zz"].to_numpy() for df in dfs])
        ax.plot(szz, zc, "o-")
        k0 = float(_nanmean_rows([[m.k0] for m in micro])[0])
        ax.set_title(f"vertical stress profile; K0 = {k0:.3f}", fontsize=9)
    ax.set_xlabel("sigma_zz (Pa)" if d == 3 else "sigma_yy (N/m)")
    ax.set_ylabel("height (m)")
    # bond order
    ax = axs[1, 2]
    q = np.concatenate([m.q6[np.isfinite(m.q6)] for m in micro])
    ax.hist(q, bins=np.linspace(0, 1, 41).tolist(), color="C2", alpha=0.8)
    ax.axvline(CRYSTAL_THRESHOLD[d], color="k", lw=1, ls="--")
    cf = float(np.mean([m.crystal_fraction for m in micro]))
    ax.set_xlabel("local q6 (contact neighbours)" if d == 3 else "local psi6")
    ax.set_ylabel("particles")
    ax.set_title(
        f"bond order: crystallised {cf:.3f} (q >= {CRYSTAL_THRESHOLD[d]} and solid-like contacts)",
        fontsize=8,
    )
    if title:
        fig.suptitle(title)
    return fig


# -- grading ----------------------------------------------------------------------------------


def grading_figure(
    pack_or_radii, scene=None, dim: int | None = None, title: str | None = None
) -> Figure:
    """Grading curve: percentage passing by mass against the diameter (log axis), the
    realised one of a pack (or of radii, with `dim`) as steps and, where a scene is
    known (the pack's, or `scene`), its law's target as a line, with the sieve sizes of
    a sieve law marked. D10, D50 and D90 of both are in the legend."""
    from .grading import passing, realised_grading, target_grading, target_passing

    scene = scene if scene is not None else getattr(pack_or_radii, "scene", None)
    if dim is None and scene is not None:
        dim = scene.dim
    inertia = scene.inertia_2d if scene is not None else None
    g = realised_grading(pack_or_radii, dim, inertia_2d=inertia)
    radii = np.asarray(getattr(pack_or_radii, "radii", pack_or_radii), dtype=np.float64)
    d = np.sort(2.0 * radii)
    lo, hi = float(d[0]), float(d[-1])
    if scene is not None:
        lo, hi = min(lo, 2.0 * scene.r_min), max(hi, 2.0 * scene.r_max)
    pad = (hi / lo) ** 0.05 if hi > lo else 1.1
    x = np.exp(np.linspace(math.log(lo / pad), math.log(hi * pad), 400))
    fig = _figure(6.5, 4.2)
    ax = fig.add_subplot()
    realised = 100.0 * passing(pack_or_radii, x, dim, inertia_2d=inertia)
    label = (
        f"realised (N = {radii.size}): D10 {g.d10_mass:.3g}, D50 {g.d50_mass:.3g}, "
        f"D90 {g.d90_mass:.3g} m, Cu {g.cu_mass:.3g}"
    )
    ax.step(x, realised, where="post", color="C0", lw=1.5, label=label)
    if scene is not None:
        t = target_grading(scene)
        ax.plot(
            x,
            100.0 * target_passing(scene, x),
            color="k",
            lw=1.2,
            ls="--",
            label=(
                f"target ({scene.radius_law}): D10 {t.d10_mass:.3g}, D50 {t.d50_mass:.3g}, "
                f"D90 {t.d90_mass:.3g} m, Cu {t.cu_mass:.3g}"
            ),
        )
        if scene.radius_law == "sieve":
            ax.plot(
                scene.sieve_sizes,
                100.0 * np.asarray(scene.sieve_passing),
                "o",
                color="k",
                ms=4,
                label="sieve curve",
            )
    ax.set_xscale("log")
    ax.set_ylim(0, 100)
    ax.set_xlabel("diameter (m)")
    ax.set_ylabel("passing by mass (%)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    if title:
        ax.set_title(title)
    return fig
