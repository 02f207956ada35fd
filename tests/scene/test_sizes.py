"""Size distributions: each radius law sampled right (goodness of fit at 1 %), a sieve
curve met by a pack, bad input refused by name, the grading measures, determinism, and
the presets' packs unchanged."""

from __future__ import annotations

import hashlib
import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import granpack as gp
from granpack import _core
from granpack.grading import passing, target_passing

ALPHA = 0.01

SIEVE = {
    "dim": 3,
    "base": (0.5, 0.5),
    "height": 0.3,
    "radius_law": "sieve",
    "sieve_sizes": (0.02, 0.03, 0.05, 0.08),
    "sieve_passing": (0.0, 0.3, 0.7, 1.0),
    "phi_layer": 0.25,
}


# -- statistics, by hand (no scipy) ---------------------------------------------------------
def kolmogorov_p(x: float) -> float:
    """P(K > x) for the Kolmogorov distribution: 2 sum_k (-1)^(k-1) exp(-2 k^2 x^2)."""
    if x < 0.2:
        return 1.0
    return min(
        1.0, 2.0 * sum((-1) ** (k - 1) * math.exp(-2 * k * k * x * x) for k in range(1, 101))
    )


def ks_p(sample: np.ndarray, cdf) -> float:
    """p-value of the one-sample Kolmogorov-Smirnov test (asymptotic, with Stephens'
    correction for n)."""
    x = np.sort(sample)
    n = len(x)
    f = cdf(x)
    d = max(np.max(np.arange(1, n + 1) / n - f), np.max(f - np.arange(n) / n))
    sn = math.sqrt(n)
    return kolmogorov_p((sn + 0.12 + 0.11 / sn) * d)


def gamma_q(a: float, x: float) -> float:
    """Regularised upper incomplete gamma Q(a, x): the series below a + 1, the continued
    fraction (modified Lentz) above (Numerical Recipes, section 6.2)."""
    if x <= 0:
        return 1.0
    ln_pre = -x + a * math.log(x) - math.lgamma(a)
    if x < a + 1:
        term = total = 1.0 / a
        ap = a
        for _ in range(1000):
            ap += 1
            term *= x / ap
            total += term
            if abs(term) < abs(total) * 1e-15:
                break
        return 1.0 - total * math.exp(ln_pre)
    tiny = 1e-300
    b = x + 1 - a
    c, d = 1 / tiny, 1 / b
    h = d
    for i in range(1, 1000):
        an = -i * (i - a)
        b += 2
        d = an * d + b
        d = tiny if abs(d) < tiny else d
        c = b + an / c
        c = tiny if abs(c) < tiny else c
        d = 1 / d
        h *= d * c
        if abs(d * c - 1) < 1e-15:
            break
    return math.exp(ln_pre) * h


def chi2_p(observed: np.ndarray, expected: np.ndarray) -> float:
    stat = float(np.sum((observed - expected) ** 2 / expected))
    return gamma_q(0.5 * (len(observed) - 1), 0.5 * stat)


def test_the_hand_written_distributions_are_right():
    # chi-squared with 2 dof: Q = exp(-x/2); with 1 dof at 6.635: 0.01
    assert gamma_q(1.0, 3.0) == pytest.approx(math.exp(-3.0), rel=1e-12)
    assert gamma_q(0.5, 6.635 / 2) == pytest.approx(0.01, abs=2e-5)
    assert gamma_q(5.0, 2.0) == pytest.approx(0.9473469826562889, rel=1e-12)
    # the Kolmogorov distribution's 1 % point
    assert kolmogorov_p(1.6276) == pytest.approx(0.01, abs=1e-4)


def dkw(n_eff: float) -> float:
    """Dvoretzky-Kiefer-Wolfowitz band for an empirical CDF of n_eff draws at ALPHA."""
    return math.sqrt(math.log(2 / ALPHA) / (2 * n_eff))


