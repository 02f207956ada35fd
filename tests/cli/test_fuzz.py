"""Fuzzing of every entry point that takes outside input: TOML scene text and
files, scene dicts, Material and Simulation keywords, the array arguments of
`Simulation.add_particles`, and pack files (random, truncated, corrupted, doctored).

Every input either works (and then gives finite numbers) or is refused with a
`ValueError` (a `granpack.GranpackError` for granpack's own checks) whose message names
the parameter or file. Any other exception type, a Rust panic
(`pyo3_runtime.PanicException`, a BaseException), a hang or a NaN fails the test.

Hypothesis runs derandomized (the same examples on every run) and without its example
database, so CI is reproducible; the example counts keep this file to a few seconds.
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
import warnings
import zipfile

import numpy as np
import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import granpack as gp
from granpack.io import detect_format
from granpack.pack import _packer

FUZZ = settings(
    max_examples=150,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
FEW = settings(FUZZ, max_examples=60)

SCENE_KEYS = [f.name for f in dataclasses.fields(gp.PackScene)]
MATERIAL_KEYS = [f.name for f in dataclasses.fields(gp.Material)]
SIM_KEYS = [
    "dim",
    "material",
    "dt",
    "gravity",
    "drag",
    "box",
    "rotations",
    "skin_ratio",
    "max_overlap_ratio",
    "inertia_2d",
]


def refused(exc: BaseException, *names: str) -> None:
    """`exc` must be a ValueError whose message names one of `names`."""
    assert isinstance(exc, ValueError), f"{type(exc).__name__}: {exc}"
    msg = str(exc)
    assert any(n in msg for n in names), f"message names none of {names}: {msg}"


def attempt(fn, *names: str):
    """Calls fn(); a ValueError must name one of `names`; anything else propagates
    (and fails the test). Returns fn's result or None when refused."""
    try:
        return fn()
    except ValueError as exc:
        refused(exc, *names)
        return None


# -- values of every kind ------------------------------------------------------------------
ODD_FLOATS = st.sampled_from(
    [
        0.0,
        -0.0,
        1e-320,
        -1e-300,
        1e-300,
        1e300,
        -1e300,
        1.7e308,
        math.inf,
        -math.inf,
        math.nan,
        0.5,
        2.0,
        3.0,
    ]
)
SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    ODD_FLOATS,
    st.text(max_size=8),
    st.sampled_from(["4.1", "4.3", "constant", "gaussian", "sphere", "disc", ""]),
    st.complex_numbers(max_magnitude=10),
    st.binary(max_size=4),
)
VALUES = st.recursive(
    SCALARS,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4),
        st.tuples(inner, inner),
        st.dictionaries(st.sampled_from(MATERIAL_KEYS + ["x"]), inner, max_size=3),
    ),
    max_leaves=6,
)
# What TOML can hold (tomli_w writes it): no None, no complex, no NaN-free restriction.
TOML_SCALARS = st.one_of(
    st.booleans(),
    st.integers(min_value=-(2**63), max_value=2**63 - 1),
    st.floats(allow_nan=True, allow_infinity=True),
    ODD_FLOATS,
    st.text(max_size=8),
    st.sampled_from(["4.1", "4.2", "4.3", "4.4", "constant", "gaussian", "sphere", "disc"]),
)
TOML_VALUES = st.recursive(
    TOML_SCALARS,
    lambda inner: st.one_of(
        st.lists(inner, max_size=3),
        st.dictionaries(st.sampled_from(MATERIAL_KEYS + ["x"]), inner, max_size=3),
    ),
    max_leaves=5,
)
NEAR_VALID = {  # values around the valid ranges, to get past the first check
    "dim": st.sampled_from([2, 3, 1, 4, 2.0, True]),
    "base": st.lists(st.one_of(ODD_FLOATS, st.floats(0.01, 2.0)), max_size=3),
    "height": st.one_of(ODD_FLOATS, st.floats(0.0, 1.0)),
    "r_mean": st.one_of(ODD_FLOATS, st.floats(0.0, 0.05)),
    "r_std": st.one_of(ODD_FLOATS, st.floats(0.0, 0.01)),
    "phi_layer": st.one_of(ODD_FLOATS, st.floats(0.0, 0.6)),
    "dt": st.one_of(ODD_FLOATS, st.floats(0.0, 1e-3)),
    "settle_dt": st.one_of(st.none(), ODD_FLOATS, st.floats(0.0, 1e-3)),
    "seed": st.integers(min_value=-5, max_value=2**65),
    "max_layers": st.integers(min_value=-5, max_value=2**65),
    "radius_law": st.sampled_from(["constant", "gaussian", "normal"]),
}


def check_scene(scene: gp.PackScene) -> None:
    """An accepted scene holds finite, typed numbers and builds the Rust packer."""
    assert scene.dim in (2, 3) and type(scene.dim) is int
    for f in dataclasses.fields(scene):
        v = getattr(scene, f.name)
        if isinstance(v, float):
            assert math.isfinite(v), (f.name, v)
    assert scene.estimated_particles() <= 5e8
    _packer(scene)  # the Python/Rust boundary accepts every field


# -- TOML scenes ---------------------------------------------------------------------------
@FUZZ
@given(st.text(max_size=120))
def test_toml_random_text(text):
    scene = attempt(lambda: gp.PackScene.from_toml_string(text), "scene", *SCENE_KEYS)
    if scene is not None:
        check_scene(scene)


