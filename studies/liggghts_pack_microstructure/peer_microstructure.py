"""The microstructure of a pack made by LIGGGHTS, analysed from LIGGGHTS' own dumps.

Runs the peers' LIGGGHTS input for example 4.3 (``peers/liggghts/in.pack3d``, ``-var
maxlay 2`` by default: two layers, a few seconds) in a temporary folder, with two
additions: ``compute pair/gran/local pos id force`` defined before the first run, and at
the end a full-precision ``write_dump`` of the particles and a ``dump local`` of the pair
forces at the same step. granpack then reads both (``read_particles``, ``read_contacts``)
and gives phi, phi_core, Z, Z_m, the fabric, f0, a^n and a^t, beside LIGGGHTS' own
``compute contact/atom`` sum.

    python studies/liggghts_pack_microstructure/peer_microstructure.py              # maxlay 2
    python studies/liggghts_pack_microstructure/peer_microstructure.py --maxlay 100 # all, minutes

Writes ``--out`` (default ``studies/liggghts_pack_microstructure/``):
``microstructure.json`` (every scalar of the analysis), ``microstructure.md`` (the
table) and ``manifest.json``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE.parent / "_common"))

from manifest import write_manifest  # noqa: E402

import granpack as gp  # noqa: E402

PAIRS = "compute         pg all pair/gran/local pos id force\n"
FINAL = """write_dump      all custom state.dump id x y z radius mass modify format \
"%d %.17g %.17g %.17g %.17g %.17g"
dump            dpg all local 1 pairs.dump {cols}
dump_modify     dpg format "{fmt}"
run             0
"""
ROWS = [
    ("particles", "n_particles", "d"),
    ("contacts N_c", "n_contacts", "d"),
    ("H_top (m)", "h_top", ".4f"),
    ("phi", "phi", ".4f"),
    ("phi_core (margin 0.1 m)", "phi_core", ".4f"),
    ("Z", "z", ".3f"),
    ("Z_m (without rattlers)", "z_mech", ".3f"),
    ("rattlers", "n_rattlers", "d"),
    ("|a^r|", "a_r_mag", ".4f"),
    ("a^r_zz", "a_r_zz", ".4f"),
    ("f0 (N)", "f0", ".5f"),
    ("|a^n|", "a_n_mag", ".4f"),
    ("a^n_zz", "a_n_zz", ".4f"),
    ("|a^t|", "a_t_mag", ".4f"),
    ("a^t_zz", "a_t_zz", ".4f"),
]


def liggghts_input(source: Path) -> str:
    """The peers' input with the pair compute before the first run and the final dumps."""
    text = source.read_text()
    anchor = "pair_coeff      * *\n"
    if anchor not in text:
        raise SystemExit(f"{source}: no '{anchor.strip()}' line to put the pair compute after")
    text = text.replace(anchor, anchor + PAIRS, 1)
    cols = " ".join(f"c_pg[{k}]" for k in range(1, 13))
    return text + FINAL.format(cols=cols, fmt=" ".join(["%.17g"] * 12))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--input",
        type=Path,
        default=ROOT.parent / "shared" / "peers" / "liggghts" / "in.pack3d",
        help="the LIGGGHTS input (default: the peers' example 4.3 beside the checkout)",
    )
    p.add_argument("--maxlay", type=int, default=2, help="layers (the input's maxlay)")
    p.add_argument("--out", type=Path, default=HERE)
    args = p.parse_args(argv)
    program = shutil.which("liggghts")
    if program is None:
        raise SystemExit("liggghts is not on PATH (apt-get install liggghts)")
    with tempfile.TemporaryDirectory() as tmp:
        run = Path(tmp)
        (run / "in.run").write_text(liggghts_input(args.input))
        # no -screen none: insert/pack then crashes in this version (peers/README.md)
        done = subprocess.run(
            [program, "-in", "in.run", "-var", "maxlay", str(args.maxlay), "-log", "log.run"],
            cwd=run,
            capture_output=True,
            text=True,
        )
        if done.returncode != 0:
            raise SystemExit(f"liggghts failed:\n{done.stdout[-3000:]}\n{done.stderr[-2000:]}")
        log = (run / "log.run").read_text()
        final = next(ln for ln in log.splitlines() if ln.startswith("FINAL N"))
        contact_atom = float(final.split("sum_contact_atom")[1].split()[0])
        particles = gp.read_particles(run / "state.dump")
        found = gp.read_contacts(run / "pairs.dump", particles)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            m = gp.microstructure(particles.with_contacts(found))
    d = m.to_dict()
    result = {
        "input": str(args.input),
        "maxlay": args.maxlay,
        "liggghts_contact_atom_sum": contact_atom,
        "contacts_layout": found.layout,
        "contacts_timestep": found.timestep,
        "notes": list(particles.notes) + list(found.notes),
        "warnings": [str(w.message) for w in caught],
        "microstructure": {k: v for k, v in d.items() if isinstance(v, int | float | bool)},
    }
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "microstructure.json").write_text(json.dumps(result, indent=2) + "\n")
    lines = [
        f"# LIGGGHTS pack (example 4.3, maxlay {args.maxlay}) analysed from its own dumps",
        "",
        f"LIGGGHTS 3.8 `compute contact/atom` summed: {contact_atom:g} (= 2 N_c: "
        f"{2 * d['n_contacts']}). Forces from `compute pair/gran/local pos id force` at "
        f"step {found.timestep}.",
        "",
        "| quantity | value |",
        "|---|---|",
    ]
    lines += [f"| {label} | {d[key]:{fmt}} |" for label, key, fmt in ROWS]
    if result["notes"]:
        lines += ["", "Notes: " + "; ".join(result["notes"]) + "."]
    (args.out / "microstructure.md").write_text("\n".join(lines) + "\n")
    write_manifest(args.out, extra={"maxlay": args.maxlay, "liggghts": program})
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
