"""Tiling a periodic pack: the copies fit together, their contacts are those of the seam,
and the microstructure is the original's."""

from __future__ import annotations

import dataclasses
import json
import sys

import numpy as np
import pytest
from scenes import outputs_on_threads, small_scene

import granpack as gp
from granpack.cli import main
from granpack.tiling import MAX_TILED_PARTICLES

COUNTS = {2: (3,), 3: (2, 3)}


@pytest.fixture(scope="module", params=[2, 3], ids=["2d", "3d"])
def periodic_pack(request) -> gp.Pack:
    return gp.generate(small_scene(request.param, container="periodic"))


def brute_force_pairs(pack: gp.Pack) -> dict[tuple[int, int], float]:
    """Every touching pair (i < j) of the pack's positions by an all-pairs search with the
    minimum image along the periodic axes: the overlap by pair."""
    x, r = pack.positions, pack.radii
    d = pack.dim
    periods = np.array(pack.scene.base)
    dx = x[None, :, :] - x[:, None, :]
    dx[..., : d - 1] -= periods * np.rint(dx[..., : d - 1] / periods)
    overlap = r[:, None] + r[None, :] - np.sqrt(np.sum(dx * dx, axis=2))
    i, j = np.triu_indices(len(r), 1)
    keep = overlap[i, j] > 0
    return {
        (int(a), int(b)): float(o)
        for a, b, o in zip(i[keep], j[keep], overlap[i, j][keep], strict=True)
    }


def test_tiled_contacts_equal_a_brute_force_search(periodic_pack):
    pack = periodic_pack
    tiled = gp.tile(pack, COUNTS[pack.dim])
    copies = int(np.prod(COUNTS[pack.dim]))
    pairs = tiled.contacts.particle_pairs()
    found = brute_force_pairs(tiled)
    listed = {
        (int(a), int(b)): float(o) for a, b, o in zip(pairs.i, pairs.j, pairs.overlap, strict=True)
    }
    assert set(listed) == set(found)
    assert len(listed) == copies * len(pack.contacts.particle_pairs()) > 0
    r_min = float(np.min(pack.radii))
    for key, overlap in listed.items():
        assert overlap == pytest.approx(found[key], abs=1e-12 * r_min)
    # every junction carries contacts: pairs between different copies exist
    n = len(pack)
    assert np.any(pairs.i // n != pairs.j // n)
    # the engine's order: pairs with i < j by (i, j), then the walls by particle
    assert np.all(pairs.i < pairs.j)
    key = pairs.i * len(tiled) + pairs.j
    assert np.all(np.diff(key) > 0)
    walls = tiled.contacts.select(tiled.contacts.is_wall)
    assert len(walls) == copies * int(np.sum(pack.contacts.is_wall))
    assert np.all(tiled.contacts.j[len(pairs) :] < 0)
    assert np.all(np.diff(walls.i) >= 0)


def test_each_copy_keeps_the_forces_of_the_original_contacts(periodic_pack):
    pack = periodic_pack
    tiled = gp.tile(pack, COUNTS[pack.dim])
    n = len(pack)
    c, t = pack.contacts, tiled.contacts
    original = {}
    for k in range(len(c)):
        original[(int(c.i[k]), int(c.j[k]))] = k
    for k in range(len(t)):
        i, j = int(t.i[k]) % n, int(t.j[k])
        j = j % n if j >= 0 else j
        sign = 1.0
        if (i, j) not in original:  # listed the other way round
            i, j, sign = j, i, -1.0
        m = original[(i, j)]
        assert t.force_normal[k] == c.force_normal[m]
        assert t.overlap[k] == c.overlap[m]
        np.testing.assert_array_equal(t.force_tangential[k], sign * c.force_tangential[m])
        np.testing.assert_array_equal(t.normal[k], sign * c.normal[m])
        np.testing.assert_array_equal(t.branch[k], sign * c.branch[m])


def test_particle_k_of_copy_a_b_is_k_plus_n_times_a_plus_nx_b(periodic_pack):
    pack = periodic_pack
    counts = COUNTS[pack.dim]
    tiled = gp.tile(pack, counts)
    n, d = len(pack), pack.dim
    nx = counts[0]
    periods = np.array(pack.scene.base)
    assert tiled.scene.base == tuple(p * c for p, c in zip(pack.scene.base, counts, strict=True))
    assert tiled.scene.container == "periodic" and tiled.height == pack.height
    ny = counts[1] if d == 3 else 1
    for b in range(ny):
        for a in range(nx):
            rows = slice(n * (a + nx * b), n * (a + nx * b + 1))
            shift = np.zeros(d)
            shift[0] = a * periods[0]
            if d == 3:
                shift[1] = b * periods[1]
            np.testing.assert_allclose(tiled.positions[rows], pack.positions + shift, atol=1e-15)
            np.testing.assert_array_equal(tiled.radii[rows], pack.radii)
            np.testing.assert_array_equal(tiled.velocities[rows], pack.velocities)
            np.testing.assert_array_equal(tiled.spins[rows], pack.spins)
            np.testing.assert_array_equal(tiled.layer[rows], pack.layer)
    lo = np.zeros(d - 1)
    hi = np.array(tiled.scene.base)
    assert np.all(tiled.positions[:, : d - 1] >= lo) and np.all(tiled.positions[:, : d - 1] < hi)
    assert tiled.layers[-1]["total"] == len(tiled)


def test_one_copy_is_the_original(periodic_pack):
    pack = periodic_pack
    same = gp.tile(pack, (1,) * (pack.dim - 1))
    np.testing.assert_array_equal(same.positions, pack.positions)
    for key, col in pack.contacts.to_dict().items():
        np.testing.assert_array_equal(getattr(same.contacts, key), col)


# the small packs' core window is empty, and microstructure says so: not the point here
@pytest.mark.filterwarnings("ignore:core window is empty")
def test_the_microstructure_of_a_tiled_pack_is_the_original_one(periodic_pack):
    pack = periodic_pack
    tiled = gp.tile(pack, COUNTS[pack.dim])
    m0 = gp.microstructure(pack)
    m1 = gp.microstructure(tiled)
    assert m1.n_particles == np.prod(COUNTS[pack.dim]) * m0.n_particles
    for key in (
        "z",
        "z_mech",
        "phi",
        "fabric",
        "f0",
        "a_n",
        "a_t",
        "force_normal_tensor",
        "force_tangential_tensor",
        "stress",
    ):
        a, b = np.asarray(getattr(m0, key), float), np.asarray(getattr(m1, key), float)
        scale = max(1.0, float(np.max(np.abs(a)))) if a.size else 1.0
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-12 * scale, err_msg=key)
    assert tiled.phi == pytest.approx(pack.phi, rel=1e-12)


