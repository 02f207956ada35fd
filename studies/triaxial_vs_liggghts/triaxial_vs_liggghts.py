"""A drained triaxial compression of one granpack consolidated sample in granpack and in
LIGGGHTS 3.8.0, side by side: the path (q, eps_v against eps_a) and the cost (steps, wall
time of the stepping loop, ns per particle-step at the same dt and rate, one thread).

The sample: a granpack deposit (``--size small``: preset 4.3 on a 0.3 m x 0.3 m base, 0.2 m
high, seed 3, about 270 spheres; ``--size full``: preset 4.3, 8 217 spheres), consolidated
isotropically to 100 kPa (`granpack.consolidate(dep, 1e5, "isotropic")`). Then, one after
the other in this one process:

1. granpack, `granpack.triaxial(pack, axial_strain=..., local_damping=0.0)`: the like-for-like
   run (LIGGGHTS has no local damping);
2. granpack at its default local damping 0.4;
3. LIGGGHTS (`liggghts_triaxial`), with run 1's dt, lid speed, step count, re-seat steps and
   side-wall speed cap.

The confining stress is the consolidation's (100 kPa), the rate I = 1e-3, walls
frictionless. granpack runs on one thread (``RAYON_NUM_THREADS=1``, set here before granpack
is imported); LIGGGHTS is the serial Debian build with ``OMP_NUM_THREADS=1``.

The stepping loop's wall time: for granpack the stage's own seconds less the rebuild of the
engine, the re-seat and the table's rows (timed here around `_Rig`'s methods); for LIGGGHTS
its "Loop time" of the loading run (its 100 thermo rows cost ~0.1 % of it).

Writes into ``--out`` (default: this folder, files prefixed by the size): one CSV per run
(the element table), ``<size>_summary.json``, ``manifest_<size>.json`` and
``<size>_triaxial.png``.

    RAYON_NUM_THREADS=1 python studies/triaxial_vs_liggghts/triaxial_vs_liggghts.py --size small
    RAYON_NUM_THREADS=1 python studies/triaxial_vs_liggghts/triaxial_vs_liggghts.py --size full
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("RAYON_NUM_THREADS", "1")  # before granpack starts its thread pool

import numpy as np  # noqa: E402
import polars as pl  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "_common"))
sys.path.insert(0, str(HERE))
import liggghts_triaxial as lt  # noqa: E402
from manifest import write_manifest  # noqa: E402

STRESS = 1e5  # Pa, the consolidation's (isotropic) target
INERTIAL = 1e-3


def make_pack(size: str, work: Path):
    """The consolidated sample of `size` (saved in `work`), and the seconds it took."""
    import granpack as gp

    if size == "small":
        scene = gp.PackScene.preset("4.3").replace(seed=3, base=(0.3, 0.3), height=0.2)
    else:
        scene = gp.PackScene.preset("4.3")
    t0 = time.perf_counter()
    dep = gp.generate(scene)
    t1 = time.perf_counter()
    pack = gp.consolidate(dep, STRESS, "isotropic")
    t2 = time.perf_counter()
    pack.save(work / f"{size}_consolidated.npz")
    return pack, {"generate_s": t1 - t0, "consolidate_s": t2 - t1}


class RigTimer:
    """Times the parts of `granpack.triaxial` that are not its stepping loop: the engine's
    rebuild (`_Rig.__init__`), the re-seat and the table's rows."""

    def __init__(self):
        import granpack.element.run as er

        self.rig = er._Rig
        self.seconds = {"init": 0.0, "reseat": 0.0, "row": 0.0}
        self.saved = {}

    def __enter__(self):
        for name, key in (("__init__", "init"), ("reseat", "reseat"), ("row", "row")):
            orig = getattr(self.rig, name)
            self.saved[name] = orig

            def timed(*a, _orig=orig, _key=key, **k):
                t = time.perf_counter()
                try:
                    return _orig(*a, **k)
                finally:
                    self.seconds[_key] += time.perf_counter() - t

            setattr(self.rig, name, timed)
        return self

    def __exit__(self, *exc):
        for name, orig in self.saved.items():
            setattr(self.rig, name, orig)