@FEW
@given(st.binary(max_size=120))
def test_toml_random_bytes_from_string_and_file(tmp_path_factory, data):
    scene = attempt(lambda: gp.PackScene.from_toml_string(data), "scene", *SCENE_KEYS)
    if scene is not None:
        check_scene(scene)
    path = tmp_path_factory.mktemp("toml") / "scene.toml"
    path.write_bytes(data)
    scene = attempt(lambda: gp.PackScene.from_toml(path), str(path), *SCENE_KEYS)
    if scene is not None:
        check_scene(scene)


@FUZZ
@given(
    st.dictionaries(
        st.sampled_from(SCENE_KEYS + ["preset", "bogus", "Dim"]), TOML_VALUES, max_size=5
    )
)
def test_toml_documents_with_random_values(doc):
    text = tomli_w.dumps(doc)
    scene = attempt(lambda: gp.PackScene.from_toml_string(text), *SCENE_KEYS, "preset", "scene")
    if scene is not None:
        check_scene(scene)


def test_toml_refusals_name_the_key(tmp_path):
    cases = {
        "dim = 2.0": "dim",
        'preset = ["4.1"]': "preset",
        "preset = 4.1": "preset",
        "max_layers = 100000000000000000000": "max_layers",
        "r_mean = 1e-300\ndt = 1e-310": "particles",
        'material = "steel"': "material",
        "material = {young = nan}": "material.young",
        "base = 1.0": "base",
        "inertia_2d = 2": "inertia_2d",
        "rotations = 1": "rotations",
    }
    for text, name in cases.items():
        with pytest.raises(gp.GranpackError, match=name):
            gp.PackScene.from_toml_string(text)
    with pytest.raises(gp.GranpackError, match="UTF-8"):
        gp.PackScene.from_toml_string(b"\xff\xfe")
    bad = tmp_path / "bad.toml"
    bad.write_bytes(b"dim = 2\n\xff")
    with pytest.raises(gp.GranpackError, match="bad.toml.*UTF-8"):
        gp.PackScene.from_toml(bad)
    for path in (None, 0, 3.5):  # open(0) would read stdin: a hang
        with pytest.raises(gp.GranpackError, match="path"):
            gp.PackScene.from_toml(path)
    with pytest.raises(gp.GranpackError, match="text"):
        gp.PackScene.from_toml_string(None)


# -- dicts and keywords --------------------------------------------------------------------
@FUZZ
@given(
    st.one_of(
        st.dictionaries(st.sampled_from(SCENE_KEYS + ["preset", "bogus"]), VALUES, max_size=5),
        st.fixed_dictionaries({}, optional={k: v for k, v in NEAR_VALID.items()}),
        st.dictionaries(
            st.one_of(st.integers(), st.none(), st.text(max_size=3)), SCALARS, max_size=2
        ),
        SCALARS,
    )
)
def test_scene_from_random_dicts(d):
    scene = attempt(lambda: gp.PackScene.from_dict(d), *SCENE_KEYS, "preset", "scene")
    if scene is not None:
        check_scene(scene)
    if isinstance(d, dict) and all(isinstance(k, str) for k in d) and "preset" not in d:
        scene = attempt(
            lambda: gp.PackScene(**d) if all(k in SCENE_KEYS for k in d) else None,
            *SCENE_KEYS,
            "scene",
        )
        if scene is not None:
            check_scene(scene)


@FUZZ
@given(
    st.dictionaries(
        st.sampled_from(MATERIAL_KEYS), st.one_of(SCALARS, st.floats(-2, 2)), max_size=5
    )
)
def test_material_random_keywords(kw):
    mat = attempt(lambda: gp.Material(**kw), *MATERIAL_KEYS)
    if mat is not None:
        assert all(math.isfinite(v) for v in mat.as_tuple())
        crit = mat.critical_time_step(0.01)
        assert crit > 0 and not math.isnan(crit)


SIM_VALUES = {
    "dim": st.one_of(st.sampled_from([2, 3, 2.0, 3.0, True, 1, 4, np.int64(3)]), SCALARS),
    "material": st.one_of(st.just(gp.Material()), st.just(gp.Material(young=1e6)), SCALARS),
    "dt": st.one_of(ODD_FLOATS, st.floats(1e-9, 1e-3), SCALARS),
    "gravity": st.one_of(st.lists(ODD_FLOATS, min_size=2, max_size=3), VALUES),
    "drag": st.one_of(ODD_FLOATS, SCALARS),
    "box": st.one_of(
        st.none(),
        st.tuples(
            st.lists(ODD_FLOATS, min_size=2, max_size=3),
            st.lists(ODD_FLOATS, min_size=2, max_size=3),
        ),
        st.just(((0.0, 0.0, 0.0), (1.0, 1.0, math.inf))),
        st.just(((0.0, 0.0), (1.0, math.inf))),
        VALUES,
    ),
    "rotations": st.one_of(st.booleans(), SCALARS),
    "skin_ratio": st.one_of(ODD_FLOATS, st.floats(0, 12), SCALARS),
    "max_overlap_ratio": st.one_of(ODD_FLOATS, st.floats(0, 1.2), SCALARS),
    "inertia_2d": st.one_of(st.sampled_from(["sphere", "disc", "cube"]), SCALARS),
}


@FUZZ
@given(st.fixed_dictionaries({}, optional=SIM_VALUES))
def test_simulation_random_keywords(kw):
    sim = attempt(lambda: gp.Simulation(**kw), *SIM_KEYS)
    if sim is None:
        return
    # An accepted world takes a particle inside its box (or at the origin) and steps.
    d = sim.dim
    x = np.full((1, d), 0.5)
    box = kw.get("box")
    if box is not None:
        with np.errstate(all="ignore"):
            lo = np.array(box[0], dtype=float)
            hi = np.array(box[1], dtype=float)
            hi[-1] = lo[-1] + 1.0
            x[0] = np.where(np.isfinite(hi - lo), 0.5 * (lo + hi), lo + 1.0)
    if attempt(lambda: sim.add_particles(x, [0.01]) or True, "positions", "radii") is None:
        return
    if attempt(lambda: sim.step(3), "dt", "unstable") is None:
        return
    assert np.all(np.isfinite(sim.positions)) and np.all(np.isfinite(sim.velocities))
    assert math.isfinite(sim.kinetic_energy()) and math.isfinite(sim.potential_energy())