def test_tiling_is_bit_identical_on_one_and_two_threads():
    script = """
import hashlib, sys, warnings
sys.path.insert(0, "tests")
warnings.simplefilter("ignore")
import granpack as gp
from scenes import small_scene
for dim, counts in ((2, (3,)), (3, (2, 2))):
    t = gp.tile(gp.generate(small_scene(dim, container="periodic")), counts)
    h = hashlib.sha256()
    for a in (t.positions, t.radii, t.velocities, t.spins, t.layer):
        h.update(a.tobytes())
    for a in t.contacts.to_dict().values():
        h.update(a.tobytes())
    print(len(t), h.hexdigest())
"""
    out = outputs_on_threads(script)
    assert out["1"] == out["2"]
    assert len(out["1"]) == 4


def test_a_walled_pack_is_refused(tiny_scene_2d):
    box = gp.generate(tiny_scene_2d)
    with pytest.raises(gp.InvalidParameterError, match="container is 'box'") as exc:
        gp.tile(box, (2,))
    assert exc.value.parameter == "pack"
    # a cylinder pack (the scene's container is all that decides)
    pack = gp.generate(small_scene(3, container="periodic", height=0.04))
    cylinder = dataclasses.replace(pack, scene=pack.scene.replace(container="cylinder"))
    with pytest.raises(gp.InvalidParameterError, match="container is 'cylinder'") as exc:
        gp.tile(cylinder, (2, 2))
    assert exc.value.parameter == "pack"
    with pytest.raises(gp.InvalidParameterError, match="granpack.Pack") as exc:
        gp.tile("pack.npz", (2, 2))
    assert exc.value.parameter == "pack"


@pytest.mark.parametrize(
    "dim, counts, words",
    [
        (2, (0,), r"nx = 0 in counts: must lie in \[1, "),
        (2, (-3,), r"nx = -3 in counts: must lie in \[1, "),
        (2, 0, r"nx = 0 in counts: must lie in \[1, "),
        (2, (2.0,), r"nx = 2.0 in counts: must be an integer in \[1, "),
        (2, ("2",), r"nx = '2' in counts: must be an integer"),
        (2, (True,), r"nx = True in counts: must be an integer"),
        (2, (2, 2), r"a 2D pack takes \(nx,\), 1 count\(s\), not 2"),
        (2, "22", r"expected \(nx,\)"),
        (2, (10**12,), r"nx = 1000000000000 in counts: must lie in \[1, "),
        (3, (4,), r"a 3D pack takes \(nx, ny\), 2 count\(s\), not 1"),
        (3, 4, r"expected \(nx, ny\)"),
        (3, (1, 0), r"ny = 0 in counts: must lie in \[1, "),
        (3, (2, 2.5), r"ny = 2.5 in counts: must be an integer"),
        (3, (10**4, 10**4), r"beyond the 1e\+08 particles"),
    ],
)
def test_bad_counts_are_refused_naming_the_range(dim, counts, words, monkeypatch):
    pack = gp.generate(small_scene(dim, container="periodic", height=0.04))
    # nothing is built before the counts are checked
    monkeypatch.setattr(sys.modules["granpack.tiling"], "_tiled_contacts", _never)
    with pytest.raises(gp.InvalidParameterError, match=words) as exc:
        gp.tile(pack, counts)
    assert exc.value.parameter == "counts"


