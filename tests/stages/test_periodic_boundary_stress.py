"""A periodic sample's boundary stress: only the vertical row (the floor's and the lid's,
whose heights are not wrapped) is a stress; the lateral entries, x_c f_c at wrapped
positions, are NaN, and the vertical row equals the particles' Love-Weber stress."""

from __future__ import annotations

import numpy as np
import pytest

import granpack as gp

SCENES = {
    "2d": gp.PackScene.preset("4.1").replace(seed=3, base=(0.4,), height=0.3, container="periodic"),
    "3d": gp.PackScene.preset("4.3").replace(
        seed=3, base=(0.3, 0.3), height=0.2, container="periodic"
    ),
}


@pytest.fixture(scope="module")
def samples() -> dict[str, gp.Pack]:
    out = {}
    for name, sc in SCENES.items():
        stress = 1e3 if name == "2d" else 1e4
        out[name] = gp.consolidate(gp.generate(sc.fast()), stress, gravity=name == "2d")
    return out


@pytest.mark.parametrize("name", list(SCENES))
def test_the_lateral_entries_are_nan_and_the_vertical_row_is_love_weber(samples, name):
    pack = samples[name]
    rec = pack.record("consolidate").table()
    bd = np.array(rec["boundary_stress"])
    lw = np.array(rec["love_weber"])
    stress = rec["targets"]["lid"]
    d = pack.dim
    lateral = bd[: d - 1, : d - 1]
    assert np.all(np.isnan(lateral))
    assert np.all(np.isfinite(bd[-1])) and np.array_equal(bd[-1], bd[:, -1])
    # the vertical row: the lid's stress (and the weight's mean over the depth, with
    # gravity), and the particles' stress to the residual
    if rec["gravity"]:
        assert bd[-1, -1] > stress
    else:
        assert bd[-1, -1] == pytest.approx(stress, rel=3e-3)
    np.testing.assert_allclose(bd[-1], lw[-1], atol=2e-3 * stress)
    # Love-Weber holds the lateral stress the boundary sum cannot
    assert np.all(np.isfinite(lw)) and np.all(np.diag(lw)[:-1] > 0.0)


def test_the_record_keeps_its_nan_through_the_pack_file(samples, tmp_path):
    pack = samples["3d"]
    back = gp.load_pack(pack.save(tmp_path / "p.npz"))
    a = np.array(pack.record("consolidate").table()["boundary_stress"])
    b = np.array(back.record("consolidate").table()["boundary_stress"])
    np.testing.assert_array_equal(a, b)  # NaN where NaN


def test_a_walled_sample_keeps_every_entry():
    sc = gp.PackScene.preset("4.1").replace(seed=3, base=(0.4,), height=0.3)
    pack = gp.consolidate(gp.generate(sc.fast()), 1e3, gravity=False)
    bd = np.array(pack.record("consolidate").table()["boundary_stress"])
    assert np.all(np.isfinite(bd)) and np.array_equal(bd, bd.T)