def held(table: pl.DataFrame, target: float) -> float:
    """The largest relative departure of sigma_3 from `target` along the loading (the
    start row left out)."""
    s3 = table["sigma_3"].to_numpy()[1:]
    return float(np.max(np.abs(s3 / target - 1.0)))


def at_strain(table: pl.DataFrame, column: str, eps: float) -> float:
    """`column` interpolated at axial strain `eps`."""
    return float(np.interp(eps, table["eps_a"].to_numpy(), table[column].to_numpy()))


def summarise(label: str, table: pl.DataFrame, n: int, steps: int, loop_s: float, extra: dict):
    from granpack.element import lab

    rep = lab.triaxial_report(table.select("eps_a", "eps_v", "sigma_1", "sigma_3"), 3)
    return {
        "code": label,
        "particles": n,
        "steps": steps,
        "loop_seconds": loop_s,
        "ns_per_particle_step": loop_s / (steps * n) * 1e9,
        "phi_peak_deg": rep["phi_peak"],
        "eta_peak": rep["eta_peak"],
        "eps_a_peak": rep["eps_a_peak"],
        "eta_at_5pct": at_strain(table, "eta", 0.05),
        "eps_v_end": rep["eps_v_end"],
        "eps_a_end": rep["eps_a_end"],
        "phi_start": float(table["phi"][0]),
        "sigma_1_start": float(table["sigma_1"][0]),
        "sigma_3_max_departure": held(table, STRESS),
        **extra,
    }


def run_granpack(pack, eps: float, local_damping: float):
    import granpack as gp

    with RigTimer() as timer:
        out = gp.triaxial(
            pack, axial_strain=eps, inertial_number=INERTIAL, local_damping=local_damping
        )
    rec = out.record("triaxial")
    table = gp.element_table(out)
    loop = float(rec.seconds) - sum(timer.seconds.values())
    extra = {
        "local_damping": local_damping,
        "dt": rec.settings["dt"],
        "lid_speed": rec.settings["lid_speed"],
        "strain_rate": rec.settings["strain_rate"],
        "reseat_steps": rec.settings["reseat_steps"],
        "stage_seconds": float(rec.seconds),
        "rebuild_reseat_rows_seconds": dict(timer.seconds),
    }
    return (
        out,
        table,
        summarise(
            f"granpack (local damping {local_damping:g})",
            table,
            len(pack.radii),
            int(rec.steps),
            loop,
            extra,
        ),
    )


