"""Largest stable time step of each preset, beside the Rayleigh estimate.

For each of the paper's presets (4.1-4.4) a reduced scene (the preset's material,
radii, layer thickness, gravity and drag, on a smaller base with a few layers and a
shorter jamming time; a few hundred particles) is packed at dt = f x the Rayleigh
estimate of r_min. A pack is stable when it completes without any of the engine's guards
firing (non-finite values, an overlap above max_overlap_ratio of the radius, a particle
moving more than half its radius per step, a centre through a wall, energy growth).
f = 1 is tried first; if a guard fires, the largest stable f is found by bisection on
(0, 1]. The engine refuses dt above the estimate, so f > 1 is not tried (the refusal is
shown at the end).

    python studies/stability/stability.py                  # 3 seeds, f to 1/128
    python studies/stability/stability.py --quick          # 1 seed, f to 1/16, smaller scenes
    python studies/stability/stability.py --damping 0.85   # a damping at which f < 1
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time

import granpack as gp

PRESETS = ("4.1", "4.2", "4.3", "4.4")


def reduced(name: str, quick: bool, damping: float | None = None) -> gp.PackScene:
    """The preset on a smaller base with about 4 layers of 0.1 m and the paper's 1 s of
    jamming per layer (quick: 2 layers, 0.5 s; a layer falls through its slab in about
    0.3 s at g = 2). `damping` overrides the material's damping ratio."""
    scene = gp.PackScene.preset(name)
    if damping is not None:
        scene = scene.replace(material=dataclasses.replace(scene.material, damping=damping))
    if quick:
        base = (0.4,) if scene.dim == 2 else (0.25, 0.25)
        return scene.replace(base=base, height=0.2, settle_time=0.5)
    base = (0.5,) if scene.dim == 2 else (0.35, 0.35)
    return scene.replace(base=base, height=0.4, settle_time=1.0)


def run(scene: gp.PackScene, frac: float, seed: int) -> tuple[str, int]:
    """('stable', N) or (the guard's message, steps) for dt = frac x the estimate."""
    crit = scene.material.critical_time_step(scene.r_min)
    s = scene.replace(dt=min(frac * crit, crit), seed=seed)
    try:
        pack = gp.generate(s)
    except gp.GranpackError as exc:
        msg = str(exc)
        if "unstable" not in msg:
            raise
        return msg, 0
    return "stable", len(pack)


def guard_name(msg: str) -> str:
    for key, name in (
        ("energy", "energy"),
        ("overlap", "overlap"),
        ("speed", "speed"),
        ("non-finite", "non-finite"),
        ("wall", "wall"),
    ):
        if key in msg:
            return name
    return msg[:40]


def stable_at(scene, frac, seeds, log) -> tuple[bool, str, int]:
    n = 0
    for seed in seeds:
        t0 = time.perf_counter()
        outcome, n_seed = run(scene, frac, seed)
        ok = outcome == "stable"
        log(
            f"    f = {frac:.4f} seed {seed}: "
            f"{'stable' if ok else 'guard: ' + guard_name(outcome)} "
            f"({time.perf_counter() - t0:.1f} s)"
        )
        if not ok:
            return False, guard_name(outcome), 0
        n = max(n, n_seed)
    return True, "", n


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="1 seed, 4 bisection steps, 2 layers")
    ap.add_argument("--presets", nargs="*", default=list(PRESETS))
    ap.add_argument(
        "--damping",
        type=float,
        default=None,
        help="override the damping ratio (e.g. 0.85: unstable below the estimate)",
    )
    ap.add_argument("-v", "--verbose", action="store_true", help="each run on stderr")
    args = ap.parse_args(argv)
    seeds = [0] if args.quick else [0, 1, 2]
    steps = 4 if args.quick else 7

    def log(msg):
        if args.verbose:
            print(msg, file=sys.stderr, flush=True)

    rows = []
    t_all = time.perf_counter()
    for name in args.presets:
        scene = reduced(name, args.quick, args.damping)
        crit = scene.material.critical_time_step(scene.r_min)
        log(f"{name}: estimate {crit:.4g} s for r_min = {scene.r_min:g} m")
        t0 = time.perf_counter()
        ok, guard, n = stable_at(scene, 1.0, seeds, log)
        if ok:
            best, first_bad = 1.0, None
        else:
            lo, hi, bad_guard = 0.0, 1.0, guard
            for _ in range(steps):
                mid = 0.5 * (lo + hi)
                ok, guard, n_mid = stable_at(scene, mid, seeds, log)
                if ok:
                    lo, n = mid, n_mid
                else:
                    hi, bad_guard = mid, guard
            best, first_bad = lo, (hi, bad_guard)
        rows.append((name, scene, crit, best, first_bad, n, time.perf_counter() - t0))

    damping = "" if args.damping is None else f", damping {args.damping}"
    print(
        f"Largest stable dt per preset (reduced scenes{damping}, seeds {seeds}; "
        "stable = no guard fires)\n"
    )
    head = (
        f"{'preset':<7}{'dim':>4}{'r_min (m)':>11}{'N':>6}{'estimate (s)':>14}"
        f"{'preset dt':>18}{'largest stable dt':>26}  first unstable"
    )
    print(head)
    print("-" * (len(head) + 18))
    for name, scene, crit, best, first_bad, n, _ in rows:
        preset_dt = gp.PackScene.preset(name).dt
        stable = f"{best * crit:.4g} ({best:.3f} est.)" if best > 0 else "none found"
        if first_bad is None:
            unstable = "stable up to the estimate; the engine refuses larger dt"
        else:
            unstable = f"{first_bad[0]:.3f} est. ({first_bad[1]} guard)"
        print(
            f"{name:<7}{scene.dim:>4}{scene.r_min:>11.3g}{n:>6}{crit:>14.4g}"
            f"{preset_dt:>10.3g} ({preset_dt / crit:.2f})"
            f"{stable:>26}  {unstable}"
        )
    # the refusal past the estimate
    scene = reduced(args.presets[0], args.quick, args.damping)
    crit = scene.material.critical_time_step(scene.r_min)
    try:
        scene.replace(dt=1.01 * crit)
        refusal = "accepted (unexpected)"
    except gp.GranpackError as exc:
        refusal = str(exc)
    print(f"\ndt = 1.01 x estimate for {args.presets[0]}: {refusal}")
    print(f"({time.perf_counter() - t_all:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
