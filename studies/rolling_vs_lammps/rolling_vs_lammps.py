"""Rolling resistance in granpack beside LAMMPS ``rolling sds``: packs and step cost.

Two parts, each writing its own table into ``--out`` (default this folder):

``--part ensemble``
    Example 4.3 (``PackScene.preset("4.3")``, the paper's settings, the normal path) as
    a layered deposit with rolling resistance (``Material(rolling="epsd",
    rolling_friction=MU_R, rolling_stiffness=K_R, rolling_damping=GAMMA_R)``), several
    seeds, beside LAMMPS on ``../shared/peers/lammps/in.pack3d`` with ``rolling sds K_R
    GAMMA_R MU_R`` added to its ``pair_coeff`` and its three ``fix wall/gran granular``
    lines; and the same without rolling (the control). Every final pack goes through
    granpack's own analysis (``gp.microstructure`` on positions and radii in the unit
    box): phi, phi_core, Z, |a^r|. Two runs at a time, each on its own core, one thread.
    Writes ``ensemble_packs.csv`` (one line a pack), ``ensemble.csv`` and ``ensemble.md``
    (mean, sd, n per code and model, and whether granpack's mean lies within one sd of
    LAMMPS'), ``manifest_ensemble.json``.

``--part ensemble --law linear [--kn 2e5]``
    The same deposit (no rolling) with granpack's linear law in both codes:
    ``Material(contact_law="linear", normal_stiffness=K_N)`` (the paper's mu 0.2 and xi
    0.1, k_t by default k_n 2(1-nu)/(2-nu)) and, in in.pack3d's ``pair_coeff`` and its
    three wall lines, the exact LAMMPS form of that law from
    ``granpack.io.lammps_input`` (``hooke k_n e`` with ``damping tsuji limit_damping``, e
    such that Tsuji's alpha(e) = 2 xi; ``tangential linear_history k_t sqrt(k_t/k_n)
    mu``). ``--packs`` packs a code; writes ``ensemble_linear_packs.csv``,
    ``ensemble_linear.csv``, ``ensemble_linear.md`` and ``manifest_ensemble_linear.json``.

``--part speed``
    The step on the settled 4.3 pack on one thread, alternating, ``--repeats`` times each:
    granpack's ``profile_step`` (default law; ``ROLLING=MU_R``; ``LINEAR=2e5``) and
    LAMMPS ``pair granular`` without and with ``rolling sds`` on a settled pack read
    from a LAMMPS dump (ns per particle-step from its loop time). Writes ``speed.csv``,
    ``speed.md`` (medians and ratios to each code's own default step) and
    ``manifest_speed.json``.

    python studies/rolling_vs_lammps/rolling_vs_lammps.py --part ensemble   # ~40 min
    python studies/rolling_vs_lammps/rolling_vs_lammps.py --part speed      # ~5 min

The rolling spring is a constant here, the same in both codes: granpack's default derives
k_r from each contact's current Hertz stiffness, which LAMMPS cannot. K_R = 2.25 mu_r^2 k_n
with k_n = 2 E* sqrt(R* d) at the overlap d of one sphere-sphere contact carrying the
weight of the column of spheres above a sphere at half the bed's height (phi 0.6): see
`rolling_stiffness`.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import os
import re
import shutil
import statistics
import subprocess
import sys
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE.parent / "_common"))
from manifest import write_manifest  # noqa: E402

#: Rolling friction coefficient of the study (-).
MU_R = 0.2
#: Rolling dashpot (N s/m), the same in both codes: none, as LIGGGHTS epsd2.
GAMMA_R = 0.0
LOOP = re.compile(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps with (\d+) atoms")


def rolling_stiffness(mu_r: float = MU_R) -> float:
    """The constant rolling spring k_r (N/m) of the study, 2.25 mu_r^2 k_n, rounded to two
    digits, with k_n the Hertz stiffness of a sphere-sphere contact of the 4.3 material
    under the weight of the column of spheres (solid fraction 0.6) above a sphere at half
    the bed's height H_d = 0.5 m: W = 0.6 rho g pi r^2 H_d / 2 = 0.377 N, d = 1.41e-5 m,
    k_n = 4.0e4 N/m, so k_r = 3.6e3 N/m at mu_r = 0.2."""
    import granpack as gp

    scene = gp.PackScene.preset("4.3")
    mat, r = scene.material, scene.r_max
    e_star = mat.young / (2 * (1 - mat.poisson**2))
    r_star = r / 2
    weight = 0.6 * mat.density * scene.gravity * math.pi * r**2 * 0.5 / 2
    overlap = (weight / (4 / 3 * e_star * math.sqrt(r_star))) ** (2 / 3)
    k_n = 2 * e_star * math.sqrt(r_star * overlap)
    return float(f"{2.25 * mu_r**2 * k_n:.2g}")


# ---------------------------------------------------------------------------- analysis


def read_dump(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Positions (z vertical) and radii from a LAMMPS `dump custom` file."""
    lines = path.read_text().splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
    cols = lines[head].split()[2:]
    data = np.loadtxt(lines[head + 1 :], ndmin=2)
    pos = np.column_stack([data[:, cols.index(a)] for a in "xyz"])
    return pos, data[:, cols.index("radius")]