# -- arrays into add_particles -------------------------------------------------------------
DTYPES = st.sampled_from(
    [
        np.float64,
        np.float32,
        np.float16,
        np.int64,
        np.int8,
        np.uint64,
        np.bool_,
        np.complex128,
        "U3",
        "S2",
        "M8[s]",
        object,
    ]
)
ARRAY_FLOATS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.sampled_from([0.01, 0.02, 0.5, 1.0, 1e-9, 1e9]),
)


def any_array(rows: int, cols: int | None):
    shapes = st.one_of(
        st.just((rows,) if cols is None else (rows, cols)),
        hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=4),
    )

    def build(dtype, shape):
        if dtype is object:
            return st.just(np.full(shape, None, dtype=object))
        if dtype is np.float64:
            return hnp.arrays(dtype, shape, elements=ARRAY_FLOATS)
        return hnp.arrays(dtype, shape)

    arrays = st.tuples(DTYPES, shapes).flatmap(lambda a: build(*a))
    return st.one_of(arrays, arrays.map(lambda a: a.tolist()), VALUES)


@st.composite
def particle_arguments(draw):
    dim = draw(st.sampled_from([2, 3]))
    n = draw(st.integers(0, 4))
    valid_x = draw(hnp.arrays(np.float64, (n, dim), elements=st.floats(0.05, 0.95)))
    valid_r = draw(hnp.arrays(np.float64, (n,), elements=st.floats(0.001, 0.01)))
    # each argument is, independently, valid or fuzzed
    x = draw(st.one_of(st.just(valid_x), any_array(n, dim)))
    r = draw(st.one_of(st.just(valid_r), any_array(n, None)))
    v = draw(st.one_of(st.none(), st.just(np.zeros((n, dim))), any_array(n, dim)))
    w = draw(st.one_of(st.none(), any_array(n, 3 if dim == 3 else None)))
    boxed = draw(st.booleans())
    return dim, x, r, v, w, boxed


@FUZZ
@given(particle_arguments())
def test_add_particles_random_arrays(args):
    dim, x, r, v, w, boxed = args
    box = ((0.0,) * dim, (1.0,) * (dim - 1) + (math.inf,)) if boxed else None
    sim = gp.Simulation(dim=dim, dt=1e-7, box=box)
    ok = attempt(
        lambda: sim.add_particles(x, r, velocities=v, spins=w) or True,
        "positions",
        "radii",
        "velocities",
        "spins",
    )
    if ok is None:
        assert len(sim) == 0, "a refused call must not add particles"
        return
    stepped = attempt(lambda: sim.step(5) or True, "dt", "unstable")
    if stepped:
        for a in (sim.positions, sim.velocities, sim.spins):
            assert np.all(np.isfinite(a))
        assert not math.isnan(sim.kinetic_energy())


def test_add_particles_refusals_name_the_argument():
    sim = gp.Simulation(dim=3)
    x = [[0.0, 0.0, 0.0]]
    for args, name in [
        ((x, [1e-200]), "radii"),  # mass underflows to 0: the engine would divide by it
        ((x, [1e120]), "radii"),  # mass overflows to inf: NaN energies
        ((np.zeros((1, 3), complex), [0.01]), "positions"),
        ((x, np.array(["0.01"])), "radii"),
        ((x, [[0.01]]), "radii"),
    ]:
        with pytest.raises(gp.GranpackError, match=name):
            sim.add_particles(*args)
    assert len(sim) == 0
    for kw, name in [
        ({"dim": 2.0}, "dim"),
        ({"dim": np.float64(3)}, "dim"),
        ({"inertia_2d": None}, "inertia_2d"),
        ({"inertia_2d": ["disc"]}, "inertia_2d"),
    ]:
        with pytest.raises(gp.GranpackError, match=name):
            gp.Simulation(**kw)
    assert gp.Simulation(dim=np.int64(2)).dim == 2
    with pytest.raises(gp.GranpackError, match="n = "):
        gp.Simulation().step(2**64)


@FEW
@given(st.one_of(any_array(2, 3), VALUES), st.one_of(any_array(2, 3), VALUES))
def test_velocity_and_spin_setters(v, w):
    sim = gp.Simulation(dim=3, dt=1e-6)
    sim.add_particles([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]], [0.01, 0.01])
    attempt(lambda: setattr(sim, "velocities", v), "velocities")
    attempt(lambda: setattr(sim, "spins", w), "spins")
    if attempt(lambda: sim.step(2) or True, "unstable"):
        assert np.all(np.isfinite(sim.positions))


@FEW
@given(st.one_of(SCALARS, st.integers(-(2**66), 2**66)), st.one_of(SCALARS, ODD_FLOATS))
def test_step_and_run_arguments(n, seconds):
    sim = gp.Simulation(dim=2, dt=1e-4, gravity=[0.0, 0.0])
    if isinstance(n, int) and not isinstance(n, bool) and n > 1000:
        n = 2**64 + n if n > 2**63 else -n  # no very long runs: only the refusals
    attempt(lambda: sim.step(n), "n")
    if isinstance(seconds, float) and math.isfinite(seconds) and seconds > 1.0:
        seconds = -seconds
    attempt(lambda: sim.run(seconds), "seconds")


