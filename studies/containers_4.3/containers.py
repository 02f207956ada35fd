"""Example 4.3 in the three containers: the walled box, the periodic cell and the
cylinder, ten packs each; what the walls do to phi, phi_core, Z and the fabric.

Reads saved packs (``granpack.load_pack``) from one folder per container, each as
``granpack generate`` writes them (``<folder>/packs/*.npz``), and writes

- ``packs.csv``: one row per pack (container, pack, N, H_top, phi, phi_core, Z, Z_m,
  |a^r|, a^r_zz, K0, and the generation time of the pack);
- ``summary.csv`` and ``summary.md``: per container, the mean and sample sd (ddof = 1);
- ``manifest.json`` (studies/_common/manifest.py) with the packs' seeds and streams.

Usage::

    granpack generate 4.3 --packs 10 --out runs/box
    granpack generate 4.3 --container periodic --packs 10 --out runs/periodic
    granpack generate 4.3 --container cylinder --cylinder-radius 0.5 --packs 10 --out runs/cyl
    python studies/containers_4.3/containers.py \\
        box=runs/box periodic=runs/periodic cylinder=runs/cyl [--out studies/containers_4.3]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import polars as pl

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from manifest import write_manifest  # noqa: E402

import granpack as gp  # noqa: E402

KEYS = ("n_particles", "phi", "phi_core", "z", "z_mech", "a_r_mag", "a_r_zz", "k0")


def fmt(mean: float, sd: float) -> str:
    return "n/a" if not math.isfinite(mean) else f"{mean:.4f} ± {sd:.4f}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="+", help="NAME=FOLDER, one per container")
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    a = ap.parse_args(argv)
    rows, seeds = [], {}
    for spec in a.folders:
        name, _, folder = spec.partition("=")
        files = sorted(Path(folder).glob("packs/*.npz")) or sorted(Path(folder).glob("*.npz"))
        streams = []
        for f in files:
            pack = gp.load_pack(f)
            d = gp.microstructure(pack).to_dict()
            rows.append(
                {
                    "container": name,
                    "pack": f.stem,
                    "h_top": pack.height,
                    "wall_seconds": pack.wall_time,
                    **{k: d[k] for k in KEYS},
                }
            )
            streams.append(int(pack.scene.stream))
        seeds[name] = {
            "seed": int(pack.scene.seed),
            "streams": streams,
            "container": pack.scene.container,
        }
        print(f"{name}: {len(files)} packs", file=sys.stderr)
    df = pl.DataFrame(rows)
    a.out.mkdir(parents=True, exist_ok=True)
    df.write_csv(a.out / "packs.csv")
    cols = [c for c in df.columns if c not in ("container", "pack")]
    summary = df.group_by("container", maintain_order=True).agg(
        [pl.len().alias("packs")]
        + [pl.col(c).mean().alias(f"{c}_mean") for c in cols]
        + [pl.col(c).std(ddof=1).alias(f"{c}_sd") for c in cols]
    )
    summary.write_csv(a.out / "summary.csv")
    lines = [
        "| container | packs | N | phi | phi_core | Z | \\|a^r\\| | a^r_zz | K0 | s per pack |",
        "|" + "---|" * 10,
    ]
    for r in summary.iter_rows(named=True):
        lines.append(
            f"| {r['container']} | {r['packs']} | {r['n_particles_mean']:.0f} | "
            + " | ".join(
                fmt(r[f"{k}_mean"], r[f"{k}_sd"])
                for k in ("phi", "phi_core", "z", "a_r_mag", "a_r_zz", "k0")
            )
            + f" | {r['wall_seconds_mean']:.1f} |"
        )
    (a.out / "summary.md").write_text("\n".join(lines) + "\n")
    write_manifest(
        a.out,
        seeds=seeds,
        extra={"study": "example 4.3 in the box, the periodic cell and the cylinder"},
    )
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