def figure(tables: dict[str, pl.DataFrame], path: Path) -> Path:
    """q / p and eps_v against eps_a, one line per run; written atomically."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_q, ax_v) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for k, (label, t) in enumerate(tables.items()):
        style = "--" if "LIGGGHTS" in label else "-"
        ax_q.plot(t["eps_a"], t["q"] / 1e3, style, color=f"C{k}", label=label)
        ax_v.plot(t["eps_a"], t["eps_v"], style, color=f"C{k}", label=label)
    ax_q.set_xlabel("eps_a (-)")
    ax_q.set_ylabel("q (kPa)")
    ax_v.set_xlabel("eps_a (-)")
    ax_v.set_ylabel("eps_v (-, compression positive)")
    ax_q.legend(fontsize=8)
    for ax in (ax_q, ax_v):
        ax.grid(alpha=0.3)
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    tmp.replace(path)
    return path


def write_csv(table: pl.DataFrame, path: Path) -> None:
    tmp = path.with_suffix(".tmp")
    table.write_csv(tmp)
    tmp.replace(path)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--size", choices=("small", "full"), default="small")
    p.add_argument("--axial-strain", type=float, default=0.25, help="final eps_a (-)")
    p.add_argument("--out", default=str(HERE), help="results folder")
    p.add_argument("--work", help="folder for the pack and LIGGGHTS' files (default: temp)")
    p.add_argument(
        "--pack",
        help="a consolidated pack saved by an earlier run (<work>/<size>_consolidated.npz): "
        "skips making it, for a repeat of the timings",
    )
    p.add_argument("--tag", help="prefix of the files written (default: the size)")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="triaxial_liggghts_"))
    work.mkdir(parents=True, exist_ok=True)
    print(f"work folder: {work}", flush=True)

    if args.pack:
        import granpack as gp

        pack, prep = gp.load_pack(args.pack), {}
    else:
        pack, prep = make_pack(args.size, work)
    tag = args.tag or args.size
    n = len(pack.radii)
    rec = pack.record("consolidate")
    print(f"{n} spheres; prep {prep}", flush=True)

    summaries, tables = [], {}
    first = None
    for ld in (0.0, 0.4):
        res, table, s = run_granpack(pack, args.axial_strain, ld)
        first = first or res.record("triaxial").settings
        tables[s["code"]] = table
        summaries.append(s)
        write_csv(table, out / f"{tag}_granpack_ld{ld:g}.csv")
        print(json.dumps(s, indent=1), flush=True)

    g_rec = summaries[0]
    steps = g_rec["steps"]
    setup = lt.Setup(
        dt=first["dt"],
        lid_speed=first["lid_speed"],
        steps=steps,
        check_every=max(1, steps // (int(first["checks"]) - 1)),
        confining=first["confining"],
        reseat_steps=int(first["reseat_steps"]),
        wall_vel_max=first["max_wall_speed"],
        lid_stress=float(rec.settings["targets"]["lid"]),
        lid_vel_max=float(rec.settings["max_wall_speed"]),
        gain=float(first["gain"]),
        gravity=bool(first["gravity"]),
    )
    lres = lt.run(pack, work / "liggghts", setup)
    ltable = lres["table"]
    label = "LIGGGHTS 3.8.0"
    tables[label] = ltable
    write_csv(ltable, out / f"{tag}_liggghts.csv")
    target = ltable["target_sigma_3"].to_numpy()
    s = summarise(
        label,
        ltable,
        n,
        steps,
        lres["loop_seconds"],
        {
            "dt": setup.dt,
            "lid_speed": setup.lid_speed,
            "reseat_steps": setup.reseat_steps,
            "side_kp": setup.kp,
            "lid_kp_reseat": setup.lid_kp,
            "side_vel_max": setup.wall_vel_max,
            "reseat_loop_seconds": lres["reseat_loop_seconds"],
            "output_seconds": lres["output_seconds"],
            "process_seconds": lres["process_seconds"],
            "sigma_1_start_over_lid_target": float(ltable["sigma_1"][0]) / setup.lid_stress,
            "target_sigma_3_max_departure": float(np.max(np.abs(target / STRESS - 1.0))),
        },
    )
    summaries.append(s)
    print(json.dumps(s, indent=1), flush=True)

    summary = {
        "size": args.size,
        "particles": n,
        "axial_strain": args.axial_strain,
        "inertial_number": INERTIAL,
        "confining": STRESS,
        "preparation_seconds": prep,
        "runs": summaries,
    }
    (out / f"{tag}_summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    figure(tables, out / f"{tag}_triaxial.png")
    write_manifest(
        out,
        seeds=[3] if args.size == "small" else [int(pack.scene.seed)],
        name=f"manifest_{tag}.json",
        extra={
            "size": args.size,
            "pack": args.pack,
            "particles": n,
            "threads": {"RAYON_NUM_THREADS": os.environ.get("RAYON_NUM_THREADS")},
            "liggghts": "LIGGGHTS-PUBLIC 3.8.0 (Debian package liggghts), serial, OMP 1",
            "machine_note": "2 cores shared with other work: the timings are indicative",
            "material": {
                k: float(getattr(pack.scene.material, k))
                for k in ("density", "young", "poisson", "friction", "damping")
            },
        },
    )
    for s in summaries:
        print(
            f"{s['code']:32s} steps {s['steps']:7d} loop {s['loop_seconds']:8.2f} s "
            f"{s['ns_per_particle_step']:7.0f} ns/p-step phi_p {s['phi_peak_deg']:.2f} "
            f"eta_peak {s['eta_peak']:.3f} eps_v_end {s['eps_v_end']:.4f}",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
