"""Density targets on the paper's example 4.3: what each mechanism reaches and costs, the
model's e_min and e_max, and phi against the deposition friction.

Three studies, each writing CSV rows, a summary and a manifest into its folder:

- ``friction``: phi (core window) against the deposition friction mu_dep, example 4.3
  (seed 1, ``fast()``), in the box and in the periodic cell; every pack is brought back
  to the material's friction and settled (unbalanced ratio 1e-4), as a target's pack is.
  Also draws ``phi_vs_friction.png``.
- ``targets``: example 4.3 (seed 1, ``fast()``), consolidated oedometrically to 100 kPa,
  at targets phi = 0.57, 0.60, 0.63 and Dr = 0.3, 0.7: realised phi, e, Dr, Z, |a^r|,
  K0, the packs generated, and the time against one plain generation of the same scene.
- ``cost``: one plain generation beside each mechanism's target phi = 0.63 (4.3 in the
  box, consolidated to 100 kPa), in turn, twice: the time a target costs, side by side.
- ``limits``: e_min and e_max over 5 packs for 4.3, 4.4, a 30-60 mm sieve curve and
  (``--scenes sieve_example``) the sieve-curve example's grading
  (examples/sieve_curve.py), deposits in example 4.3's box.

    python studies/density_targets/density_targets.py friction [--containers box periodic]
    python studies/density_targets/density_targets.py targets --container box
    python studies/density_targets/density_targets.py limits [--packs 5] [--scenes sieve_example]
    python studies/density_targets/density_targets.py figure   # the friction figure, from runs.csv
    python studies/density_targets/density_targets.py cost [--rounds 2]
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from manifest import write_manifest  # noqa: E402

import granpack as gp  # noqa: E402
from granpack.density import sample_phi  # noqa: E402

#: this study's folder: each study writes into its own subfolder of it
RESULTS = Path(__file__).resolve().parent
FRICTIONS = (0.0, 0.05, 0.1, 0.2, 0.4, 0.7, 1.0, 2.0)
TARGETS = (
    ("target_relative_density", 0.3),
    ("target_relative_density", 0.7),
    ("target_phi", 0.57),
    ("target_phi", 0.60),
    ("target_phi", 0.63),
)
STRESS = 1e5


def _sieve_scene() -> gp.PackScene:
    """A sieve curve of 30 to 60 mm in example 4.3's box."""
    sieves = (0.03, 0.04, 0.05, 0.06)
    return gp.PackScene.preset("4.3").replace(
        radius_law="sieve", sieve_sizes=sieves, sieve_passing=(0.0, 0.3, 0.7, 1.0)
    )


def _sieve_example_scene() -> gp.PackScene:
    """The sieve-curve example's grading (examples/sieve_curve.py: 20 to 80 mm) in
    example 4.3's box, wide and tall enough for a core window."""
    return gp.PackScene.preset("4.3").replace(
        radius_law="sieve",
        sieve_sizes=(0.02, 0.03, 0.05, 0.08),
        sieve_passing=(0.0, 0.3, 0.7, 1.0),
    )


SCENES = {
    "4.3": lambda: gp.PackScene.preset("4.3"),
    "4.4": lambda: gp.PackScene.preset("4.4"),
    "sieve": _sieve_scene,
    "sieve_example": _sieve_example_scene,
}


