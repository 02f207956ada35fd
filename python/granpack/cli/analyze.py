"""``granpack analyze``: the microstructure of a saved pack or of another code's
particles (and, with --contacts, its contact forces)."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from .._console import Console
from .._outputs import json_text, jsonable, microstructure
from .._validate import GranpackError, InvalidParameterError, check_outputs
from ..analysis.container import CONTAINERS
from ..io import FORMATS
from ..io import LAYOUTS as CONTACT_LAYOUTS
from ..io.contacts import COLUMN_NAMES
from . import _args

HELP = "microstructure of a saved pack or of particles from another code"
DESCRIPTION = (
    "Prints the microstructure of a granpack pack (.npz), a LAMMPS or "
    "LIGGGHTS dump custom file (columns x y z or xs ys zs, radius or diameter, id), a "
    "LAMMPS data file (atom_style sphere), YADE's text export (#format x_y_z_r), "
    "extended XYZ with a radius property, a gsd file (HOOMD-blue's schema), a CSV or "
    "Parquet table with columns x y (z) "
    "and r, radius or diameter, or a plain text file with columns x y r (2D) or "
    "x y z r (3D; lines starting with # are comments). The format is detected from the "
    "content and the suffix, and printed. --contacts adds another code's contact "
    "forces."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    a = parser
    a.add_argument("file", type=Path, metavar="FILE")
    a.add_argument(
        "--format",
        choices=FORMATS,
        default=None,
        help="the file's format (default: detected)",
    )
    a.add_argument(
        "--snapshot",
        type=int,
        default=-1,
        metavar="K",
        help="which snapshot of a dump, or frame of an XYZ file: 0 the first, -1 the last "
        "(default)",
    )
    a.add_argument(
        "--contacts",
        type=Path,
        default=None,
        metavar="FILE",
        help="contact forces of the same step: a LIGGGHTS compute pair/gran/local or LAMMPS "
        "compute pair/local dump local file (docs/interop.md); gives f0, a^n, a^t",
    )
    a.add_argument(
        "--contact-layout",
        choices=tuple(CONTACT_LAYOUTS),
        default=None,
        help="the columns of --contacts (default: told from their number)",
    )
    a.add_argument(
        "--contact-columns",
        default=None,
        metavar="NAMES",
        help="instead of --contact-layout: what each column of --contacts holds, such as "
        "'id2 id1 fnx fny fnz ftx fty ftz' for YADE's interactions written as a plain "
        "table (names: " + " ".join(COLUMN_NAMES) + ")",
    )
    a.add_argument("--dim", type=int, choices=(2, 3), default=None, help="dimension of a text file")
    a.add_argument(
        "--box",
        type=float,
        nargs="+",
        metavar="V",
        default=None,
        help="box of a text file: XLO XHI YLO YHI (2D) or XLO XHI YLO YHI ZLO ZHI (3D); "
        "default: the particles' bounding box",
    )
    a.add_argument(
        "--container",
        choices=CONTAINERS,
        default=None,
        help="the container to analyse in, for files that cannot say: walled box, periodic "
        "horizontal axes (periods from the box) or vertical cylinder (default: what the file "
        "says, else a box, and the output says which it used and why)",
    )
    a.add_argument(
        "--cylinder-radius",
        type=float,
        default=None,
        metavar="R",
        help="radius of --container cylinder (m; default: the file's)",
    )
    a.add_argument(
        "--lid",
        type=float,
        default=None,
        metavar="Z",
        help="height of the lid that closes a consolidated sample (m): the sample is taken "
        "from the floor up to it (default: what the file says, granpack's exports of a "
        "consolidated pack; else an open top)",
    )
    a.add_argument("--json", action="store_true", help="print JSON instead of a table")
    a.add_argument("--figures", type=Path, default=None, metavar="DIR", help="also draw pictures")
    _args.add_quiet(a)


def _figure_files(args: argparse.Namespace) -> list[Path]:
    return [
        args.figures / f"{args.file.stem}{suffix}.png" for suffix in ("", "_normals", "_forces")
    ]


def run(args: argparse.Namespace, console: Console) -> int:
    if args.figures is not None:  # before the analysis: a folder it cannot write
        check_outputs(_figure_files(args), [args.file, args.contacts], "--figures")
    particles, kwargs = _load_for_analysis(args, console)
    pack = particles.pack
    if "positions" in kwargs:
        m = microstructure(console, args.file.name, **kwargs)
    else:
        m = microstructure(console, args.file.name, particles, **kwargs)
    if m.container_source == "assumed":
        console.note(
            f"the file does not say its container: analysed as a {m.container} "
            f"({'walls at the file box' if particles.box is not None else 'no walls'}); "
            "give --container box|periodic|cylinder to choose",
            args.file.name,
        )
    console.flush_notes()
    d = jsonable(m.to_dict())
    head: dict = {
        "file": str(args.file),
        "format": particles.format,
        "container": m.container,
        "container_source": m.container_source,
    }
    if particles.n_snapshots > 1 or particles.format in ("lammps-dump", "xyz", "gsd"):
        head.update(
            snapshot=particles.snapshot,
            n_snapshots=particles.n_snapshots,
            timestep=particles.timestep,
        )
    found = getattr(args, "contacts_read", None)
    if found is not None:
        head.update(
            contacts_file=str(found.path),
            contacts_layout=found.layout,
            contacts_timestep=found.timestep,
        )
    d = {**head, "n_particles": len(particles), **d}
    if args.json:
        print(json_text(d), end="")
    elif not args.quiet:
        width = max(len(k) for k in d)
        for k, v in d.items():
            print(f"{k:<{width}}  {_format_value(v)}")
    if args.figures is not None:
        from types import SimpleNamespace

        from .. import plot

        subject = pack
        if subject is None:
            subject = SimpleNamespace(positions=particles.positions, radii=particles.radii)
        made = [
            plot.save(
                plot.pack_figure(subject, title=args.file.name),
                args.figures / f"{args.file.stem}.png",
            )
        ]
        if pack is not None:
            contacts = pack.contacts
        else:  # the particle-particle contacts the analysis found, for the normals
            from .. import _core
            from ..contacts import Contacts

            found = _core.find_contacts(
                np.ascontiguousarray(particles.positions, dtype=np.float64),
                np.ascontiguousarray(particles.radii, dtype=np.float64),
                walls=None,
            )
            contacts = Contacts.from_dict(found)
        if len(contacts):
            made.append(
                plot.save(
                    plot.normals_figure(contacts.particle_pairs().normal, title=args.file.name),
                    args.figures / f"{args.file.stem}_normals.png",
                )
            )
            if pack is not None:
                made.append(
                    plot.save(
                        plot.force_chain_figure(pack, title=args.file.name),
                        args.figures / f"{args.file.stem}_forces.png",
                    )
                )
        if not args.json:
            console.say("figures: " + ", ".join(str(p) for p in made))
    return 0


def _load_for_analysis(args, console: Console):
    """(particles, microstructure kwargs) for any file read_particles reads; kwargs
    replace the file's box when --box is given."""
    from ..io import detect_format, read_particles

    path: Path = args.file
    fmt = args.format or detect_format(path)
    if fmt == "npz" and (args.box is not None or args.dim is not None):
        raise GranpackError("--box and --dim apply to text and LAMMPS files, not to packs")
    particles = read_particles(path, format=fmt, snapshot=args.snapshot, dim=args.dim)
    for note in particles.notes:
        console.note(note, path.name)
    if args.contacts is not None:
        from ..io import read_contacts

        found = read_contacts(
            args.contacts, particles, layout=args.contact_layout, columns=args.contact_columns
        )
        for note in found.notes:
            console.note(note, args.contacts.name)
        particles = particles.with_contacts(found)
        args.contacts_read = found
    elif args.contact_layout is not None or args.contact_columns is not None:
        raise GranpackError("--contact-layout and --contact-columns need --contacts FILE")
    where: dict = {}
    if args.container is not None:
        where["container"] = args.container
    if args.cylinder_radius is not None:
        where["cylinder_radius"] = args.cylinder_radius
    if args.lid is not None:
        where["lid"] = args.lid
    if args.box is None:
        return particles, where
    if particles.contacts is not None and args.contacts is not None:
        raise GranpackError("--box cannot be combined with --contacts: the dump gives the box")
    dim = particles.dim
    if args.box is not None:
        if len(args.box) != 2 * dim:
            raise InvalidParameterError(
                f"invalid --box: {len(args.box)} values, expected {2 * dim} "
                f"(lo hi for each of the {dim} axes)",
                parameter="--box",
            )
        v = np.asarray(args.box, dtype=np.float64)
        box = (v[0::2], v[1::2])
        if np.any(box[1] <= box[0]):
            raise InvalidParameterError(
                "invalid --box: every axis needs lo < hi", parameter="--box"
            )
    if "container" not in where and particles.container is not None:
        # --box replaces the file's box, not its container
        where["container"] = particles.container
        if particles.cylinder_radius is not None and "cylinder_radius" not in where:
            where["cylinder_radius"] = particles.cylinder_radius
    if "lid" not in where and particles.lid is not None:
        where["lid"] = particles.lid  # nor its lid
    return particles, {
        "positions": particles.positions,
        "radii": particles.radii,
        "box": box,
        **where,
    }


def _format_value(v) -> str:
    if isinstance(v, bool) or v is None:
        return str(v)
    if isinstance(v, int | np.integer):
        return str(int(v))
    if isinstance(v, float | np.floating):
        return f"{float(v):.6g}"
    return str(v)