def scene(**kw) -> gp.PackScene:
    return gp.PackScene(**{"dim": 3, "base": (0.5, 0.5), "phi_layer": 0.25, **kw})


# -- each law sampled right -----------------------------------------------------------------
CONTINUOUS = {
    "uniform": {"radius_law": "uniform", "r_min": 0.01, "r_max": 0.04},
    "gaussian": {"radius_law": "gaussian", "r_mean": 0.02, "r_std": 0.004},
    "lognormal": {
        "radius_law": "lognormal",
        "r_mean": 0.02,
        "r_std": 0.008,
        "r_min": 0.012,
        "r_max": 0.05,
    },
    "lognormal_tail": {  # a window wholly in the right tail
        "radius_law": "lognormal",
        "r_mean": 0.01,
        "r_std": 0.002,
        "r_min": 0.016,
        "r_max": 0.03,
    },
    "sieve": {k: SIEVE[k] for k in ("radius_law", "sieve_sizes", "sieve_passing")},
}


@pytest.mark.parametrize("name", list(CONTINUOUS))
def test_each_continuous_law_fits_by_number(name):
    s = scene(**CONTINUOUS[name])
    r = _core.sample_radii(s, 4000, seed=11)
    assert np.all((r >= s.r_min) & (r <= s.r_max))
    p = ks_p(2 * r, lambda d: target_passing(s, d, by="number"))
    assert p > ALPHA, f"{name}: KS p = {p:.4g}"


def mass_weighted_ks(r: np.ndarray, cdf, p: int) -> tuple[float, float]:
    """sup |F_mass - target| over the sample's steps, and the DKW band with the
    mass-weighted sample's effective size (sum m)^2 / sum m^2."""
    order = np.argsort(r)
    r = r[order]
    m = r**p
    cum = np.cumsum(m) / m.sum()
    f = cdf(2 * r)
    d = max(np.max(np.abs(cum - f)), np.max(np.abs(np.concatenate([[0], cum[:-1]]) - f)))
    n_eff = m.sum() ** 2 / np.sum(m * m)
    return float(d), dkw(n_eff)


@pytest.mark.parametrize("inertia", ["sphere", "disc"])
def test_a_sieve_law_meets_its_curve_by_mass(inertia):
    kw = {**CONTINUOUS["sieve"], "inertia_2d": inertia}
    s = gp.PackScene(dim=2, base=(1.0,), **kw) if inertia == "disc" else scene(**kw)
    p = 2 if inertia == "disc" else 3
    r = _core.sample_radii(s, 6000, seed=3)
    d, band = mass_weighted_ks(r, lambda x: target_passing(s, x, by="mass"), p)
    assert d < band, (d, band)
    # the target by mass is the sieve curve itself
    assert np.allclose(target_passing(s, s.sieve_sizes), s.sieve_passing, atol=1e-9)


@pytest.mark.parametrize("by", ["number", "mass"])
def test_a_discrete_mixture_fits_by_number_and_by_mass(by):
    radii, fractions = (0.01, 0.02, 0.035), (0.5, 0.3, 0.2)
    s = scene(radius_law="discrete", radii=radii, fractions=fractions, fractions_by=by)
    n = 20_000
    r = _core.sample_radii(s, n, seed=5)
    counts = np.array([np.sum(r == x) for x in radii])
    assert counts.sum() == n
    number = np.asarray(_core.number_fractions(s))
    if by == "number":
        assert np.allclose(number, fractions, rtol=0, atol=1e-15)
    else:  # n_k proportional to w_k / r_k^3
        w = np.asarray(fractions) / np.asarray(radii) ** 3
        assert np.allclose(number, w / w.sum(), rtol=1e-14)
    assert chi2_p(counts, n * number) > ALPHA
    # by mass: each class's realised mass fraction within the DKW band of the target
    # (n_eff of the mass-weighted sample)
    m = np.asarray(radii) ** 3 * counts
    mass = m / m.sum()
    target = number * np.asarray(radii) ** 3
    target /= target.sum()
    n_eff = m.sum() ** 2 / np.sum(np.asarray(radii) ** 6 * counts)
    assert np.all(np.abs(np.cumsum(mass) - np.cumsum(target)) < dkw(n_eff))
    if by == "mass":
        assert np.allclose(target, fractions, rtol=1e-12)