def analyse(positions, radii) -> dict:
    """phi, phi_core, Z and |a^r| of a final pack by granpack's analysis in the unit box
    (contacts found from the geometry, the same way for every code)."""
    import granpack as gp
    from granpack.analysis import MicrostructureWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MicrostructureWarning)
        m = gp.microstructure(
            positions=np.asarray(positions),
            radii=np.asarray(radii),
            box=(np.zeros(3), np.array([1.0, 1.0, np.inf])),
        )
    return {
        "particles": len(radii),
        "phi": float(m.phi),
        "phi_core": float(m.phi_core),
        "z": float(m.z),
        "a_r": float(m.a_r_mag),
    }


# ---------------------------------------------------------------------------- LAMMPS


#: in.pack3d's Hertz-Mindlin law, in its pair_coeff and its three wall/gran lines.
HERTZ_LAW = "hertz/material ${E} ${e} ${nu} tangential mindlin NULL 1.0 ${mu} damping tsuji"

#: in.pack3d's final dump, whose floats LAMMPS writes with six digits by default.
DUMP = "write_dump      all custom pack3d_final.dump id x y z radius vx vy vz modify sort id"


def linear_lammps_law(k_n: float) -> str:
    """LAMMPS' exact form of granpack's linear law with the 4.3 material (mu, xi) and
    normal stiffness `k_n` (N/m), k_t its default: granpack.io.lammps_input's mapping."""
    from granpack.io.lammps_input import _lammps_linear_law

    return _lammps_linear_law(material(0.0, 0.0, 0.0, "linear", k_n))[0]


def lammps_input(
    text: str, mu_r: float, k_r: float, gamma_r: float, law: str = "hertz", k_n: float = 0.0
) -> str:
    """in.pack3d with ``rolling sds k_r gamma_r mu_r`` after every ``damping tsuji`` (the
    pair_coeff and the three wall/gran lines; none at mu_r = 0); with law "linear", its
    Hertz-Mindlin law replaced by `linear_lammps_law` in those four lines."""
    if law == "linear":
        n = text.count(HERTZ_LAW)
        if n != 4:
            raise SystemExit(f"expected 4 '{HERTZ_LAW}' in in.pack3d (pair + 3 walls), found {n}")
        text = text.replace(HERTZ_LAW, linear_lammps_law(k_n))
        # the overlaps of the stiff linear contacts (~1e-6 m) lie below the dump's default
        # six digits, which would open about one contact in ten: write every digit
        if text.count(DUMP) != 1:
            raise SystemExit(f"expected one '{DUMP}' in in.pack3d")
        text = text.replace(DUMP, DUMP + " format float %.17g")
    if mu_r == 0:
        return text
    new, n = re.subn(
        r"damping tsuji", f"damping tsuji rolling sds {k_r:g} {gamma_r:g} {mu_r:g}", text
    )
    if n != 4:
        raise SystemExit(f"expected 4 'damping tsuji' in in.pack3d (pair + 3 walls), found {n}")
    return new