# -- pack files ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def pack_bytes(tmp_path_factory) -> bytes:
    scene = gp.PackScene.preset("4.1").replace(
        base=(0.12,), height=0.03, h_layer=0.03, settle_time=0.02, seed=1
    )
    # 0.02 s per layer keeps the fixture fast; the pack is a file to damage, not a
    # settled pack, and the warning that says so is expected
    with pytest.warns(gp.UnsettledPackWarning, match="settle_time"):
        pack = gp.generate(scene)
    layers = [{**rep, "wall_seconds": 0.0} for rep in pack.layers]
    path = tmp_path_factory.mktemp("pack") / "pack.npz"
    dataclasses.replace(pack, layers=layers, wall_time=0.0).save(path)
    # Same bytes on every run (zip time stamps fixed), so the corruptions are reproducible.
    out = io.BytesIO()
    with zipfile.ZipFile(path) as src, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as dst:
        for name in src.namelist():
            dst.writestr(
                zipfile.ZipInfo(name, date_time=(2000, 1, 1, 0, 0, 0)),
                src.read(name),
                compress_type=zipfile.ZIP_DEFLATED,
            )
    return out.getvalue()


def load_bytes(tmp_path, data: bytes, name: str = "p.npz"):
    path = tmp_path / name
    path.write_bytes(data)
    pack = attempt(lambda: gp.load_pack(path), str(path))
    if pack is not None:
        assert np.all(np.isfinite(pack.positions)) and np.all(pack.radii > 0)
        assert pack.positions.shape == (len(pack), pack.dim)
    return pack


def test_pack_file_round_trips(tmp_path, pack_bytes):
    assert load_bytes(tmp_path, pack_bytes) is not None


def test_truncated_pack_files(tmp_path, pack_bytes):
    cuts = sorted(set(np.linspace(0, len(pack_bytes) - 1, 120).astype(int)))
    for cut in cuts:
        assert load_bytes(tmp_path, pack_bytes[:cut]) is None, cut


def test_corrupted_pack_files(tmp_path, pack_bytes):
    """Random bytes overwritten (fixed seed): CRC and zlib errors, unknown compression
    methods and zip versions, damaged headers. Some flips land in bytes zip does not
    check (timestamps, padding) and the pack still loads: it must then be sound."""
    rng = np.random.default_rng(7)
    for _ in range(300):
        b = bytearray(pack_bytes)
        for q in rng.integers(0, len(b), size=rng.integers(1, 6)):
            b[q] = rng.integers(0, 256)
        load_bytes(tmp_path, bytes(b))


@FEW
@given(st.binary(max_size=300))
def test_random_bytes_as_pack_file(tmp_path_factory, data):
    load_bytes(tmp_path_factory.mktemp("p"), data)


def archive(members: dict) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **members)
    return buf.getvalue()


def unpack(raw: bytes) -> dict:
    with np.load(io.BytesIO(raw)) as z:
        return {k: z[k] for k in z.files}


def text(s: str) -> np.ndarray:
    return np.frombuffer(s.encode(), dtype=np.uint8)


def test_doctored_pack_archives(tmp_path, pack_bytes):
    """Valid zip archives whose members are missing, of the wrong kind or shape."""
    good = unpack(pack_bytes)
    n = len(good["radii"])
    doctored = {
        "no meta": {k: v for k, v in good.items() if k != "meta.json"},
        "no positions": {k: v for k, v in good.items() if k != "positions"},
        "no contacts": {k: v for k, v in good.items() if not k.startswith("contacts.")},
        "meta is a list": {**good, "meta.json": text("[]")},
        "meta is a number": {**good, "meta.json": np.array(10**11)},
        "meta deeply nested": {**good, "meta.json": text("[" * 100_000)},
        "meta wrong format": {**good, "meta.json": text('{"format": "other"}')},
        "height overflows": {
            **good,
            "meta.json": text(
                json.dumps({**json.loads(good["meta.json"].tobytes()), "height": 10**400})
            ),
        },
        "scene not TOML": {**good, "scene.toml": text("dim = ")},
        "scene invalid": {**good, "scene.toml": text("dim = 5")},
        "scene as floats": {**good, "scene.toml": np.zeros(4)},
        "positions 1-D": {**good, "positions": np.zeros(n)},
        "positions text": {**good, "positions": np.full((n, 2), "a")},
        "positions NaN": {**good, "positions": np.full((n, 2), np.nan)},
        "radii short": {**good, "radii": good["radii"][:-1]},
        "radii negative": {**good, "radii": -good["radii"]},
        "layer floats": {**good, "layer": good["layer"].astype(float)},
        "spins 3-D in 2D": {**good, "spins": np.zeros((n, 3))},
        "contacts ragged": {**good, "contacts.normal": np.zeros((1, 2))},
        "contacts i float": {**good, "contacts.i": good["contacts.i"].astype(float)},
    }
    for what, members in doctored.items():
        assert load_bytes(tmp_path, archive(members)) is None, what
    one = tmp_path / "one.npz"  # np.save: a plain .npy array named like a pack
    np.save(tmp_path / "one.npy", np.arange(3))
    one.write_bytes((tmp_path / "one.npy").read_bytes())
    with pytest.raises(gp.GranpackError, match="one.npz"):
        gp.load_pack(one)
    pickled = tmp_path / "obj.npz"
    pickled.write_bytes(archive({"meta.json": np.array([{"a": 1}], dtype=object)}))
    with pytest.raises(gp.GranpackError, match="obj.npz"):
        gp.load_pack(pickled)
    zipped = tmp_path / "text.npz"  # a zip that is not an npz
    with zipfile.ZipFile(zipped, "w") as zf:
        zf.writestr("readme.txt", "hello")
    with pytest.raises(gp.GranpackError, match="text.npz"):
        gp.load_pack(zipped)
    for path in (tmp_path / "missing.npz", tmp_path):
        with pytest.raises(gp.GranpackError, match="cannot read pack"):
            gp.load_pack(path)
    for path in (None, 3, b"\x00"):
        with pytest.raises(gp.GranpackError, match="path"):
            gp.load_pack(path)


