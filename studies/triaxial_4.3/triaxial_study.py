"""Drained triaxial compression, its loading rate and an oedometer test on the paper's
example 4.3.

Four studies, each writing into its own subfolder of this folder:

- ``samples``: example 4.3 (seed 1, ``fast()``, in the box) consolidated isotropically
  to 100 kPa at relative densities Dr = 0.2 and 0.8 (``target_relative_density`` on the
  scene: e_min and e_max of this seed's packs under the same consolidation). The two
  targets share the search's packs (the window's grid is measured once). The samples
  are written as ``samples/dr_0.2.npz`` and ``samples/dr_0.8.npz`` (or under /tmp where
  they exceed 5 MB; ``samples/summary.md`` says where).
- ``triaxial``: ``granpack.triaxial`` of both samples to axial strain 0.25 at inertial
  number I = 1e-3: a table per sample (CSV), the figure (q, eps_v and fabric against
  eps_a) and the lab quantities (``summary.md``).
- ``rate``: the same tests at I = 1e-4. ``rate --sample dr_0.2`` runs one (each takes
  about ten times the I = 1e-3 test: run them in the background); ``rate --report``
  sets them beside the I = 1e-3 tests (``triaxial/``).
- ``oedometer``: the Dr = 0.2 sample loaded to 25, 50, 100, 200, 400 kPa and unloaded to
  200, 100, 50 kPa: e against log sigma_v (figure), Cc, Cs and K0 per step.

    python studies/triaxial_4.3/triaxial_study.py samples
    python studies/triaxial_4.3/triaxial_study.py triaxial
    python studies/triaxial_4.3/triaxial_study.py rate --sample dr_0.2   # and dr_0.8
    python studies/triaxial_4.3/triaxial_study.py rate --report
    python studies/triaxial_4.3/triaxial_study.py oedometer

Timings are taken with one thread (RAYON_NUM_THREADS=1, set here where unset).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
import time
import warnings
from pathlib import Path

os.environ.setdefault("RAYON_NUM_THREADS", "1")

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from manifest import cpu_model, write_manifest  # noqa: E402

import granpack as gp  # noqa: E402
from granpack import density as _density  # noqa: E402
from granpack.element.figures import compression_figure, triaxial_figure  # noqa: E402
from granpack.element.lab import eps_v_at, triaxial_report  # noqa: E402

RESULTS = Path(__file__).resolve().parent
STRESS = 1e5
SAMPLES = {"dr_0.2": 0.2, "dr_0.8": 0.8}
LABELS = {"dr_0.2": "Dr 0.2 (loose)", "dr_0.8": "Dr 0.8 (dense)"}
AXIAL_STRAIN = 0.25
OEDOMETER = (25e3, 50e3, 100e3, 200e3, 400e3, 200e3, 100e3, 50e3)
MAX_NPZ = 5 * 2**20


def _scene(dr: float) -> gp.PackScene:
    return (
        gp.PackScene.preset("4.3")
        .replace(
            seed=1,
            consolidate={"stress": STRESS, "mode": "isotropic"},
            target_relative_density=dr,
        )
        .fast()
    )


def _threads() -> str:
    return os.environ.get("RAYON_NUM_THREADS", "")


def _machine() -> str:
    return (
        f"CPU: {cpu_model()}, {os.cpu_count()} logical CPUs; "
        f"RAYON_NUM_THREADS={_threads()}; load average at the end "
        f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}"
    )


def _write_csv(path: Path, rows: list[dict]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    tmp = path.with_suffix(path.suffix + ".tmp")
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows([{k: r.get(k, "") for k in keys} for r in rows])
    os.replace(tmp, path)


def _write_text(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def _fmt(v, nd=3) -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        if not math.isfinite(v):
            return "-"
        return f"{v:.{nd}f}"
    return str(v)


# ---------------------------------------------------------------------------- samples


def _shared_runs():
    """Makes every target's search in this process share one set of packs: the window
    (the grid of deposition frictions and the servo's end) is the same for both targets
    of one scene and seed, and is measured once. The packs are made exactly as each
    search alone would make them."""
    original = _density._Runs
    shared: dict[str, object] = {}

    class Shared(original):  # type: ignore[misc, valid-type]
        def __new__(cls, scene, key, value, progress):
            runs = shared.get("runs")
            if runs is None:
                runs = object.__new__(cls)
                original.__init__(runs, scene, key, value, progress)
                shared["runs"] = runs
            else:
                runs.key, runs.value = key, value
            return runs

        def __init__(self, *args, **kwargs):
            pass

    _density._Runs = Shared
    return shared


def samples(args) -> None:
    out = RESULTS / "samples"
    shared = _shared_runs()
    rows = []
    for name in args.samples:
        dr = SAMPLES[name]
        t = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            pack = gp.generate(_scene(dr))
        secs = time.perf_counter() - t
        d = pack.record("density").table()
        c = pack.record("consolidate")
        m = gp.microstructure(pack)
        path = out / f"{name}.npz"
        pack.save(path)
        size = path.stat().st_size
        if size > MAX_NPZ:
            tmp = Path("/tmp/triaxial_4.3") / path.name
            tmp.parent.mkdir(parents=True, exist_ok=True)
            os.replace(path, tmp)
            path = tmp
        runs = shared.get("runs")
        row = {
            "sample": name,
            "target_dr": dr,
            "method": d["method"],
            "friction": d["friction"],
            "phi": d["phi"],
            "void_ratio": d["void_ratio"],
            "relative_density": d.get("relative_density"),
            "e_min": d.get("e_min"),
            "e_max": d.get("e_max"),
            "n": len(pack),
            "z": m.z,
            "a_r": m.a_r_mag,
            "k0": c.report.get("k0"),
            "wall_stress": json.dumps(c.report.get("wall_stress")),
            "gravity": c.settings.get("gravity"),
            "mode": c.settings.get("mode"),
            "generations_so_far": runs.generations if runs is not None else d["generations"],
            "seconds": secs,
            "npz": str(
                path
                if path.is_absolute() and not path.is_relative_to(RESULTS)
                else path.relative_to(RESULTS)
            ),
            "npz_bytes": size,
            "warnings": "; ".join(
                str(w.message) for w in caught if not isinstance(w.message, gp.UnsettledPackWarning)
            ),
            "history": json.dumps(d["history"], default=float),
        }
        print(json.dumps({k: v for k, v in row.items() if k != "history"}), flush=True)
        rows.append(row)
        _write_csv(out / f"runs_{name}.csv", [row])
    _write_csv(out / "runs.csv", _read_rows(out, [f"runs_{n}.csv" for n in SAMPLES]))
    _samples_summary(out)
    write_manifest(out, seeds=[1], extra={"rayon_num_threads": _threads()})


def _read_rows(folder: Path, names: list[str]) -> list[dict]:
    rows = []
    for n in names:
        p = folder / n
        if p.exists():
            with open(p) as f:
                rows += list(csv.DictReader(f))
    return rows


def _samples_summary(out: Path) -> None:
    rows = _read_rows(out, ["runs.csv"])
    lines = [
        "# The two samples: example 4.3 consolidated isotropically to 100 kPa",
        "",
        "`python studies/triaxial_4.3/triaxial_study.py samples`: example 4.3, seed 1, "
        '`fast()`, in the box, `consolidate = {stress = 1e5, mode = "isotropic"}`, '
        '`target_relative_density` 0.2 and 0.8 (`density_method = "auto"`). e_min and '
        "e_max are this seed's, measured under the same consolidation (the grid of "
        "deposition frictions and the servo's zero-friction end); both targets' searches "
        "share those packs. phi is the sample's, between the walls.",
        "",
        "| sample | method | mu_dep | phi | e | Dr | e_min | e_max | Z | \\|a^r\\| | K0 | "
        "gravity | packs generated (cumulative) | seconds | npz |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            "| "
            + " | ".join(
                [
                    r["sample"],
                    r["method"],
                    f"{float(r['friction']):.3f}",
                    f"{float(r['phi']):.4f}",
                    f"{float(r['void_ratio']):.4f}",
                    f"{float(r['relative_density']):.3f}" if r["relative_density"] else "-",
                    f"{float(r['e_min']):.4f}" if r["e_min"] else "-",
                    f"{float(r['e_max']):.4f}" if r["e_max"] else "-",
                    f"{float(r['z']):.3f}",
                    f"{float(r['a_r']):.3f}",
                    f"{float(r['k0']):.3f}" if r["k0"] else "-",
                    r["gravity"],
                    r["generations_so_far"],
                    f"{float(r['seconds']):.0f}",
                    f"`{r['npz']}` ({int(r['npz_bytes']) / 2**20:.1f} MiB)",
                ]
            )
            + " |"
        )
    lines += ["", _machine(), ""]
    _write_text(out / "summary.md", "\n".join(lines))


def _load(name: str) -> gp.Pack:
    row = _read_rows(RESULTS / "samples", [f"runs_{name}.csv"])
    if not row:
        raise SystemExit(f"no sample {name}: run `triaxial_study.py samples` first")
    p = Path(row[0]["npz"])
    return gp.load_pack(p if p.is_absolute() else RESULTS / p)


# --------------------------------------------------------------------------- triaxial


def _shear(name: str, inertial: float, out: Path) -> dict:
    pack = _load(name)
    t = time.perf_counter()
    done = gp.triaxial(pack, inertial_number=inertial, axial_strain=AXIAL_STRAIN)
    wall = time.perf_counter() - t
    table = gp.element_table(done, "triaxial")
    rec = done.record("triaxial")
    tag = f"{name}_I{inertial:g}"
    table.write_csv(out / f"table_{tag}.csv")
    row = {
        "sample": name,
        "inertial_number": inertial,
        "steps": rec.steps,
        "reseat_steps": rec.settings["reseat_steps"],
        "dt": rec.settings["dt"],
        "strain_rate": rec.settings["strain_rate"],
        "gravity": rec.settings["gravity"],
        "test_seconds": rec.seconds,
        "wall_seconds": wall,
        "rayon_num_threads": _threads(),
        "load_average_1min": os.getloadavg()[0],
        "lab": json.dumps(rec.report["lab"], default=float),
    }
    _write_csv(out / f"run_{tag}.csv", [row])
    print(json.dumps({k: v for k, v in row.items() if k != "lab"}), flush=True)
    return row


def _table(out: Path, name: str, inertial: float):
    import polars as pl

    p = out / f"table_{name}_I{inertial:g}.csv"
    return pl.read_csv(p) if p.exists() else None


def triaxial(args) -> None:
    out = RESULTS / "triaxial"
    out.mkdir(parents=True, exist_ok=True)
    for name in args.samples:
        _shear(name, 1e-3, out)
    _triaxial_report(out)
    write_manifest(out, seeds=[1], extra={"rayon_num_threads": _threads()})


def _triaxial_report(out: Path) -> None:
    tables = {LABELS[n]: t for n in SAMPLES if (t := _table(out, n, 1e-3)) is not None}
    triaxial_figure(tables, out / "triaxial.png", dim=3)
    lines = [
        "# Drained triaxial compression of example 4.3 at 100 kPa, I = 1e-3",
        "",
        "`python studies/triaxial_4.3/triaxial_study.py triaxial`: `granpack.triaxial` of "
        "the two samples of `../samples/` to axial strain 0.25 at inertial number 1e-3, "
        "sigma_3 = 100 kPa (the consolidation's), smooth walls, local damping 0.4. The lab "
        "quantities are `granpack.element.lab.triaxial_report`'s (phi_cs: the mean over the "
        "last 20 % of the axial strain; psi_max over a 2 % window; E_50 secant to half the "
        "largest deviator rise). Tables: `table_<sample>_I0.001.csv`; figure: "
        "`triaxial.png`.",
        "",
        "| sample | e (Dr) at the start | phi_p (deg) | eps_a at phi_p | phi_cs (deg) | "
        "eta_cs | psi_max (deg) | E_50 (MPa) | marked peak | eps_v at 10 % | "
        "eps_v at the end | e at the end | steps | test s | wall s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name in SAMPLES:
        run = _read_rows(out, [f"run_{name}_I0.001.csv"])
        t = _table(out, name, 1e-3)
        if not run or t is None:
            continue
        r = run[0]
        lab = json.loads(r["lab"])
        lines.append(
            f"| {LABELS[name]} | {t['e'][0]:.4f} ({_dr(t['e'][0]):.2f}) | "
            f"{_fmt(lab['phi_peak'], 2)} | {_fmt(lab['eps_a_peak'], 4)} | "
            f"{_fmt(lab['phi_cs'], 2)} | {_fmt(lab['eta_cs'], 3)} | "
            f"{_fmt(lab['psi_max'], 2)} | "
            f"{_fmt(lab['E_50'] / 1e6 if lab['E_50'] else None, 1)} | {_fmt(lab['peak'])} | "
            f"{_fmt(eps_v_at(t, 0.10), 4)} | {_fmt(lab['eps_v_end'], 4)} | "
            f"{t['e'][-1]:.4f} | {r['steps']} | "
            f"{float(r['test_seconds']):.0f} | {float(r['wall_seconds']):.0f} |"
        )
    lines += [
        "",
        "eps_v is compression-positive: a negative value is a dilation.",
        "",
        "![triaxial](triaxial.png)",
        "",
        _machine(),
        "",
    ]
    _write_text(out / "summary.md", "\n".join(lines))


# ------------------------------------------------------------------------------- rate


def rate(args) -> None:
    out = RESULTS / "rate"
    out.mkdir(parents=True, exist_ok=True)
    if not args.report:
        for name in args.samples:
            _shear(name, 1e-4, out)
    _rate_report(out)
    write_manifest(
        out,
        seeds=[1],
        extra={"rayon_num_threads": _threads()},
        name="manifest.json" if args.report else f"manifest_{'_'.join(args.samples)}.json",
    )


def _rate_report(out: Path) -> None:
    tri = RESULTS / "triaxial"
    rows = []
    tables = {}
    for name in SAMPLES:
        for inertial, folder in ((1e-3, tri), (1e-4, out)):
            t = _table(folder, name, inertial)
            run = _read_rows(folder, [f"run_{name}_I{inertial:g}.csv"])
            if t is None or not run:
                continue
            tables[f"{LABELS[name]}, I = {inertial:g}"] = t
            lab = triaxial_report(t, 3)
            rows.append(
                {
                    "sample": name,
                    "inertial_number": inertial,
                    "e_start": t["e"][0],
                    "phi_peak": lab["phi_peak"],
                    "eps_a_peak": lab["eps_a_peak"],
                    "phi_cs": lab["phi_cs"],
                    "psi_max": lab["psi_max"],
                    "E_50": lab["E_50"],
                    "eps_v_10": eps_v_at(t, 0.10),
                    "eps_v_end": lab["eps_v_end"],
                    "steps": run[0]["steps"],
                    "wall_seconds": run[0]["wall_seconds"],
                }
            )
    if not rows:
        return
    _write_csv(out / "rate.csv", rows)
    if tables:
        triaxial_figure(tables, out / "rate.png", dim=3)
    lines = [
        "# The loading rate: I = 1e-4 beside I = 1e-3",
        "",
        "`python studies/triaxial_4.3/triaxial_study.py rate --sample dr_0.2` (and "
        "`dr_0.8`), then `rate --report`: the two samples of `../samples/` sheared as in "
        "`../triaxial/`, at I = 1e-4 (ten times slower). The criterion: phi_p within "
        "0.5 degree of the I = 1e-3 value.",
        "",
        "| sample | I | e at the start | phi_p (deg) | eps_a at phi_p | phi_cs (deg) | "
        "psi_max (deg) | E_50 (MPa) | eps_v at 10 % | eps_v at the end | steps | wall s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {LABELS[r['sample']]} | {r['inertial_number']:g} | {r['e_start']:.4f} | "
            f"{_fmt(r['phi_peak'], 2)} | "
            f"{_fmt(r['eps_a_peak'], 4)} | {_fmt(r['phi_cs'], 2)} | {_fmt(r['psi_max'], 2)} | "
            f"{_fmt(r['E_50'] / 1e6 if r['E_50'] else None, 1)} | {_fmt(r['eps_v_10'], 4)} | "
            f"{_fmt(r['eps_v_end'], 4)} | {r['steps']} | {float(r['wall_seconds']):.0f} |"
        )
    lines += [
        "",
        "| sample | phi_p(1e-4) - phi_p(1e-3) (deg) | phi_cs(1e-4) - phi_cs(1e-3) "
        "(deg) | within 0.5 deg |",
        "|---|---|---|---|",
    ]
    for name in SAMPLES:
        a = [r for r in rows if r["sample"] == name and r["inertial_number"] == 1e-3]
        b = [r for r in rows if r["sample"] == name and r["inertial_number"] == 1e-4]
        if a and b:
            dp = b[0]["phi_peak"] - a[0]["phi_peak"]
            dc = b[0]["phi_cs"] - a[0]["phi_cs"]
            lines.append(
                f"| {LABELS[name]} | {dp:+.2f} | {dc:+.2f} | {'yes' if abs(dp) <= 0.5 else 'no'} |"
            )
    lines += ["", "![rate](rate.png)", "", _machine(), ""]
    _write_text(out / "summary.md", "\n".join(lines))


# ----------------------------------------------------------------------------- reseat


def _window() -> tuple[float, float]:
    r = _read_rows(RESULTS / "samples", ["runs.csv"])[0]
    return float(r["e_min"]), float(r["e_max"])


def _dr(e: float) -> float:
    e_min, e_max = _window()
    return (e_max - e) / (e_max - e_min)


def reseat(args) -> None:
    """What the tests' reseat does to each sample: e as consolidated and at the first row
    of a triaxial test (the sample brought back to equilibrium at the consolidation's
    targets), with smooth walls (the tests' default) and with the material's friction on
    the walls (the consolidation's). A test 1e-4 long is enough: its first row is the
    reseated sample."""
    out = RESULTS / "reseat"
    rows = []
    for name in args.samples:
        pack = _load(name)
        rec = pack.record("consolidate")
        e0 = 1.0 / rec.report["phi"] - 1.0
        for wf in (0.0, None):
            done = gp.triaxial(pack, axial_strain=1e-4, checks=2, wall_friction=wf)
            t = gp.element_table(done, "triaxial")
            first = t.row(0, named=True)
            rows.append(
                {
                    "sample": name,
                    "wall_friction": "material's" if wf is None else wf,
                    "e_consolidated": e0,
                    "dr_consolidated": _dr(e0),
                    "floor_kpa_consolidated": rec.report["wall_stress"]["floor"] / 1e3,
                    "e_reseated": first["e"],
                    "dr_reseated": _dr(first["e"]),
                    "z_reseated": first["z"],
                    "reseat_steps": done.record("triaxial").settings["reseat_steps"],
                }
            )
            print(json.dumps(rows[-1]), flush=True)
    _write_csv(out / "runs.csv", rows)
    lines = [
        "# The reseat: the sample at the start of a test against the sample as consolidated",
        "",
        "`python studies/triaxial_4.3/triaxial_study.py reseat`: each sample of "
        "`../samples/` sheared by 1e-4 (`granpack.triaxial`, I = 1e-3), its first row "
        "being the sample brought back to equilibrium at the consolidation's targets "
        "before the lid moves; smooth walls (the tests' default, `wall_friction=0`) and "
        "the material's friction on the walls (`wall_friction=None`, as in the "
        "consolidation). Dr from this seed's e_min and e_max (`../samples/`).",
        "",
        "| sample | walls | e consolidated | Dr | floor (kPa) as consolidated | e reseated | "
        "Dr reseated | Z reseated | reseat steps |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {LABELS[r['sample']]} | {r['wall_friction']} | {r['e_consolidated']:.4f} | "
            f"{r['dr_consolidated']:.3f} | {r['floor_kpa_consolidated']:.1f} | "
            f"{r['e_reseated']:.4f} | {r['dr_reseated']:.3f} | {r['z_reseated']:.3f} | "
            f"{r['reseat_steps']} |"
        )
    lines += ["", _machine(), ""]
    _write_text(out / "summary.md", "\n".join(lines))
    write_manifest(out, seeds=[1], extra={"rayon_num_threads": _threads()})


# -------------------------------------------------------------------------- oedometer


#: the oedometer's other sample: example 4.3's recipe deposit consolidated oedometrically
#: to the first stress of the path, so that its loading branch is virgin from the start
OED_25 = "oed_25kpa"


def _oedometric_sample() -> tuple[gp.Pack, float]:
    scene = (
        gp.PackScene.preset("4.3")
        .replace(seed=1, consolidate={"stress": OEDOMETER[0], "mode": "oedometric"})
        .fast()
    )
    t = time.perf_counter()
    pack = gp.generate(scene)
    secs = time.perf_counter() - t
    path = Path("/tmp/triaxial_4.3") / f"{OED_25}.npz"
    path.parent.mkdir(parents=True, exist_ok=True)
    pack.save(path)
    return pack, secs


def oedometer(args) -> None:
    out = RESULTS / ("oedometer" if args.sample != OED_25 else "oedometer_25kpa")
    out.mkdir(parents=True, exist_ok=True)
    made = None
    if args.sample == OED_25:
        pack, made = _oedometric_sample()
    else:
        pack = _load(args.sample)
    consolidated = pack.record("consolidate")
    t = time.perf_counter()
    done = gp.oedometer(pack, list(OEDOMETER))
    wall = time.perf_counter() - t
    rec = done.record("oedometer")
    table = gp.element_table(done, "oedometer")
    table.write_csv(out / f"table_{args.sample}.csv")
    lab = rec.report["lab"]
    (out / "lab.json").write_text(json.dumps(lab, indent=1, default=float) + "\n")
    label = LABELS.get(args.sample, "recipe, oedometric 25 kPa")
    compression_figure({label: table}, out / "e_log_sigma.png")
    if args.sample == OED_25:
        what = (
            "`python studies/triaxial_4.3/triaxial_study.py oedometer --sample oed_25kpa`: "
            "example 4.3's recipe deposit (seed 1, `fast()`, mu_dep = the material's 0.2) "
            "consolidated oedometrically to 25 kPa (`consolidate = {stress = 25e3, mode = "
            f'"oedometric"}}`; {made:.0f} s for the generation and consolidation; '
            f"e = {1.0 / consolidated.report['phi'] - 1.0:.4f}, gravity "
            f"{consolidated.settings['gravity']}; the pack is written to /tmp only, it is "
            "made again by this command), then "
        )
    else:
        what = (
            "`python studies/triaxial_4.3/triaxial_study.py oedometer`: the isotropically "
            "consolidated Dr 0.2 sample of `../samples/` (100 kPa on every wall), then "
        )
    lines = [
        f"# Oedometric loading and unloading of example 4.3 ({label})",
        "",
        what + "its side "
        "walls fixed, the lid's servo taken to 25, 50, 100, 200, 400 kPa and back to "
        "200, 100, 50 kPa, each held to equilibrium (`granpack.oedometer`, smooth walls). "
        "Cc and Cs are `granpack.element.lab.compression_report`'s (Cc over the loading "
        "branch's virgin rows, from the second on; Cs over the unloading branch).",
        "",
        f"Start (the sample reseated): sigma_1 = {rec.report['start']['sigma_1'] / 1e3:.1f} "
        f"kPa, sigma_3 = {rec.report['start']['sigma_3'] / 1e3:.1f} kPa, "
        f"e = {rec.report['start']['e']:.4f}.",
        "",
        "| row | target (kPa) | sigma_v (kPa) | sigma_h (kPa) | e | K0 | steps (cumulative) |",
        "|---|---|---|---|---|---|---|",
    ]
    for k, r in enumerate(table.iter_rows(named=True)):
        lines.append(
            f"| {k} | {r['target'] / 1e3:.0f} | {r['sigma_1'] / 1e3:.1f} | "
            f"{r['sigma_3'] / 1e3:.1f} | {r['e']:.4f} | {r['k0']:.3f} | {r['step']} |"
        )
    lines += [
        "",
        f"Cc = {_fmt(lab['Cc'], 4)} (virgin rows {lab['virgin_rows']}), Cs = "
        f"{_fmt(lab['Cs'], 4)} (unloading rows {lab['unloading_rows']}), K0 over the "
        f"virgin rows = {_fmt(lab['k0_virgin'], 3)}; lambda = {_fmt(lab['lambda_ln'], 4)}, "
        f"kappa = {_fmt(lab['kappa_ln'], 4)}.",
        "",
        f"Steps {rec.steps} (reseat {rec.settings['reseat_steps']}), dt "
        f"{rec.settings['dt']:.3g} s, gravity {rec.settings['gravity']}; test "
        f"{rec.seconds:.0f} s, wall {wall:.0f} s.",
        "",
        "![e against log sigma_v](e_log_sigma.png)",
        "",
        _machine(),
        "",
    ]
    _write_text(out / "summary.md", "\n".join(lines))
    write_manifest(out, seeds=[1], extra={"rayon_num_threads": _threads()})


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="study", required=True)
    s = sub.add_parser("samples")
    s.add_argument("--samples", nargs="+", choices=list(SAMPLES), default=list(SAMPLES))
    t = sub.add_parser("triaxial")
    t.add_argument("--samples", nargs="+", choices=list(SAMPLES), default=list(SAMPLES))
    t.add_argument("--report", action="store_true")
    r = sub.add_parser("rate")
    r.add_argument(
        "--sample", dest="samples", nargs="+", choices=list(SAMPLES), default=list(SAMPLES)
    )
    r.add_argument("--report", action="store_true", help="only set the runs side by side")
    rs = sub.add_parser("reseat")
    rs.add_argument("--samples", nargs="+", choices=list(SAMPLES), default=list(SAMPLES))
    o = sub.add_parser("oedometer")
    o.add_argument("--sample", default="dr_0.2", choices=[*SAMPLES, OED_25])
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore", gp.UnsettledPackWarning)
    if args.study == "triaxial" and args.report:
        _triaxial_report(RESULTS / "triaxial")
        return 0
    {
        "samples": samples,
        "triaxial": triaxial,
        "rate": rate,
        "reseat": reseat,
        "oedometer": oedometer,
    }[args.study](args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