def lammps_seed(seed: int) -> int:
    """The input's seed0 for pack number `seed` (fix pour seeds seed0 + 1000 layer + try)."""
    return 4767 + 100_000 * seed


def run_lammps_pack(mu_r: float, seed: int, core: int, work: Path, args) -> dict:
    tag = f"lammps{_law_tag(args)}_mur{mu_r:g}_s{seed}"
    d = work / tag
    d.mkdir(parents=True, exist_ok=True)
    src = (args.peers_dir / "lammps" / "in.pack3d").read_text()
    (d / "in.pack3d").write_text(lammps_input(src, mu_r, args.k_r, args.gamma_r, args.law, args.kn))
    cmd = ["taskset", "-c", str(core), "lmp", "-in", "in.pack3d", "-log", "log.txt"]
    cmd += ["-screen", "none", "-var", "seed0", str(lammps_seed(seed))]
    if args.maxlay:
        cmd += ["-var", "maxlay", str(args.maxlay)]
    t0 = time.perf_counter()
    subprocess.run(cmd, cwd=d, env=dict(os.environ, OMP_NUM_THREADS="1"), check=True)
    wall = time.perf_counter() - t0
    runs = [(float(t), int(n), int(m)) for t, n, m in LOOP.findall((d / "log.txt").read_text())]
    pos, rad = read_dump(d / "pack3d_final.dump")
    return {
        "code": "LAMMPS",
        "mu_r": mu_r,
        "seed": lammps_seed(seed),
        "wall_s": wall,
        "layers": len([r for r in runs if r[1] > 1]),
        "particle_steps": sum(n * m for _, n, m in runs),
        **analyse(pos, rad),
    }


# ---------------------------------------------------------------------------- granpack


def _law_tag(args) -> str:
    """The law's part of file names: empty for the default Hertz-Mindlin law."""
    return "" if args.law == "hertz" else f"_linear{args.kn:g}"


def material(mu_r: float, k_r: float, gamma_r: float, law: str = "hertz", k_n: float = 0.0):
    """The 4.3 material; with law "linear", granpack's linear law of normal stiffness
    `k_n` (N/m) and the same friction and damping ratio; rolling epsd for mu_r > 0."""
    import granpack as gp

    base = gp.PackScene.preset("4.3").material
    if law == "linear":
        base = dataclasses.replace(base, contact_law="linear", normal_stiffness=k_n)
    if mu_r == 0:
        return base
    return dataclasses.replace(
        base,
        rolling="epsd",
        rolling_friction=mu_r,
        rolling_stiffness=k_r,
        rolling_damping=gamma_r,
    )


def granpack_worker(
    mu_r: float, seed: int, k_r: float, gamma_r: float, layers, law: str = "hertz", k_n=0.0
) -> dict:
    """One granpack pack of 4.3 with the paper's settings, in this process."""
    import granpack as gp
    from granpack.pack import _packer

    scene = gp.PackScene.preset("4.3").replace(
        seed=seed, material=material(mu_r, k_r, gamma_r, law, k_n)
    )
    t0 = time.perf_counter()
    packer = _packer(scene)
    reports = []
    while not packer.done and (layers is None or len(reports) < layers):
        reports.append(packer.next_layer())
    wall = time.perf_counter() - t0
    state = packer.state()
    return {
        "code": "granpack",
        "mu_r": mu_r,
        "seed": seed,
        "wall_s": wall,
        "layers": len(reports),
        "particle_steps": sum(r["steps"] * r["total"] for r in reports),
        **analyse(state["positions"], state["radii"]),
    }