# -- damaged arrays in a pack whose records are intact --------------------------------------
ARRAY_KEYS = [
    "positions",
    "radii",
    "velocities",
    "spins",
    "layer",
    "contacts.i",
    "contacts.j",
    "contacts.normal",
    "contacts.overlap",
    "contacts.force_normal",
    "contacts.force_tangential",
    "contacts.branch",
]
DAMAGE = hnp.arrays(
    dtype=st.sampled_from([np.float64, np.float32, np.int64, np.int8, np.uint8, np.bool_]),
    shape=hnp.array_shapes(min_dims=0, max_dims=3, max_side=6),
    elements=None,
)


@FEW
@given(st.sampled_from(ARRAY_KEYS), DAMAGE, st.integers(0, 2**16))
def test_pack_files_with_damaged_arrays(tmp_path_factory, pack_bytes, key, damage, seed):
    """One array of a pack replaced (any dtype, shape and values, the scene and meta
    records intact); also the same array with a few entries poked (NaN, huge values,
    indices out of range). Either the pack loads and is sound, or the refusal names the
    file; a rerun over it either trusts a sound pack or makes it again."""
    from granpack.ensemble import PackTask, _existing

    tmp = tmp_path_factory.mktemp("damaged")
    good = unpack(pack_bytes)
    rng = np.random.default_rng(seed)
    poked = good[key].copy()
    flat = poked.reshape(-1)
    if flat.size:
        floaty = poked.dtype.kind == "f"
        bad = [np.nan, np.inf, -1.0, 1e308] if floaty else [-(2**40), 2**40, -7, 10**6]
        for q in rng.integers(0, flat.size, size=min(3, flat.size)):
            flat[q] = bad[rng.integers(len(bad))]
    for members in ({**good, key: damage}, {**good, key: poked}):
        pack = load_bytes(tmp, archive(members))
        scene = gp.PackScene.from_toml_string(bytes(good["scene.toml"]).decode())
        kept = _existing(PackTask(scene, tmp / "p.npz", "#0"))
        assert kept == (pack is not None)
        if pack is not None:
            assert np.all(pack.contacts.i != pack.contacts.j)
            assert np.all((pack.contacts.j >= -5) & (pack.contacts.j < len(pack)))


# -- the analysis arrays -------------------------------------------------------------------
ANALYSIS_FLOATS = st.one_of(
    st.floats(-2.0, 2.0),
    st.sampled_from([0.0, 1e-320, 1e-300, 1e-150, 1e150, 1e300, 1.7e308, -1.7e308]),
)


@st.composite
def analysis_input(draw):
    dim = draw(st.sampled_from([2, 3]))
    n = draw(st.integers(1, 12))
    x = draw(hnp.arrays(np.float64, (n, dim), elements=ANALYSIS_FLOATS))
    r = draw(hnp.arrays(np.float64, (n,), elements=st.one_of(ANALYSIS_FLOATS, st.just(0.1))))
    kw = {"positions": x, "radii": r}
    if draw(st.booleans()):
        lo = draw(hnp.arrays(np.float64, (dim,), elements=ANALYSIS_FLOATS))
        hi = draw(hnp.arrays(np.float64, (dim,), elements=ANALYSIS_FLOATS))
        kw["box"] = (lo, hi)
    if draw(st.booleans()):
        m = draw(st.integers(0, 6))
        kw["contacts"] = {
            "i": draw(hnp.arrays(np.int64, (m,), elements=st.integers(-2, n))),
            "j": draw(hnp.arrays(np.int64, (m,), elements=st.integers(-6, n))),
            "normal": draw(hnp.arrays(np.float64, (m, dim), elements=ANALYSIS_FLOATS)),
            "force_normal": draw(hnp.arrays(np.float64, (m,), elements=ANALYSIS_FLOATS)),
        }
    kw["core_margin"] = draw(st.sampled_from([0.0, 0.1, 1e300]))
    return kw