def _never(*args, **kwargs):
    raise AssertionError("tiling started before the counts were checked")


def test_the_particle_bound_is_the_documented_one():
    assert MAX_TILED_PARTICLES == 10**8


def test_save_and_load_keep_the_tiling_record(periodic_pack, tmp_path):
    pack = periodic_pack
    counts = COUNTS[pack.dim]
    tiled = gp.tile(pack, counts)
    record = tiled.record("tile").table()
    assert record["counts"] == list(counts)
    assert record["particles"] == len(pack)
    assert record["base"] == list(pack.scene.base)
    assert (record["seed"], record["stream"]) == (pack.scene.seed, pack.scene.stream)
    assert len(record["scene_sha256"]) == 64
    back = gp.load_pack(tiled.save(tmp_path / "tiled.npz"))
    assert back.record("tile").table() == record
    np.testing.assert_array_equal(back.positions, tiled.positions)
    assert back.scene == tiled.scene
    # a pack that was not tiled has no record, before and after a save (files written
    # before tiling existed have none either)
    assert pack.record("tile") is None
    assert gp.load_pack(pack.save(tmp_path / "plain.npz")).record("tile") is None
    meta = json.loads(np.load(tmp_path / "plain.npz")["meta.json"].tobytes())
    assert "tiled" not in meta
    # tiling a tiled pack counts the copies of the first original
    again = gp.tile(back, (2,) * (pack.dim - 1))
    assert again.record("tile").table()["counts"] == [2 * c for c in counts]
    assert again.record("tile").table()["particles"] == len(pack)
    assert len(again) == len(pack) * int(np.prod(again.record("tile").table()["counts"]))


def test_a_tiling_record_that_does_not_match_the_pack_is_refused(periodic_pack, tmp_path):
    tiled = gp.tile(periodic_pack, COUNTS[periodic_pack.dim])
    rec = tiled.record("tile")
    wrong = dataclasses.replace(rec, report={**rec.report, "particles": 1})
    bad = dataclasses.replace(tiled, history=tuple(wrong if r is rec else r for r in tiled.history))
    path = bad.save(tmp_path / "bad.npz")
    with pytest.raises(gp.FileFormatError, match="'tiled' says 1 particles"):
        gp.load_pack(path)


def test_the_command_line_tiles_a_pack(tmp_path, capsys):
    pack = gp.generate(small_scene(3, container="periodic", height=0.04))
    src = pack.save(tmp_path / "small.npz")
    out = tmp_path / "big.npz"
    assert main(["tile", str(src), "2", "3", "--out", str(out)]) == 0
    said = capsys.readouterr().out
    big = gp.load_pack(out)
    assert len(big) == 6 * len(pack) and big.record("tile").table()["counts"] == [2, 3]
    assert f"{6 * len(pack)} particles" in said
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    # default name beside the input
    assert main(["tile", str(src), "2", "2", "-q"]) == 0
    assert gp.load_pack(tmp_path / "small_tiled_2x2.npz").record("tile").table()["counts"] == [2, 2]
    # the input is never the output
    before = src.read_bytes()
    assert main(["tile", str(src), "2", "2", "--out", str(src)]) == 2
    assert "invalid --out" in capsys.readouterr().err
    assert src.read_bytes() == before
    # bad counts, walled packs and missing files: one line, status 2
    assert main(["tile", str(tmp_path / "missing.npz"), "2", "2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no such file" in err and "Traceback" not in err
    assert main(["tile", str(src), "2", "--out", str(out)]) == 2
    assert "a 3D pack takes (nx, ny)" in capsys.readouterr().err
    with pytest.raises(SystemExit) as stop:
        main(["tile", str(src), "0", "2", "--out", str(out)])
    assert stop.value.code == 2
    assert "argument COUNT: invalid value 0: must be >= 1" in capsys.readouterr().err
    box = gp.generate(small_scene(2, height=0.04)).save(tmp_path / "box.npz")
    assert main(["tile", str(box), "2", "--out", str(tmp_path / "b.npz")]) == 2
    assert "container = 'periodic'" in capsys.readouterr().err