def run_granpack_pack(mu_r: float, seed: int, core: int, work: Path, args) -> dict:
    cmd = ["taskset", "-c", str(core), sys.executable, __file__, "--worker"]
    cmd += ["--mu-r", str(mu_r), "--seed", str(seed), "--k-r", str(args.k_r)]
    cmd += ["--gamma-r", str(args.gamma_r), "--law", args.law, "--kn", str(args.kn)]
    if args.maxlay:
        cmd += ["--layers", str(args.maxlay)]
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


# ---------------------------------------------------------------------------- ensemble

STATS = ("phi", "phi_core", "z", "a_r")


def summarise(packs: list[dict]) -> list[dict]:
    """Mean, sd and n of each statistic per code and mu_r."""
    rows = []
    for mu_r in sorted({p["mu_r"] for p in packs}, reverse=True):
        for code in ("granpack", "LAMMPS"):
            mine = [p for p in packs if p["code"] == code and p["mu_r"] == mu_r]
            if not mine:
                continue
            row = {"code": code, "mu_r": mu_r, "n": len(mine)}
            for s in STATS + ("particles", "h_top", "wall_s"):
                v = [p[s] for p in mine]
                row[f"{s}_mean"] = float(np.mean(v))
                row[f"{s}_sd"] = float(np.std(v, ddof=1)) if len(v) > 1 else float("nan")
            rows.append(row)
    return rows