@FUZZ
@given(analysis_input())
def test_microstructure_of_random_arrays(kw):
    """Any positions, radii, box and contacts: finite, meaningful numbers or a
    GranpackError, never another exception (ZeroDivisionError, OverflowError, a hang
    in the cell grid)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gp.analysis.MicrostructureWarning)
        try:
            m = gp.microstructure(**kw)
        except gp.GranpackError:
            return
    assert 0.0 < m.phi and math.isfinite(m.phi)
    assert math.isfinite(m.void_ratio) and m.void_ratio > -1.0
    assert math.isfinite(m.z) and m.z >= 0.0


# -- the command line ----------------------------------------------------------------------
class _Accepted(Exception):
    """Raised in place of the pack runs: the arguments got as far as the work."""


def _no_runs(*args, **kwargs):
    raise _Accepted


@pytest.fixture(scope="module")
def cli_files(tmp_path_factory, pack_bytes) -> dict[str, str]:
    """Files of every kind for the fuzzed command lines to name."""
    d = tmp_path_factory.mktemp("cli")
    (d / "pack.npz").write_bytes(pack_bytes)
    (d / "cut.npz").write_bytes(pack_bytes[: len(pack_bytes) // 2])
    (d / "scene.toml").write_text('preset = "4.1"\nbase = [0.2]\nheight = 0.06\n')
    (d / "bad.toml").write_text("dim = [[[[[[1]]]]]]\n" + "r_mean = " + "[" * 3000)
    (d / "xyzr.txt").write_text("0 0 0.1\n0.5 0 0.1\n")
    (d / "far.txt").write_text("1e308 1 0.1\n-1e308 1 0.1\n")
    (d / "overlap.txt").write_text("0 0 0.1\n0.001 0 0.1\n")
    (d / "junk.data").write_bytes(b"\x00\xffLAMMPS\n3 atoms\n")
    (d / "empty.txt").write_text("")
    return {k: str(d / k) for k in (p.name for p in d.iterdir())} | {"dir": str(d)}


CLI_WORDS = st.sampled_from(
    [
        "generate",
        "paper",
        "analyze",
        "export",
        "4.1",
        "4.3",
        "--packs",
        "--seed",
        "--rotations",
        "--out",
        "--workers",
        "--scheduler",
        "--fast",
        "--settle-time",
        "--scale",
        "--format",
        "--dim",
        "--box",
        "--json",
        "--figures",
        "--examples",
        "--quick",
        "-q",
        "--no-figures",
        "--help",
        "on",
        "off",
        "vtk",
        "csv",
        "lammps-data",
        "0",
        "1",
        "2",
        "3",
        "-1",
        "1e12",
        "1e-300",
        "nan",
        "inf",
        "-inf",
        "99999999999999999999",
        "9" * 400,
        "tcp://127.0.0.1:1",
        "tcp://x",
        "",
        "\x00",
        "é",
    ]  # fmt: skip
)


@settings(FUZZ, max_examples=120)
@given(st.data())
def test_random_command_lines(cli_files, data):
    """Random command lines over the four commands, naming files of every kind: each
    ends in an exit status, an argparse exit, or the start of the pack runs (replaced
    here by a stub), never in a traceback."""
    import contextlib
    from unittest import mock

    from granpack.cli import main

    files = st.sampled_from(sorted(cli_files.values()))
    words = st.one_of(CLI_WORDS, files)
    command = data.draw(st.sampled_from(["generate", "paper", "analyze", "export", "--bogus"]))
    first = data.draw(st.one_of(files, st.sampled_from(["4.1", "4.3", "x"])))
    argv = [command, first, *data.draw(st.lists(words, max_size=6))]
    if command in ("generate", "export") and data.draw(st.booleans()):
        argv += ["--out", data.draw(st.one_of(files, st.just(cli_files["dir"] + "/out")))]
    sink = io.StringIO()
    with (
        mock.patch("granpack.ensemble.run_tasks", _no_runs),
        contextlib.chdir(cli_files["dir"]),
        contextlib.redirect_stdout(sink),
        contextlib.redirect_stderr(sink),
        warnings.catch_warnings(),
    ):
        warnings.simplefilter("ignore", gp.analysis.MicrostructureWarning)
        try:
            rc = main(argv)
        except SystemExit as exc:  # argparse: --help, or a usage error
            assert exc.code in (0, 2), (argv, exc.code)
            return
        except _Accepted:
            return
    assert rc in (0, 1, 2), (argv, rc)
    assert "Traceback" not in sink.getvalue()
    if rc == 2:
        assert len(sink.getvalue()) < 1000, argv


# -- deeply nested TOML --------------------------------------------------------------------
@FEW
@given(st.integers(1, 5000), st.sampled_from(["[", "{a = "]), st.sampled_from(SCENE_KEYS))
def test_toml_nested_to_any_depth(depth, opener, key):
    closer = "]" if opener == "[" else "}"
    text = f"{key} = " + opener * depth + "1" + closer * depth + "\n"
    attempt(lambda: gp.PackScene.from_toml_string(text), key, "scene", "nested")


# -- particle files of every format (read_particles) ---------------------------------------
# Four spheres, written in the order of P_IDS; every value exact in binary, so that a read
# compares with ==. Each file is damaged in one way: cut at any byte, two columns exchanged
# in every row, a NaN or infinity in one value, or the rows left out after the header. The
# read must then be a FileFormatError (or InvalidParameterError) naming the file, or the
# particles the damaged file holds, bit for bit: never another exception, never other
# values.
P_IDS = np.array([3, 1, 4, 2])
P_X = np.array([[0.25, 0.75, 0.125], [0.75, 0.25, 0.125], [0.25, 0.25, 0.5], [0.75, 0.75, 1.5]])
P_R = np.array([0.125, 0.0625, 0.09375, 0.125])
NON_FINITE = ["nan", "NaN", "-nan", "inf", "-inf", "Infinity", "1e999", "-1e999"]


@dataclasses.dataclass
class TextFile:
    """A text particle file as lines: `header`, one row of tokens per particle, `footer`;
    which row column holds the id, the coordinates and the radius (or diameter)."""

    header: list[str]
    rows: list[list[str]]
    footer: list[str]
    pos: tuple[int, ...]
    radius: int
    id: int | None = None
    diameter: bool = False
    sep: str = " "
    counts: tuple[int, ...] = ()  # header lines that hold the number of rows
    flat: bool = False  # rows of three values are x y r (2D)

    def text(self) -> str:
        rows = [self.sep.join(row) for row in self.rows]
        return "\n".join([*self.header, *rows, *self.footer]) + "\n"


def _t(v) -> str:
    return repr(float(v))


def text_file(fmt: str, images: bool = True, style: bool = True) -> TextFile:
    """The undamaged file of `fmt` (a text format) holding P_IDS, P_X, P_R; a data file
    with or without the image flags and the Atoms line's style comment."""
    rows = list(zip(P_IDS.tolist(), P_X.tolist(), P_R.tolist(), strict=True))
    if fmt == "lammps-dump":
        return TextFile(
            header=["ITEM: TIMESTEP", "0", "ITEM: NUMBER OF ATOMS", "4"]
            + ["ITEM: BOX BOUNDS pp pp ff", "0.0 1.0", "0.0 1.0", "0.0 2.0"]
            + ["ITEM: ATOMS id type x y z radius vx"],
            rows=[[str(i), "1", *map(_t, x), _t(r), "0"] for i, x, r in rows],
            footer=[],
            pos=(2, 3, 4),
            radius=5,
            id=0,
            counts=(3,),
        )
    if fmt == "lammps-data":
        return TextFile(
            header=["granpack fuzz data file", "", "4 atoms", "1 atom types", ""]
            + ["0.0 1.0 xlo xhi", "0.0 1.0 ylo yhi", "0.0 2.0 zlo zhi", ""]
            + ["Atoms # sphere" if style else "Atoms", ""],
            rows=[
                [str(i), "1", _t(2 * r), "1000.0", *map(_t, x)] + ["0", "0", "0"] * images
                for i, x, r in rows
            ],
            footer=["", "Velocities", ""] + [f"{i} 0.0 0.0 0.0 0.0 0.0 0.0" for i in P_IDS],
            pos=(4, 5, 6),
            radius=2,
            diameter=True,
            id=0,
            counts=(2,),
        )
    if fmt == "yade":
        return TextFile(
            header=["#format x_y_z_r"],
            rows=[[*map(_t, x), _t(r)] for _, x, r in rows],
            footer=[],
            pos=(0, 1, 2),
            radius=3,
        )
    if fmt == "xyz":
        comment = (
            'Lattice="1.0 0.0 0.0 0.0 1.0 0.0 0.0 0.0 2.0" Origin="0.0 0.0 0.0" '
            'Properties=species:S:1:pos:R:3:radius:R:1 pbc="T T F"'
        )
        return TextFile(
            header=["4", comment],
            rows=[["X", *map(_t, x), _t(r)] for _, x, r in rows],
            footer=[],
            pos=(1, 2, 3),
            radius=4,
            counts=(0,),
        )
    if fmt == "xyzr":
        return TextFile(
            header=["# x y z r"],
            rows=[[*map(_t, x), _t(r)] for _, x, r in rows],
            footer=[],
            pos=(0, 1, 2),
            radius=3,
            flat=True,
        )
    assert fmt == "csv"
    return TextFile(
        header=["id,x,y,z,radius"],
        rows=[[str(i), *map(_t, x), _t(r)] for i, x, r in rows],
        footer=[],
        pos=(1, 2, 3),
        radius=4,
        id=0,
        sep=",",
    )