def test_a_2d_mass_counts_the_engines_mass():
    radii, fractions = (0.01, 0.02), (0.5, 0.5)
    base = {"dim": 2, "base": (1.0,), "radius_law": "discrete", "radii": radii}
    sphere = gp.PackScene(**base, fractions=fractions, fractions_by="mass", inertia_2d="sphere")
    disc = sphere.replace(inertia_2d="disc")
    assert _core.number_fractions(sphere) == pytest.approx([8 / 9, 1 / 9], rel=1e-14)
    assert _core.number_fractions(disc) == pytest.approx([0.8, 0.2], rel=1e-14)


# -- the derived keys -----------------------------------------------------------------------
def test_every_law_sets_r_min_and_r_max():
    s = scene(**CONTINUOUS["sieve"])
    assert (s.r_min, s.r_max) == (0.01, 0.04)
    # empty end classes do not count
    s = scene(radius_law="sieve", sieve_sizes=(0.01, 0.02, 0.04), sieve_passing=(0, 0, 1))
    assert (s.r_min, s.r_max) == (0.01, 0.02)
    d = scene(radius_law="discrete", radii=(0.01, 0.03), fractions=(1.0, 0.0))
    assert (d.r_min, d.r_max, d.r_mean, d.r_std) == (0.01, 0.01, 0.01, 0.0)
    u = scene(radius_law="uniform", r_min=0.01, r_max=0.03)
    assert u.r_mean == pytest.approx(0.02) and u.r_std == pytest.approx(0.02 / math.sqrt(12))
    ln = scene(radius_law="lognormal", r_mean=0.02, r_std=0.004)
    s2 = math.log1p(0.04)
    mu = math.log(0.02) - s2 / 2
    assert ln.r_min == pytest.approx(math.exp(mu - 3 * math.sqrt(s2)), rel=1e-14)
    assert ln.r_max == pytest.approx(math.exp(mu + 3 * math.sqrt(s2)), rel=1e-14)
    # r_min sets the time step's check
    fine = scene(radius_law="uniform", r_min=1e-4, r_max=0.03, dt=1e-6)
    with pytest.raises(gp.InvalidParameterError, match="invalid dt"):
        fine.replace(dt=1e-4)


def test_a_sieve_scene_round_trips_through_toml(tmp_path):
    s = gp.PackScene(**SIEVE)
    assert gp.PackScene.from_toml_string(s.to_toml()) == s
    text = (
        'preset = "4.3"\nradius_law = "sieve"\nsieve_sizes = [0.02, 0.03, 0.05, 0.08]\n'
        "sieve_passing = [0.0, 0.3, 0.7, 1.0]\n"
    )
    t = gp.PackScene.from_toml_string(text)
    assert t.sieve_sizes == (0.02, 0.03, 0.05, 0.08) and t.r_max == 0.04
    d = gp.PackScene(
        dim=3,
        base=(0.5, 0.5),
        radius_law="discrete",
        radii=[0.01, 0.02],
        fractions=[0.4, 0.6],
        fractions_by="mass",
        phi_layer=0.25,
    )
    assert gp.PackScene.from_toml_string(d.to_toml()) == d


# -- bad input, refused by name ---------------------------------------------------------------
SIEVE_LAW = {"radius_law": "sieve", "sieve_sizes": (0.02, 0.03, 0.05, 0.08)}
DISCRETE_LAW = {"radius_law": "discrete", "radii": (0.01, 0.02)}