def ensemble_table(rows: list[dict]) -> str:
    names = {"phi": "phi", "phi_core": "phi_core", "z": "Z", "a_r": r"\|a^r\|"}
    out = [
        "| mu_r | code | n | particles | H_top m | "
        + " | ".join(names.values())
        + " | wall s a pack |",
        "|---|---|---|---|---|" + "---|" * len(names) + "---|",
    ]
    for row in rows:
        cells = [f"{row['mu_r']:g}", row["code"], str(row["n"]), f"{row['particles_mean']:.0f}"]
        cells.append(f"{row['h_top_mean']:.4f} ± {row['h_top_sd']:.4f}")
        cells += [f"{row[f'{s}_mean']:.4f} ± {row[f'{s}_sd']:.4f}" for s in STATS]
        cells.append(f"{row['wall_s_mean']:.0f}")
        out.append("| " + " | ".join(cells) + " |")
    out += ["", "granpack's mean within one sd (the larger of the two codes') of LAMMPS':", ""]
    out.append("| mu_r | " + " | ".join(names.values()) + " |")
    out.append("|---|" + "---|" * len(names))
    for mu_r in sorted({r["mu_r"] for r in rows}, reverse=True):
        by = {r["code"]: r for r in rows if r["mu_r"] == mu_r}
        if len(by) < 2:
            continue
        g, lmp = by["granpack"], by["LAMMPS"]
        cells = []
        for s in STATS:
            diff = g[f"{s}_mean"] - lmp[f"{s}_mean"]
            sd = max(g[f"{s}_sd"], lmp[f"{s}_sd"])
            ok = abs(diff) <= sd
            cells.append(f"{'yes' if ok else 'no'} ({diff:+.4f}, {abs(diff) / sd:.1f} sd)")
        out.append(f"| {mu_r:g} | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def part_ensemble(args) -> None:
    work = args.work
    (work / "results").mkdir(parents=True, exist_ok=True)
    jobs = []
    # the linear law is compared without rolling only
    counts = (
        ((0.0, args.packs),) if args.law == "linear" else ((MU_R, args.packs), (0.0, args.control))
    )
    for mu_r, n in counts:
        for seed in range(1, n + 1):
            jobs += [("LAMMPS", mu_r, seed), ("granpack", mu_r, seed)]

    def result_path(job) -> Path:
        code, mu_r, seed = job
        return work / "results" / f"{code}{_law_tag(args)}_mur{mu_r:g}_s{seed}.json"

    # the two codes alternate, so that a run cut short still has packs of both
    todo = [] if args.report_only else [j for j in jobs if not result_path(j).is_file()]
    free_cores = list(range(args.parallel))

    def run(job):
        core = free_cores.pop()
        try:
            code, mu_r, seed = job
            f = run_lammps_pack if code == "LAMMPS" else run_granpack_pack
            res = f(mu_r, seed, core, work, args)
            tmp = result_path(job).with_suffix(".tmp")
            tmp.write_text(json.dumps(res))
            tmp.replace(result_path(job))  # atomic: a cut-off run leaves no half result
            print(f"{code} mu_r={mu_r:g} seed={seed}: {res['wall_s']:.0f} s", file=sys.stderr)
        finally:
            free_cores.append(core)

    with ThreadPoolExecutor(args.parallel) as pool:
        list(pool.map(run, todo))

    packs = [json.loads(result_path(j).read_text()) for j in jobs if result_path(j).is_file()]
    for p in packs:
        p["ns_per_particle_step"] = 1e9 * p["wall_s"] / p["particle_steps"]
        # phi is the solids over the unit base times the top's height: that height
        p["h_top"] = p["particles"] * 4 / 3 * math.pi * 0.02**3 / p["phi"]
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    stem = "ensemble" if args.law == "hertz" else "ensemble_linear"
    fields = ["code", "mu_r", "seed", "particles", "layers", "wall_s", "particle_steps"]
    fields += ["ns_per_particle_step", "h_top", *STATS]
    with open(out / f"{stem}_packs.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        w.writerows(packs)
    rows = summarise(packs)
    with open(out / f"{stem}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    text = ensemble_table(rows)
    (out / f"{stem}.md").write_text(text)
    write_manifest(
        out,
        name=f"manifest_{stem}.json",
        seeds={
            "granpack": f"1..{max(args.packs, 0 if args.law == 'linear' else args.control)}",
            "lammps_seed0": "4767 + 100000 seed",
        },
        extra=(
            {
                "law": "linear",
                "k_n_N_per_m": args.kn,
                "lammps_law": linear_lammps_law(args.kn),
                "maxlay": args.maxlay,
            }
            if args.law == "linear"
            else {"mu_r": MU_R, "k_r_N_per_m": args.k_r, "gamma_r_N_s_per_m": args.gamma_r}
        )
        | {
            "lammps": _version("lammps"),
            "parallel_runs": args.parallel,
            "note": "other work shared the 2-core machine during the runs",
        },
    )
    print(text)


# ---------------------------------------------------------------------------- speed


#: The LAMMPS step input: the peers' settled 4.3 pack (read from a data file), the
#: material, walls, gravity, drag and step of in.pack3d, SETTLE steps, then STEPS timed.
LAMMPS_STEP = """units si
atom_style sphere
atom_modify map hash
dimension 3
boundary f f f
newton off
comm_modify vel yes
read_data pack.data
neighbor 0.004 bin
neigh_modify delay 0 every 1 check yes
pair_style granular
pair_coeff * * hertz/material 1.0e8 0.7292 0.25 tangential mindlin NULL 1.0 0.2 damping tsuji
fix wx all wall/gran granular hertz/material 1.0e8 0.7292 0.25 tangential mindlin NULL 1.0 0.2 \
  damping tsuji xplane 0.0 1.0
fix wy all wall/gran granular hertz/material 1.0e8 0.7292 0.25 tangential mindlin NULL 1.0 0.2 \
  damping tsuji yplane 0.0 1.0
fix wz all wall/gran granular hertz/material 1.0e8 0.7292 0.25 tangential mindlin NULL 1.0 0.2 \
  damping tsuji zplane 0.0 NULL
fix grav all gravity 2.0 vector 0 0 -1
fix drag all viscous 0.005
fix integ all nve/sphere
timestep 1.0e-4
thermo 0
run ${settle}
run ${steps}
"""
#: granpack's variants: profile_step's environment (ROLLING uses the derived spring).
GRANPACK_STEP = {
    "default (Hertz-Mindlin)": {},
    "rolling epsd mu_r 0.2": {"ROLLING": str(MU_R)},
    "linear k_n 2e5": {"LINEAR": "2e5"},
}


def lammps_data(xyzr: Path, out: Path) -> int:
    """A LAMMPS data file (atom_style sphere) of an ``x y z r`` pack; returns N."""
    data = np.loadtxt(xyzr, ndmin=2)
    top = data[:, 2].max() + 0.1
    lines = [
        "settled 4.3 pack",
        "",
        f"{len(data)} atoms",
        "1 atom types",
        "",
        "0 1 xlo xhi",
        "0 1 ylo yhi",
        f"0 {top:.6f} zlo zhi",
        "",
        "Atoms # sphere",
        "",
    ]
    lines += [
        f"{i + 1} 1 {2 * r:.17g} 1000 {x:.17g} {y:.17g} {z:.17g}"
        for i, (x, y, z, r) in enumerate(data)
    ]
    out.write_text("\n".join(lines) + "\n")
    return len(data)


def time_granpack(binary: Path, env_extra: dict, steps: int, core: int) -> tuple[float, int]:
    env = dict(os.environ, RAYON_NUM_THREADS="1", **env_extra)
    cmd = ["taskset", "-c", str(core), str(binary), str(steps)]
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
    ns = float(re.search(r"([0-9.]+) ns a particle-step", res.stderr).group(1))
    n = int(res.stdout.split()[0])
    return ns, n


def time_lammps(work: Path, rolling: bool, steps: int, core: int, args) -> tuple[float, int]:
    text = LAMMPS_STEP
    if rolling:
        text = text.replace(
            "damping tsuji",
            f"damping tsuji rolling sds {args.k_r:g} {args.gamma_r:g} {MU_R:g}",
        )
    (work / "in.step").write_text(text)
    cmd = ["taskset", "-c", str(core), "lmp", "-in", "in.step", "-log", "log.txt"]
    cmd += ["-screen", "none", "-var", "settle", "20", "-var", "steps", str(steps)]
    subprocess.run(cmd, cwd=work, env=dict(os.environ, OMP_NUM_THREADS="1"), check=True)
    t, m, n = LOOP.findall((work / "log.txt").read_text())[-1]
    return 1e9 * float(t) / (int(m) * int(n)), int(n)


def part_speed(args) -> None:
    binary = args.profile_step
    if not binary.is_file():
        raise SystemExit(
            f"{binary} not found: cargo build --release --example profile_step "
            "(or pass --profile-step)"
        )
    work = args.work / "speed"
    work.mkdir(parents=True, exist_ok=True)
    lammps_data(args.peers_dir / "liggghts" / "pack3d_final_xyzr.txt", work / "pack.data")
    variants = [("granpack", name, env) for name, env in GRANPACK_STEP.items()]
    variants += [("LAMMPS", "default (pair granular)", False)]
    variants += [("LAMMPS", "rolling sds mu_r 0.2", True)]
    rows = []
    for rep in range(args.repeats):
        for code, name, how in variants:  # alternating: drifts of the machine hit all alike
            if code == "granpack":
                ns, n = time_granpack(binary, how, args.steps, args.core)
            else:
                ns, n = time_lammps(work, how, args.steps, args.core, args)
            rows.append({"code": code, "variant": name, "repeat": rep, "particles": n, "ns": ns})
            print(f"{code} {name}: {ns:.1f} ns a particle-step", file=sys.stderr)
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "speed.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = [
        "| code | variant | particles | ns a particle-step, median (min-max) "
        "| / the code's default |",
        "|---|---|---|---|---|",
    ]
    medians = {}
    for code, name, _ in variants:
        v = [r["ns"] for r in rows if r["code"] == code and r["variant"] == name]
        medians[(code, name)] = statistics.median(v)
        base = medians[(code, variants[0 if code == "granpack" else 3][1])]
        n = next(r["particles"] for r in rows if r["code"] == code)
        lines.append(
            f"| {code} | {name} | {n} | {statistics.median(v):.1f} ({min(v):.1f}-{max(v):.1f}) "
            f"| {statistics.median(v) / base:.2f}x |"
        )
    lmp_default = medians[("LAMMPS", variants[3][1])]
    lmp_rolling = medians[("LAMMPS", variants[4][1])]
    gp_default = medians[("granpack", variants[0][1])]
    gp_rolling = medians[("granpack", variants[1][1])]
    lines += [
        "",
        f"LAMMPS / granpack, default law: {lmp_default / gp_default:.1f}x; "
        f"with rolling: {lmp_rolling / gp_rolling:.1f}x.",
    ]
    text = "\n".join(lines) + "\n"
    (out / "speed.md").write_text(text)
    write_manifest(
        out,
        name="manifest_speed.json",
        extra={
            "steps": args.steps,
            "repeats": args.repeats,
            "core": args.core,
            "k_r_lammps_N_per_m": args.k_r,
            "gamma_r_N_s_per_m": args.gamma_r,
            "granpack_rolling_spring": "derived, 2.25 mu_r^2 k_n (profile_step's ROLLING)",
            "lammps": _version("lammps"),
            "profile_step": str(binary),
            "note": "other work shared the 2-core machine during the runs",
        },
    )
    print(text)


def _version(code: str) -> str:
    try:
        out = subprocess.run(
            ["dpkg-query", "-W", "-f=${Version}", code], capture_output=True, text=True
        )
        return out.stdout.strip() or "unknown"
    except OSError:
        return "unknown"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--part", choices=["ensemble", "speed"], default="ensemble")
    p.add_argument("--packs", type=int, default=10, help="packs a code with rolling")
    p.add_argument("--control", type=int, default=3, help="packs a code without rolling")
    p.add_argument("--parallel", type=int, default=2, help="runs at a time, one core each")
    p.add_argument("--maxlay", type=int, help="layers a pack (a quick check; default all)")
    p.add_argument("--repeats", type=int, default=5, help="speed: runs of each variant")
    p.add_argument("--steps", type=int, default=300, help="speed: timed steps a run")
    p.add_argument("--core", type=int, default=0, help="speed: the core the runs are pinned to")
    p.add_argument(
        "--profile-step",
        type=Path,
        default=ROOT / "target" / "release" / "examples" / "profile_step",
        help="speed: granpack's profile_step binary",
    )
    p.add_argument("--k-r", type=float, help="rolling spring N/m (default: rolling_stiffness())")
    p.add_argument("--gamma-r", type=float, default=GAMMA_R)
    p.add_argument(
        "--law",
        choices=["hertz", "linear"],
        default="hertz",
        help="ensemble: the contact law (linear: no rolling, --packs packs a code)",
    )
    p.add_argument("--kn", type=float, default=2e5, help="linear law's normal stiffness N/m")
    p.add_argument("--peers-dir", type=Path, default=ROOT.parent / "shared" / "peers")
    p.add_argument("--work", type=Path, default=Path("/tmp/rolling_vs_lammps"))
    p.add_argument("--out", type=Path, default=HERE)
    p.add_argument(
        "--report-only", action="store_true", help="tabulate the packs already in --work"
    )
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--mu-r", type=float, help=argparse.SUPPRESS)
    p.add_argument("--seed", type=int, help=argparse.SUPPRESS)
    p.add_argument("--layers", type=int, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.k_r is None:
        args.k_r = rolling_stiffness()
    if args.worker:
        res = granpack_worker(
            args.mu_r, args.seed, args.k_r, args.gamma_r, args.layers, args.law, args.kn
        )
        print(json.dumps(res))
        return 0
    for tool in ("taskset", "lmp"):
        if shutil.which(tool) is None:
            p.error(f"{tool} not found (util-linux; apt-get install lammps)")
    if args.part == "ensemble":
        part_ensemble(args)
    else:
        part_speed(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
