"""Drained triaxial compression of one consolidated granpack pack, in granpack and in YADE.

A granpack 4.3 deposit (made here, or `--pack`) is consolidated isotropically to
`--confining` (100 kPa) with `granpack.consolidate(mode="isotropic")`; the consolidated
pack is then sheared to `--axial-strain` (25 %) by a lid moving down at constant speed
v = eps_dot H0, eps_dot = I / (d_mean sqrt(rho / sigma_3)) at inertial number `--inertial`
(1e-3), while the four side walls hold sigma_3:

- **granpack**: `granpack.triaxial` (where this checkout has it), its PFC servo on the
  side walls;
- **YADE** 2023.02a (`yade_triaxial.run_yade_triaxial`): the same spheres, walls, Hertz-
  Mindlin law, dt, lid speed and local damping; `TranslationEngine` on the lid,
  `TriaxialStressController` on the side walls.

Each runs on one thread (RAYON_NUM_THREADS=1, OMP_NUM_THREADS=1), pinned to `--cpu` where
given. Written to `--out`: ``granpack_triaxial.csv`` and ``yade_triaxial.csv`` (one row per
check), ``summary.json`` (steps, wall s, phi_p, eta at peak, eps_v at 10 % axial strain,
and the differences), ``triaxial.png`` and ``manifest.json``.

    python studies/triaxial_vs_yade/triaxial_vs_yade.py                   # makes the pack
    python studies/triaxial_vs_yade/triaxial_vs_yade.py --pack deposit.npz --cpu 1
"""

from __future__ import annotations

import os