@pytest.mark.parametrize(
    ("changes", "name"),
    [
        ({**SIEVE_LAW, "sieve_passing": (0.0, 0.5, 0.4, 1.0)}, r"sieve_passing\[2\].*not decrease"),
        ({**SIEVE_LAW, "sieve_passing": (0.1, 0.3, 0.7, 1.0)}, r"sieve_passing\[0\].*must be 0"),
        ({**SIEVE_LAW, "sieve_passing": (0.0, 0.3, 0.7, 0.9)}, r"sieve_passing\[3\].*must be 1"),
        ({**SIEVE_LAW, "sieve_passing": (0.0, 0.3, 1.0)}, "sieve_passing.*one passing fraction"),
        (
            {
                **SIEVE_LAW,
                "sieve_sizes": (0.02, 0.05, 0.03, 0.08),
                "sieve_passing": (0, 0.3, 0.7, 1),
            },
            r"sieve_sizes\[2\].*strictly increasing",
        ),
        (
            {
                **SIEVE_LAW,
                "sieve_sizes": (0.0, 0.03, 0.05, 0.08),
                "sieve_passing": (0, 0.3, 0.7, 1),
            },
            r"sieve_sizes\[0\].*> 0",
        ),
        ({"radius_law": "sieve"}, "sieve_sizes.*needs"),
        ({**SIEVE_LAW, "sieve_passing": ("a", 0, 0, 1)}, r"sieve_passing\[0\].*real number"),
        ({**DISCRETE_LAW, "radii": (0.02, 0.01), "fractions": (0.5, 0.5)}, r"radii\[1\]"),
        ({**DISCRETE_LAW, "radii": (-0.01, 0.01), "fractions": (0.5, 0.5)}, r"radii\[0\].*> 0"),
        ({**DISCRETE_LAW, "fractions": (1.2, -0.2)}, r"fractions\[1\].*>= 0"),
        ({**DISCRETE_LAW, "fractions": (0.5, 0.5 + 2e-9)}, "fractions.*sum to 1 within 1e-9"),
        ({**DISCRETE_LAW, "fractions": (0.5, 0.5), "fractions_by": "volume"}, "fractions_by"),
        ({**DISCRETE_LAW, "fractions": (0.5, 0.5), "fractions_by": 3}, "fractions_by"),
        ({"radius_law": "gaussian", "r_mean": 0.02, "r_std": -0.001}, "r_std.*>= 0"),
        ({"radius_law": "lognormal", "r_mean": 0.02, "r_std": -0.001}, "r_std.*>= 0"),
        (
            {
                "radius_law": "lognormal",
                "r_mean": 0.01,
                "r_std": 0.001,
                "r_min": 0.05,
                "r_max": 0.06,
            },
            "r_min.*holds no mass",
        ),
        (
            {
                "radius_law": "lognormal",
                "r_mean": 0.02,
                "r_std": 0.001,
                "r_min": 1e-3,
                "r_max": 5e-3,
            },
            "r_max.*holds no mass",
        ),
        ({"radius_law": "uniform", "r_min": 0.02}, "r_max.*needs r_min and r_max"),
        ({"radius_law": "uniform", "r_min": 0.02, "r_max": 0.01}, "r_max.*>= r_min"),
        ({"radius_law": "gaussian", "radii": (0.01,)}, "radii.*only radius_law"),
        ({"radius_law": "weibull"}, "radius_law"),
    ],
)
def test_bad_size_input_is_refused_by_name(changes, name):
    with pytest.raises(gp.InvalidParameterError, match=name) as e:
        scene(**changes)
    # the parameter attribute names the key as the user wrote it
    key = name.split(".")[0].replace("\\", "")
    assert e.value.parameter is not None and e.value.parameter in key