def _write(out: Path, rows: list[dict], name: str = "runs.csv") -> None:
    out.mkdir(parents=True, exist_ok=True)
    with open(out / name, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def friction(args) -> None:
    from granpack.consolidation import settle

    rows = []
    for cont in args.containers:
        base = gp.PackScene.preset("4.3").replace(container=cont, seed=1)
        for mu in FRICTIONS:
            sc = base.replace(material=dataclasses.replace(base.material, friction=mu)).fast()
            t = time.perf_counter()
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                pack = gp.generate(sc)
            t_gen = time.perf_counter() - t
            m = gp.microstructure(pack)
            rest = dataclasses.replace(pack, scene=pack.scene.replace(material=base.material))
            t = time.perf_counter()
            rest = settle(rest, 1e-4)
            t_settle = time.perf_counter() - t
            m2 = gp.microstructure(rest)
            row = {
                "container": cont,
                "mu_dep": mu,
                "n": len(pack),
                "phi_core_jammed": m.phi_core,
                "phi_core": m2.phi_core,
                "z": m2.z,
                "unsettled_warning": bool(caught),
                "seconds_generate": t_gen,
                "seconds_settle": t_settle,
            }
            print(json.dumps(row), flush=True)
            rows.append(row)
    out = args.out or RESULTS / "density_friction_4.3"
    _write(out, rows)
    _figure(rows, out / "phi_vs_friction.png")
    write_manifest(out, seeds=[1])


def _figure(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    for cont, mark, colour in (("box", "o", "C0"), ("periodic", "s", "C1")):
        pts = sorted((r for r in rows if r["container"] == cont), key=lambda r: r["mu_dep"])
        if not pts:
            continue
        # the search's variable, ln(mu_dep + 0.1), in which phi is nearly linear
        x = [float(r["mu_dep"]) + 0.1 for r in pts]
        ax.plot(
            x,
            [float(r["phi_core"]) for r in pts],
            mark + "-",
            color=colour,
            label=f"{cont}: settled at the material's mu",
        )
        ax.plot(
            x,
            [float(r["phi_core_jammed"]) for r in pts],
            mark,
            color=colour,
            alpha=0.4,
            mfc="none",
            label=f"{cont}: as jammed at mu_dep",
        )
    ax.axvline(0.3, color="grey", lw=0.8)
    ax.text(0.31, 0.637, "material's mu = 0.2", fontsize=8)
    ax.set_xscale("log")
    ticks = [0.0, 0.05, 0.1, 0.2, 0.4, 0.7, 1.0, 2.0]
    ax.set_xticks([t + 0.1 for t in ticks], [f"{t:g}" for t in ticks])
    ax.minorticks_off()
    ax.set_xlabel("deposition friction mu_dep (axis: ln(mu_dep + 0.1))")
    ax.set_ylabel("core phi")
    ax.set_title("Example 4.3 (seed 1, fast): phi against mu_dep")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def figure(args) -> None:
    """Draws the friction study's figure again from its runs.csv."""
    out = args.out or RESULTS / "density_friction_4.3"
    with open(out / "runs.csv") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        r["mu_dep"] = float(r["mu_dep"])
    _figure(rows, out / "phi_vs_friction.png")


def targets(args) -> None:
    scene = (
        gp.PackScene.preset("4.3")
        .replace(container=args.container, seed=1, consolidate={"stress": STRESS})
        .fast()
    )
    t = time.perf_counter()
    plain = gp.generate(scene)
    t_plain = time.perf_counter() - t
    m = gp.microstructure(plain)
    phi = sample_phi(plain)[0]
    rows = [_row("plain", None, "recipe", plain, m, phi, t_plain, t_plain, None)]
    print(json.dumps(rows[-1]), flush=True)
    limits = None
    for method in ("auto", "deposition"):
        for key, value in TARGETS:
            if method == "deposition" and not (key == "target_phi" and value > phi):
                continue  # the same runs as auto's, where auto searched mu_dep
            sc = scene.replace(**{key: value, "density_method": method})
            t = time.perf_counter()
            try:
                pack = gp.generate(sc)
            except gp.DensityTargetError as e:
                rows.append(
                    {
                        "target": f"{key}={value}",
                        "method": method,
                        "status": str(e),
                        "phi_min": e.phi_min,
                        "phi_max": e.phi_max,
                        "seconds": time.perf_counter() - t,
                        "seconds_plain": t_plain,
                    }
                )
                print(json.dumps(rows[-1]), flush=True)
                continue
            secs = time.perf_counter() - t
            d = pack.record("density").table()
            if "e_min" in d:
                limits = (d["e_min"], d["e_max"])
            rows.append(
                _row(
                    f"{key}={value}",
                    d,
                    method,
                    pack,
                    gp.microstructure(pack),
                    d["phi"],
                    secs,
                    t_plain,
                    limits,
                )
            )
            print(json.dumps(rows[-1]), flush=True)
    out = args.out or RESULTS / f"density_targets_4.3_{args.container}"
    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    _write(out, [{k: r.get(k, "") for k in keys} for r in rows])
    write_manifest(out, seeds=[1])


def _row(target, d, method, pack, m, phi, secs, t_plain, limits) -> dict:
    e = 1.0 / phi - 1.0
    dr = (limits[1] - e) / (limits[1] - limits[0]) if limits else math.nan
    return {
        "target": target,
        "method": d["method"] if d else method,
        "status": "reached" if d else "",
        "phi": phi,
        "void_ratio": e,
        "relative_density": dr,
        "z": m.z,
        "a_r": m.a_r_mag,
        "k0": pack.record("consolidate").report["k0"],
        "generations": d["generations"] if d else 1,
        "friction": d["friction"] if d else pack.scene.material.friction,
        "servo_phases": sum(len(h.get("phases", [])) for h in d["history"]) if d else 0,
        "seconds": secs,
        "seconds_plain": t_plain,
        "ratio_to_plain": secs / t_plain,
        "history": json.dumps(d["history"], default=float) if d else "",
    }


def cost(args) -> None:
    """One plain generation (with its consolidation) beside each mechanism's target
    phi = 0.63, in turn, `--rounds` times: the time a target costs against the plain
    generation, taken side by side in one run."""
    scene = (
        gp.PackScene.preset("4.3")
        .replace(container="box", seed=1, consolidate={"stress": STRESS})
        .fast()
    )
    runs = (
        ("plain", {}),
        ("servo", {"target_phi": 0.63, "density_method": "servo"}),
        ("deposition", {"target_phi": 0.63, "density_method": "deposition"}),
    )
    rows = []
    for k in range(args.rounds):
        for name, kw in runs:
            t = time.perf_counter()
            pack = gp.generate(scene.replace(**kw))
            secs = time.perf_counter() - t
            d = pack.record("density").table()
            rows.append(
                {
                    "round": k,
                    "run": name,
                    "seconds": secs,
                    "phi": sample_phi(pack)[0],
                    "generations": d["generations"] if d else 1,
                }
            )
            print(json.dumps(rows[-1]), flush=True)
    out = args.out or RESULTS / "density_target_cost_4.3"
    _write(out, rows)
    write_manifest(out, seeds=[1])


def limits(args) -> None:
    rows = []
    for name in args.scenes:
        scene = SCENES[name]()
        t = time.perf_counter()
        lim = gp.void_ratio_limits(scene.replace(seed=1).fast(), packs=args.packs)
        rows.append(
            {
                "scene": name,
                "packs": lim.packs,
                "measure": lim.measure,
                "e_min": lim.e_min,
                "e_min_sd": lim.e_min_sd,
                "e_max": lim.e_max,
                "e_max_sd": lim.e_max_sd,
                "phi_max": lim.phi_max,
                "phi_min": lim.phi_min,
                "e_min_values": json.dumps(lim.e_min_values),
                "e_max_values": json.dumps(lim.e_max_values),
                "seconds": time.perf_counter() - t,
            }
        )
        print(json.dumps(rows[-1]), flush=True)
    out = args.out or RESULTS / "void_ratio_limits"
    tag = "" if args.scenes == ["4.3", "4.4", "sieve"] else "_" + "_".join(args.scenes)
    _write(out, rows, name=f"runs{tag}.csv")
    write_manifest(out, seeds=[1], name=f"manifest{tag}.json")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="study", required=True)
    f = sub.add_parser("friction")
    f.add_argument("--containers", nargs="+", default=["box", "periodic"])
    t = sub.add_parser("targets")
    t.add_argument("--container", default="box", choices=["box", "periodic"])
    lim = sub.add_parser("limits")
    lim.add_argument("--packs", type=int, default=5)
    lim.add_argument("--scenes", nargs="+", choices=list(SCENES), default=["4.3", "4.4", "sieve"])
    fig = sub.add_parser("figure")
    c = sub.add_parser("cost")
    c.add_argument("--rounds", type=int, default=2)
    for p in (f, t, lim, fig, c):
        p.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore", gp.UnsettledPackWarning)
    studies = {
        "friction": friction,
        "targets": targets,
        "limits": limits,
        "figure": figure,
        "cost": cost,
    }
    studies[args.study](args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