# one thread for granpack's engine, set before granpack is imported
os.environ.setdefault("RAYON_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "_common"))
sys.path.insert(0, str(HERE))
from manifest import write_manifest  # noqa: E402
from yade_triaxial import (  # noqa: E402
    run_yade_triaxial,
    strain_rate,
    summary_figures,
)


def load_or_make_deposit(args):
    import granpack as gp

    if args.pack:
        pack = gp.load_pack(args.pack)
        print(f"pack: {args.pack} ({len(pack.radii)} particles)", flush=True)
        return pack
    scene = gp.PackScene.preset("4.3").replace(seed=args.seed)
    if args.small:  # a few hundred spheres: the check of the setup
        scene = scene.replace(base=(0.25, 0.25), height=0.25)
    # the fast settings, the pack the other benchmarks use
    if hasattr(scene, "fast"):
        scene = scene.fast()
    t0 = time.perf_counter()
    pack = gp.generate(scene)
    path = pack.save(Path(args.work) / "deposit.npz")
    print(
        f"pack: preset 4.3 seed {args.seed}, {len(pack.radii)} particles, "
        f"{time.perf_counter() - t0:.1f} s; saved to {path} (reuse with --pack)",
        flush=True,
    )
    return pack


def consolidated(pack, confining: float):
    import granpack as gp

    if pack.record("consolidate") is not None:
        return pack
    t0 = time.perf_counter()
    out = gp.consolidate(pack, confining, mode="isotropic")
    rec = out.record("consolidate")
    assert rec is not None  # consolidate records itself
    print(
        f"consolidated to {confining:g} Pa in {rec.steps} steps, {time.perf_counter() - t0:.1f} s; "
        f"phi {rec.report['phi']:.4f}, dt {rec.settings['dt']:.4g} s",
        flush=True,
    )
    return out


#: granpack's triaxial takes the consolidation's step, or the step of the stiffer contacts
#: at this many times sigma_3 (the axial stress at the peak at most), whichever is less.
PEAK_STRESS_RATIO = 5.0


def stage_default_dt(pack, confining: float) -> float:
    """The time step (s) `granpack.triaxial` takes by default: the consolidation's, or
    `stage_time_step` at PEAK_STRESS_RATIO sigma_3 where that is smaller."""
    from granpack.consolidation import stage_time_step

    rec = pack.record("consolidate")
    return min(float(rec.settings["dt"]), stage_time_step(pack, PEAK_STRESS_RATIO * confining))


def run_granpack(pack, args, out: Path):
    """granpack's triaxial stage, its table and summary; None where this checkout has no
    `granpack.triaxial`."""
    import granpack as gp

    if not hasattr(gp, "triaxial"):
        print("granpack: this checkout has no gp.triaxial yet; YADE alone", flush=True)
        return None, None
    t0 = time.perf_counter()
    res = gp.triaxial(
        pack,
        args.confining,
        axial_strain=args.axial_strain,
        inertial_number=args.inertial,
        checks=args.checks,
        local_damping=args.local_damping,
        dt=args.dt,
        **({} if args.wall_friction is None else {"wall_friction": args.wall_friction}),
    )
    wall = time.perf_counter() - t0
    table = gp.element_table(res)
    rec = res.record("triaxial")
    assert rec is not None  # the stage records itself
    table.write_csv(out / "granpack_triaxial.csv")
    n = len(res.radii)
    steps = int(table["step"][-1])
    seconds = float(getattr(rec, "seconds", None) or wall)
    settings = dict(rec.settings or {})
    # the stage's seconds hold its re-seating too: the cost per step counts both
    reseat = int(settings.get("reseat_steps") or 0)
    summary = {
        "particles": n,
        "dt": float(settings.get("dt", float("nan"))),
        "steps": steps,
        "reseat_steps": reseat,
        "wall_seconds": seconds,
        "python_seconds": wall,
        "ns_per_particle_step": seconds / (steps + reseat) / n * 1e9 if steps else None,
        **summary_figures(table),
        "settings": settings,
    }
    return table, summary


def figure(tables: dict, path: Path) -> None:
    """q and eps_v against eps_a, one line per code: granpack's own figure
    (`granpack.element.figures.triaxial_figure`) where this checkout has it."""
    try:
        from granpack.element import figures

        figures.triaxial_figure(tables, path)
        return
    except (ImportError, AttributeError, ValueError):
        # a checkout without granpack's element figures, or one whose figure wants columns
        # YADE's table lacks (the Love-Weber and fabric columns): the plain figure below
        pass
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    for name, t in tables.items():
        a.plot(t["eps_a"] * 100, t["q"] / 1e3, label=name)
        b.plot(t["eps_a"] * 100, t["eps_v"] * 100, label=name)
    a.set(xlabel="axial strain (%)", ylabel="q (kPa)")
    b.set(xlabel="axial strain (%)", ylabel="volumetric strain (%, compression +)")
    for ax in (a, b):
        ax.grid(alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--pack", help="a deposit or consolidated pack saved by Pack.save")
    p.add_argument("--seed", type=int, default=1, help="seed of the pack made here")
    p.add_argument("--small", action="store_true", help="a 0.25 m box (a few hundred spheres)")
    p.add_argument("--out", default=str(HERE), help="results folder")
    p.add_argument("--work", help="folder for the deposit and YADE's files (default: temp)")
    p.add_argument("--confining", type=float, default=1e5, help="sigma_3, Pa")
    p.add_argument("--axial-strain", type=float, default=0.25)
    p.add_argument("--inertial", type=float, default=1e-3, help="inertial number I")
    p.add_argument("--checks", type=int, default=100, help="checks along the path")
    p.add_argument("--local-damping", type=float, default=0.4)
    p.add_argument("--dt", type=float, help="time step, s (default: granpack.triaxial's)")
    p.add_argument("--max-vel", type=float, default=1.0, help="YADE's servo max_vel, m/s")
    p.add_argument(
        "--wall-friction",
        type=float,
        help="the walls' friction coefficient in both codes (default: granpack.triaxial's, 0)",
    )
    p.add_argument("--cpu", type=int, help="pin both codes to this CPU")
    p.add_argument("--codes", default="granpack,yade", help="comma-separated")
    args = p.parse_args(argv)

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if not args.work:
        args.work = tempfile.mkdtemp(prefix="triaxial_")
    Path(args.work).mkdir(parents=True, exist_ok=True)
    print(f"work folder: {args.work}", flush=True)
    if args.cpu is not None and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {args.cpu})
    codes = {c.strip() for c in args.codes.split(",") if c.strip()}

    pack = consolidated(load_or_make_deposit(args), args.confining)
    rec = pack.record("consolidate")
    eps_dot = strain_rate(pack, args.confining, args.inertial)
    print(
        f"{len(pack.radii)} spheres, box {rec.report['walls']}, eps_dot {eps_dot:.4g} 1/s",
        flush=True,
    )

    tables, summaries = {}, {}
    if "granpack" in codes:
        table, summary = run_granpack(pack, args, out)
        if table is not None:
            tables["granpack"], summaries["granpack"] = table, summary
            print("granpack:", json.dumps(summary, indent=1), flush=True)
    if "yade" in codes:
        work = Path(args.work) / "yade"
        # the walls' friction of granpack's run (its record), or smooth walls, its default
        g_settings = summaries.get("granpack", {}).get("settings", {})
        if args.wall_friction is not None:
            wall_friction = args.wall_friction
        elif "wall_friction" in g_settings:
            wall_friction = g_settings["wall_friction"]  # None: the particles' mu
        else:
            wall_friction = 0.0
        # the same dt as granpack's run; without it, the one granpack's stage defaults to
        dt = (
            args.dt
            or summaries.get("granpack", {}).get("dt")
            or stage_default_dt(pack, args.confining)
        )
        table = run_yade_triaxial(
            pack,
            args.confining,
            args.axial_strain,
            ("strain_rate", eps_dot),
            dt,
            args.local_damping,
            args.axial_strain / args.checks,
            work,
            max_vel=args.max_vel,
            wall_friction=wall_friction,
            cpu=args.cpu,
        )
        table.write_csv(out / "yade_triaxial.csv")
        ys = json.loads((work / "summary.json").read_text())
        summaries["yade"] = {
            "particles": ys["particles"],
            "dt": ys["dt"],
            "steps": ys["steps"],
            "wall_seconds": ys["stepping_seconds"],
            "loop_seconds": ys["loop_seconds"],
            "ns_per_particle_step": ys["ns_per_particle_step"],
            "lid_speed": ys["lid_speed"],
            "wall_friction": ys["wall_friction"],
            "reseat_steps": ys["reseat_steps"],
            "reseat_converged": ys["reseat_converged"],
            "H0": ys["H0"],
            "sigma_3_max_rel_error": float((table["sigma_3"] / args.confining - 1.0).abs().max()),
            **summary_figures(table),
        }
        tables["yade"] = table
        print("yade:", json.dumps(summaries["yade"], indent=1), flush=True)

    if "granpack" in summaries and "yade" in summaries:
        g, y = summaries["granpack"], summaries["yade"]
        summaries["difference_granpack_minus_yade"] = {
            k: (g[k] - y[k]) if g.get(k) is not None and y.get(k) is not None else None
            for k in ("phi_p_deg", "eta_peak", "eps_v_at_10pct", "eps_v_end", "eta_end")
        }
    summaries["settings"] = {
        "confining": args.confining,
        "axial_strain": args.axial_strain,
        "inertial_number": args.inertial,
        "strain_rate": eps_dot,
        "local_damping": args.local_damping,
        "consolidation_dt": float(rec.settings["dt"]),
        "dt": summaries.get("yade", summaries.get("granpack", {})).get("dt"),
        "consolidation_phi": float(rec.report["phi"]),
        "gravity": bool(rec.settings["gravity"]),
    }
    (out / "summary.json").write_text(json.dumps(summaries, indent=2) + "\n")
    if tables:
        figure(tables, out / "triaxial.png")
    write_manifest(
        out,
        seeds=None if args.pack else [args.seed],
        extra={"pack": args.pack, "particles": len(pack.radii), "codes": sorted(codes)},
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