def held_particles(f: TextFile, text: str):
    """What the (damaged) `text` of `f` holds: (ids or None, positions (N, 2 or 3), radii)
    sorted by id, read with f's layout from the rows still there; None where a row lacks a
    value or holds a word (a reader must refuse such a file)."""
    lines = text.removeprefix("\ufeff").splitlines()
    rows = []
    for k in range(len(f.rows)):
        at = len(f.header) + k
        if at < len(lines):
            rows.append(
                [w.strip() for w in lines[at].split(f.sep)] if f.sep == "," else lines[at].split()
            )
    pos, radius = f.pos, f.radius
    if f.flat and rows and all(len(t) == 3 for t in rows):
        pos, radius = (0, 1), 2  # x y r text: 2D
    need = max(*pos, radius, f.id if f.id is not None else 0)
    if not rows or any(len(t) <= need for t in rows):
        return None
    try:
        x = np.array([[float(t[c]) for c in pos] for t in rows])
        r = np.array([float(t[radius]) for t in rows]) / (2.0 if f.diameter else 1.0)
        ids = None if f.id is None else np.array([float(t[f.id]) for t in rows])
    except ValueError:
        return None
    if ids is not None:
        order = np.argsort(ids, kind="stable")
        ids, x, r = ids[order], x[order], r[order]
    return ids, x, r


def check_read(path, fmt, expected, must_read=False, **kwargs):
    """read_particles(path): a FileFormatError or InvalidParameterError naming the file,
    or exactly `expected` (ids, positions, radii; None: the file holds no valid particles).
    `must_read`: the file is whole, and a refusal fails too."""
    try:
        p = gp.read_particles(path, **kwargs)
    except (gp.FileFormatError, gp.InvalidParameterError) as exc:
        assert str(path) in str(exc), f"message does not name the file: {exc}"
        assert not must_read, f"{fmt}: a whole file refused: {exc}"
        return None
    assert expected is not None, f"{fmt}: read a file that holds no valid particles: {p}"
    ids, x, r = expected
    assert len(p) == len(r) > 0
    assert np.all(np.isfinite(p.positions)) and np.all(np.isfinite(p.radii) & (p.radii > 0))
    np.testing.assert_array_equal(p.radii, r)
    got = np.asarray(p.positions)
    if got.shape[1] < x.shape[1]:  # a constant z read as 2D
        assert np.all(x[:, 2] == x[0, 2]), (got, x)
        x = x[:, : got.shape[1]]
    np.testing.assert_array_equal(got, x)
    if ids is not None:
        np.testing.assert_array_equal(p.ids, ids)
    return p


