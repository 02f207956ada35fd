"""Pack quality of the paper's cases beyond the paper: P(Z), the strong network, K0, the
crystallised fraction and the phi profile over the height, mean and sd over the packs.

Reads saved packs (``granpack.load_pack``) from one folder per case, named
``<example>-<on|off>`` (as ``granpack paper`` writes them under ``packs/``), and writes

- ``packs.csv``: one row per pack;
- ``summary.csv``: per case, mean and sample sd (ddof = 1) of every column;
- ``summary.md``: the table the documentation cites;
- ``profile_fine.csv``: per case, the mean and sd over the packs of phi in ``--fine-slices``
  slices from the floor to H_top (about one diameter each by default), which resolves the
  floor's layering and would show any layering at the interfaces of the deposited layers;
- ``manifest.json`` (studies/_common/manifest.py), with the packs' seeds and streams.

Usage::

    python studies/pack_quality/pack_quality.py PACKS_DIR [--out studies/pack_quality]
        [--slices 5] [--fine-slices 25]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import polars as pl

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from manifest import write_manifest  # noqa: E402

import granpack as gp  # noqa: E402

CASES = [(ex, rot) for ex in ("4.1", "4.2", "4.3", "4.4") for rot in ("on", "off")]
#: Columns of Microstructure.to_dict() kept per pack.
KEYS = (
    "n_particles",
    "phi",
    "phi_core",
    "z",
    "z_std",
    "z_mech",
    "z_mech_frictional",
    "z_mech_iterative",
    "n_rattlers_frictional",
    "strong_fraction",
    "a_r_mag",
    "a_r_strong_mag",
    "a_r_weak_mag",
    "k0",
    "q6_mean",
    "crystal_fraction",
)


def fine_profile(pack, slices: int) -> np.ndarray:
    return gp.profiles(pack, slices=slices)["phi"].to_numpy()


def pack_row(pack, slices: int) -> dict:
    m = gp.microstructure(pack)
    d = m.to_dict()
    row = {k: d[k] for k in KEYS}
    df = gp.profiles(pack, slices=slices)
    phi = df["phi"].to_list()
    # top to bottom: slice 1 is the top one
    for k, v in enumerate(reversed(phi)):
        row[f"phi_slice{k + 1}"] = v
    return row


def fmt(mean: float, sd: float, digits: int) -> str:
    if not math.isfinite(mean):
        return "n/a"
    return f"{mean:.{digits}f} ± {sd:.{digits}f}" if math.isfinite(sd) else f"{mean:.{digits}f}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("packs", type=Path, help="folder with one sub-folder per case (4.3-on, ...)")
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    ap.add_argument("--slices", type=int, default=5, help="slices of the phi profile")
    ap.add_argument("--fine-slices", type=int, default=25, help="slices of profile_fine.csv")
    a = ap.parse_args(argv)
    rows = []
    fine = []
    seeds = {}
    for ex, rot in CASES:
        folder = a.packs / f"{ex}-{rot}"
        files = sorted(folder.glob("*.npz"))
        if not files:
            print(f"{ex}-{rot}: no packs in {folder}", file=sys.stderr)
            continue
        streams = []
        profs = []
        for f in files:
            pack = gp.load_pack(f)
            streams.append(int(pack.scene.stream))
            profs.append(fine_profile(pack, a.fine_slices))
            rows.append(
                {
                    "example": ex,
                    "rotations": rot.upper(),
                    "pack": f.stem,
                    **pack_row(pack, a.slices),
                }
            )
        seeds[f"{ex}-{rot}"] = {"seed": int(pack.scene.seed), "streams": streams}
        arr = np.array(profs)
        for k in range(a.fine_slices):
            fine.append(
                {
                    "example": ex,
                    "rotations": rot.upper(),
                    "slice": k + 1,
                    "z_over_h_top_lo": k / a.fine_slices,
                    "z_over_h_top_hi": (k + 1) / a.fine_slices,
                    "phi_mean": float(arr[:, k].mean()),
                    "phi_sd": float(arr[:, k].std(ddof=1)) if len(arr) > 1 else math.nan,
                }
            )
        print(f"{ex}-{rot}: {len(files)} packs", file=sys.stderr)
    if not rows:
        print("no packs found", file=sys.stderr)
        return 1
    per_pack = pl.DataFrame(rows)
    a.out.mkdir(parents=True, exist_ok=True)
    per_pack.write_csv(a.out / "packs.csv")
    pl.DataFrame(fine).write_csv(a.out / "profile_fine.csv")
    value_cols = [c for c in per_pack.columns if c not in ("example", "rotations", "pack")]
    summary = per_pack.group_by(["example", "rotations"], maintain_order=True).agg(
        [pl.len().alias("packs")]
        + [pl.col(c).mean().alias(f"{c}_mean") for c in value_cols]
        + [pl.col(c).std(ddof=1).alias(f"{c}_sd") for c in value_cols]
    )
    summary.write_csv(a.out / "summary.csv")

    slices = [f"phi_slice{k + 1}" for k in range(a.slices)]
    head = (
        "| case | packs | Z | width of P(Z) | Z_m (one pass) | Z_m (iterative, D) "
        "| strong fraction | a_r strong | a_r weak | K0 | crystallised | phi, top to bottom |"
    )
    lines = [head, "|" + "---|" * 12]
    for r in summary.iter_rows(named=True):

        def c(key, digits=3, r=r):
            return fmt(r[f"{key}_mean"], r[f"{key}_sd"] if r["packs"] > 1 else math.nan, digits)

        prof = " / ".join(f"{r[f'{s}_mean']:.3f}" for s in slices)
        lines.append(
            f"| {r['example']} {r['rotations']} | {r['packs']} | {c('z', 2)} | {c('z_std', 2)} "
            f"| {c('z_mech', 2)} | {c('z_mech_frictional', 2)} | {c('strong_fraction')} "
            f"| {c('a_r_strong_mag')} | {c('a_r_weak_mag')} | {c('k0')} "
            f"| {c('crystal_fraction')} | {prof} |"
        )
    (a.out / "summary.md").write_text("\n".join(lines) + "\n")
    write_manifest(
        a.out,
        seeds=seeds,
        extra={
            "study": "pack quality of the paper's eight cases beyond the paper: P(Z), the "
            "strong network, K0, the crystallised fraction and the phi profile",
            "packs_folder": a.packs.name,
            "slices": a.slices,
            "fine_slices": a.fine_slices,
        },
    )
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