def test_the_engine_refuses_what_the_scene_refuses():
    """The same Rust checks run at LayerPacker(scene): a scene object that bypassed its
    own construction is still refused by name."""
    s = scene(**SIEVE_LAW, sieve_passing=(0.0, 0.3, 0.7, 1.0))
    object.__setattr__(s, "sieve_passing", (0.0, 0.8, 0.7, 1.0))
    with pytest.raises(gp.InvalidParameterError, match=r"sieve_passing\[2\]"):
        _core.LayerPacker(s)
    object.__setattr__(s, "sieve_passing", (0.0, 0.3, 0.7, 1.0))
    object.__setattr__(s, "settle_tol", -1.0)
    with pytest.raises(gp.InvalidParameterError, match="settle_tol"):
        _core.LayerPacker(s)


# -- grading ----------------------------------------------------------------------------------
def test_the_target_grading_of_a_sieve_curve_is_read_log_linearly():
    g = gp.target_grading(gp.PackScene(**SIEVE))
    sizes, passing = (0.02, 0.03, 0.05, 0.08), (0.0, 0.3, 0.7, 1.0)

    def read(x):
        k = np.searchsorted(passing, x) - 1
        t = (x - passing[k]) / (passing[k + 1] - passing[k])
        return sizes[k] * (sizes[k + 1] / sizes[k]) ** t

    for f in (10, 30, 50, 60, 90):
        assert getattr(g, f"d{f}_mass") == pytest.approx(read(f / 100), rel=1e-6)
    assert g.cu_mass == pytest.approx(read(0.6) / read(0.1), rel=1e-6)
    assert g.cc_mass == pytest.approx(read(0.3) ** 2 / (read(0.1) * read(0.6)), rel=1e-6)
    # by number the small grains dominate
    assert g.d50_number < g.d50_mass


def test_grading_of_simple_sets():
    g = gp.realised_grading(np.full(10, 0.01), dim=3)
    assert g.d10_mass == g.d90_number == 0.02 and g.cu_mass == g.cc_number == 1.0
    r = np.array([0.01] * 8 + [0.02])  # equal masses in 3D
    g = gp.realised_grading(r, dim=3)
    # D_x: the smallest diameter at which the cumulative fraction reaches x
    assert (g.d30_mass, g.d50_mass, g.d60_mass) == (0.02, 0.02, 0.04)
    assert (g.d10_number, g.d90_number) == (0.02, 0.04)
    # in 2D with discs of unit thickness the mass goes with the area
    g2 = gp.realised_grading(np.array([0.01] * 4 + [0.02]), dim=2, inertia_2d="disc")
    assert (g2.d50_mass, g2.d60_mass) == (0.02, 0.04)
    assert set(g.to_dict()) >= {"d10_mass", "cu_mass", "cc_mass", "d50_number", "cu_number"}
    uniform = gp.target_grading(scene(radius_law="uniform", r_min=0.01, r_max=0.03))
    assert uniform.d50_number == pytest.approx(0.04, rel=1e-7)
    assert uniform.d10_number == pytest.approx(0.024, rel=1e-7)
    with pytest.raises(gp.InvalidParameterError, match="radii"):
        gp.realised_grading(np.array([0.01, -1.0]))


# -- a sieve-curve pack -------------------------------------------------------------------------
@pytest.fixture(scope="module")
def sieve_pack():
    s = gp.PackScene(**SIEVE).replace(base=(0.3, 0.3), height=0.15, seed=4)
    return gp.generate(s)


def test_a_sieve_pack_meets_its_curve_within_the_dkw_band(sieve_pack):
    """By mass, against the sieve curve itself: the band uses the mass-weighted
    sample's effective size (sum m)^2 / sum m^2."""
    r = sieve_pack.radii
    assert len(r) > 150
    m = r**3
    n_eff = m.sum() ** 2 / np.sum(m * m)
    sizes = np.array(SIEVE["sieve_sizes"])
    fine = np.exp(np.linspace(np.log(sizes[0]), np.log(sizes[-1]), 200))
    realised = passing(sieve_pack, fine)
    target = target_passing(sieve_pack.scene, fine)
    assert np.max(np.abs(realised - target)) < dkw(n_eff)
    assert np.allclose(target_passing(sieve_pack.scene, sizes), SIEVE["sieve_passing"])
    g, t = gp.realised_grading(sieve_pack), gp.target_grading(sieve_pack.scene)
    assert g.d50_mass == pytest.approx(t.d50_mass, rel=0.2)