TEXT_FORMATS = ["lammps-dump", "lammps-data", "yade", "xyz", "xyzr", "csv"]
READER_SUFFIX = {
    "lammps-dump": "p.dump",
    "lammps-data": "p.data",
    "yade": "p.yade.txt",
    "xyz": "p.xyz",
    "xyzr": "p.txt",
    "csv": "p.csv",
    "parquet": "p.parquet",
    "npz": "p.npz",
}
DAMAGE_KINDS = st.sampled_from(["cut", "swap", "non-finite", "no rows", "no rows, count 0"])


@pytest.fixture(scope="module")
def reader_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("readers")


@pytest.mark.parametrize("fmt", TEXT_FORMATS)
@FUZZ
@given(data=st.data())
def test_damaged_text_particle_files(reader_dir, fmt, data):
    images, style = data.draw(st.tuples(st.booleans(), st.booleans()), label="data file flags")
    f = text_file(fmt, images, style)
    kind = data.draw(DAMAGE_KINDS, label="damage")
    width = len(f.rows[0])
    if kind == "swap":
        i, j = data.draw(st.lists(st.integers(0, width - 1), min_size=2, max_size=2, unique=True))
        for row in f.rows:
            row[i], row[j] = row[j], row[i]
    elif kind == "non-finite":
        k, c = data.draw(st.integers(0, len(f.rows) - 1)), data.draw(st.integers(0, width - 1))
        f.rows[k][c] = data.draw(st.sampled_from(NON_FINITE))
    elif kind.startswith("no rows"):
        f.rows = []
        if fmt == "lammps-data":
            f.footer = []
        if kind.endswith("count 0"):
            for at in f.counts:
                f.header[at] = f.header[at].replace("4", "0")
    text = f.text()
    whole = kind == "cut" and data.draw(st.booleans(), label="whole")
    if kind == "cut":
        # whole: only the last newline (or nothing) cut, and the file must read
        at = len(text) - data.draw(st.integers(0, 1)) if whole else None
        text = text[: data.draw(st.integers(0, len(text)), label="cut at") if at is None else at]
    path = reader_dir / READER_SUFFIX[fmt]
    path.write_text(text)
    expected = held_particles(f, text)
    plain = check_read(path, fmt, expected, must_read=whole, format=fmt)
    # as `granpack analyze` reads it: the format found by content
    if detect_format(path) == fmt:
        check_read(path, fmt, expected, must_read=whole)
    # a byte-order mark (Excel writes one) changes nothing: the same particles or the
    # same refusal
    path.write_text("\ufeff" + text)
    assert detect_format(path) == detect_format_of(text, reader_dir / ("plain_" + path.name))
    marked = check_read(path, fmt, expected, must_read=plain is not None, format=fmt)
    assert (marked is None) == (plain is None)


def detect_format_of(text: str, path):
    path.write_text(text)
    return detect_format(path)


def _parquet_bytes(columns: dict) -> bytes:
    import polars as pl

    buf = io.BytesIO()
    pl.DataFrame(columns).write_parquet(buf)
    return buf.getvalue()


@FUZZ
@given(data=st.data())
def test_damaged_parquet_particle_files(reader_dir, data):
    columns = {"id": P_IDS.astype(float), "x": P_X[:, 0], "y": P_X[:, 1], "z": P_X[:, 2]}
    columns["radius"] = P_R.copy()
    columns = {k: np.array(v, dtype=np.float64) for k, v in columns.items()}
    kind = data.draw(DAMAGE_KINDS, label="damage")
    names = list(columns)
    if kind == "swap":
        a, b = data.draw(st.lists(st.sampled_from(names), min_size=2, max_size=2, unique=True))
        columns[a], columns[b] = columns[b], columns[a]
    elif kind == "non-finite":
        name = data.draw(st.sampled_from(names))
        columns[name][data.draw(st.integers(0, 3))] = float(data.draw(st.sampled_from(NON_FINITE)))
    elif kind.startswith("no rows"):
        columns = {k: v[:0] for k, v in columns.items()}
    raw = _parquet_bytes(columns)
    if kind == "cut":
        raw = raw[: data.draw(st.integers(0, len(raw)), label="cut at")]
    path = reader_dir / READER_SUFFIX["parquet"]
    path.write_bytes(raw)
    ids = columns["id"]
    order = np.argsort(ids, kind="stable")
    x = np.column_stack([columns["x"], columns["y"], columns["z"]])[order]
    expected = (ids[order], x, columns["radius"][order]) if len(ids) else None
    check_read(path, "parquet", expected)


@FUZZ
@given(data=st.data())
def test_damaged_npz_particle_files(reader_dir, pack_bytes, data):
    members = unpack(pack_bytes)
    kind = data.draw(DAMAGE_KINDS, label="damage")
    if kind == "swap":  # two columns of the positions, or positions and velocities
        if data.draw(st.booleans()):
            members["positions"] = members["positions"][:, ::-1].copy()
        else:
            members["positions"], members["velocities"] = (
                members["velocities"],
                members["positions"],
            )
    elif kind == "non-finite":
        key = data.draw(st.sampled_from(["positions", "radii"]))
        flat = members[key].reshape(-1)
        flat[data.draw(st.integers(0, flat.size - 1))] = float(
            data.draw(st.sampled_from(NON_FINITE))
        )
    elif kind.startswith("no rows"):
        for k, v in members.items():
            if k in ARRAY_KEYS:
                members[k] = v[:0]
    raw = archive(members)
    if kind == "cut":
        raw = raw[: data.draw(st.integers(0, len(raw)), label="cut at")]
    path = reader_dir / READER_SUFFIX["npz"]
    path.write_bytes(raw)
    expected = (
        None if kind.startswith("no rows") else (None, members["positions"], members["radii"])
    )
    check_read(path, "npz", expected)
