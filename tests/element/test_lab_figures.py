"""The lab report's figures: a PNG written whole, one line per label, the peak marked."""

from __future__ import annotations

import numpy as np
import polars as pl
import pytest

from granpack.element.figures import (
    compression_figure,
    compression_plot,
    triaxial_figure,
    triaxial_plot,
)
from granpack.errors import InvalidParameterError

PNG = b"\x89PNG\r\n\x1a\n"


def triaxial(peak_at: float, q_peak: float) -> pl.DataFrame:
    eps = np.linspace(0.0, 0.2, 101)
    q = np.interp(eps, [0.0, peak_at, 0.2], [0.0, q_peak, 0.8 * q_peak])
    return pl.DataFrame(
        {
            "eps_a": eps,
            "eps_v": 0.02 * np.sin(8 * eps) - 0.1 * eps,
            "sigma_1": 1e5 + q,
            "sigma_3": np.full_like(eps, 1e5),
            "fabric_dev": 0.1 * eps / (0.05 + eps),
        }
    )


def oedometer() -> pl.DataFrame:
    s = np.array([1e5, 2e5, 4e5, 8e5, 4e5, 1e5])
    e = np.array([0.7, 0.66, 0.6, 0.54, 0.55, 0.57])
    return pl.DataFrame(
        {"target": s, "sigma_1": s, "sigma_3": 0.5 * s, "p": 2 * s / 3, "e": e, "k0": 0.5 + 0 * s}
    )


def test_triaxial_figure_writes_a_png_with_one_line_per_label(tmp_path):
    tables = {"Dr 0.2": triaxial(0.15, 2e5), "Dr 0.8": triaxial(0.04, 3.5e5)}
    path = triaxial_figure(tables, tmp_path / "out" / "triaxial.png")
    assert path == tmp_path / "out" / "triaxial.png"
    data = path.read_bytes()
    assert data.startswith(PNG) and len(data) > 10_000
    assert not list(path.parent.glob(".*"))  # no temporary file left beside it

    fig = triaxial_plot(tables)
    ax_q, ax_v, ax_f = fig.axes
    assert [t.get_text() for t in ax_q.get_legend().get_texts()] == ["Dr 0.2", "Dr 0.8"]
    for ax in (ax_v, ax_f):
        assert [ln.get_label() for ln in ax.get_lines() if not ln.get_label().startswith("_")] == [
            "Dr 0.2",
            "Dr 0.8",
        ]
    # the peak of each line marked at its (eps_a %, q kPa)
    markers = [ln for ln in ax_q.get_lines() if ln.get_marker() == "o"]
    assert [(float(m.get_xdata()[0]), float(m.get_ydata()[0])) for m in markers] == [
        pytest.approx((15.0, 200.0)),
        pytest.approx((4.0, 350.0)),
    ]


def test_compression_figure_marks_loading_and_unloading(tmp_path):
    iso = oedometer().drop("k0").with_columns(p=pl.col("sigma_1"))
    path = compression_figure({"oedometer": oedometer(), "isotropic": iso}, tmp_path / "e.png")
    data = path.read_bytes()
    assert data.startswith(PNG) and len(data) > 10_000

    fig = compression_plot({"oedometer": oedometer()})
    (ax,) = fig.axes
    assert ax.get_xscale() == "log"
    load, unload = ax.get_lines()
    assert load.get_label() == "oedometer, loading" and unload.get_label() == "oedometer, unloading"
    assert list(load.get_xdata()) == [100.0, 200.0, 400.0, 800.0]
    assert list(unload.get_xdata()) == [800.0, 400.0, 100.0]
    assert unload.get_linestyle() == "--"


def test_figures_refuse_an_empty_mapping_or_a_bad_table(tmp_path):
    with pytest.raises(InvalidParameterError) as info:
        triaxial_figure({}, tmp_path / "t.png")
    assert info.value.parameter == "tables"
    with pytest.raises(InvalidParameterError, match="fabric_dev") as info:
        triaxial_figure({"a": triaxial(0.1, 1e5).drop("fabric_dev")}, tmp_path / "t.png")
    assert info.value.parameter == "table"
    with pytest.raises(InvalidParameterError, match="1 row") as info:
        compression_figure({"a": oedometer().head(1)}, tmp_path / "e.png")
    assert info.value.parameter == "table"
    with pytest.raises(InvalidParameterError) as info:
        compression_figure({"a": oedometer()}, tmp_path / "e.png", dim=1)
    assert info.value.parameter == "dim"
    assert not list(tmp_path.iterdir())  # nothing written