def test_the_grading_figure_draws_the_realised_and_the_target_curve(sieve_pack, tmp_path):
    from granpack.plot import grading_figure, save

    fig = grading_figure(sieve_pack, title="sieve pack")
    ax = fig.axes[0]
    assert ax.get_xscale() == "log"
    labels = [line.get_label() for line in ax.get_lines()]
    assert any(lab.startswith("realised") for lab in labels)
    assert any(lab.startswith("target (sieve)") for lab in labels)
    assert "sieve curve" in labels
    # the realised curve rises from 0 to 100 %
    y = ax.get_lines()[0].get_ydata()
    assert y[0] == 0 and y[-1] == pytest.approx(100)
    assert save(fig, tmp_path / "grading.png").stat().st_size > 1000
    # bare radii, no target
    assert len(grading_figure(sieve_pack.radii, dim=3).axes[0].get_lines()) == 1


def test_the_microstructure_and_the_report_carry_the_grading(sieve_pack):
    from granpack.report import _grading_lines

    d = gp.microstructure(sieve_pack, core_margin=0.02).to_dict()
    g = gp.realised_grading(sieve_pack).to_dict()
    assert {k: d[k] for k in g} == g
    lines = _grading_lines(sieve_pack.scene, [d, d])
    assert any(line.startswith("| realised |") for line in lines)
    target = gp.target_grading(sieve_pack.scene)
    assert f"{target.d50_mass:.4f}" in next(x for x in lines if x.startswith("| target |"))


THREAD_SCRIPT = textwrap.dedent(
    """
    import hashlib, granpack as gp
    scene = gp.PackScene(
        dim=3, base=(0.25, 0.25), height=0.12, radius_law="sieve", phi_layer=0.25,
        sieve_sizes=[0.01, 0.015, 0.025, 0.04], sieve_passing=[0.0, 0.3, 0.7, 1.0],
        settle_time=0.15, dt=5e-5, seed=3,
    )
    p = gp.generate(scene)
    h = hashlib.sha256()
    for a in (p.positions, p.radii, p.velocities, p.spins, p.contacts.force_normal):
        h.update(a.tobytes())
    print(len(p), h.hexdigest())
    """
)


def test_a_sieve_pack_is_bit_identical_on_one_and_two_threads():
    out = {}
    for threads in ("1", "2"):
        env = {**os.environ, "RAYON_NUM_THREADS": threads}
        res = subprocess.run(
            [sys.executable, "-c", THREAD_SCRIPT],
            env=env,
            capture_output=True,
            text=True,
            check=True,
        )
        out[threads] = res.stdout.split()
    assert int(out["1"][0]) > 512  # more than one parallel chunk
    assert out["1"] == out["2"]


# -- the presets unchanged --------------------------------------------------------------------
# sha256 of the positions' bytes, recorded from the code before the new laws (4.2 with
# sphere mass, the 2D default when they were recorded)
PRESET_HASHES = {
    "4.2": (
        {"height": 0.15, "inertia_2d": "sphere"},
        "3b1e4c77077a68036fb620f74a6df3bb4261b61ec18de2dc639f91a548f8125c",
    ),
    "4.4": (
        {"base": (0.3, 0.3), "height": 0.12},
        "a1fe0c23e15dca6d36d965621fa3c6f6e38c186450946bf22498dfd6d87221b3",
    ),
}


@pytest.mark.parametrize("name", list(PRESET_HASHES))
def test_the_gaussian_presets_give_the_same_bits_as_before(name):
    changes, expected = PRESET_HASHES[name]
    p = gp.generate(gp.PackScene.preset(name).replace(**changes))
    assert hashlib.sha256(np.ascontiguousarray(p.positions).tobytes()).hexdigest() == expected
