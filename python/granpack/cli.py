"""The ``granpack`` command.

::

    granpack paper --quick                 # the paper's section 4, 2 packs per case
    granpack paper --out DIR [--packs 10]  # the full reproduction
    granpack generate 4.3 --packs 10 --seed 1 --rotations off --out DIR
    granpack generate my_scene.toml --out DIR
    granpack analyze DIR/packs/pack_000.npz          # or a dump, data, text, CSV file
    granpack export DIR/packs/pack_000.npz --format vtk   # vtk | lammps | csv | parquet
    granpack tile DIR/packs/pack_000.npz 4 4 --out big.npz  # a periodic pack, 4 x 4 copies

Packs run in local worker processes (all cores) or, with ``--scheduler ADDRESS``, on a
Dask cluster; the results are the same for the same master seed. Every finished pack is
on disk at once, and running the same command again skips what is there.

Bad input gives one line on stderr and exit status 2; an interrupted run exits with 130
(Ctrl-C) or 143 (SIGTERM), after the same clean stop: the packs in progress are
stopped, the finished ones are on disk. One run at a time writes into an output folder
(a second one is refused while the first holds the folder's lock), and no command
writes over one of its own input files.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import json
import math
import os
import re
import signal
import sys
import time
import warnings
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from ._validate import GranpackError, InvalidParameterError, check_outputs
from .container_tag import CONTAINER_KINDS
from .io import FORMATS
from .io import LAYOUTS as CONTACT_LAYOUTS

__all__ = ["main", "build_parser"]

#: The paper's examples and their figure numbers (rotations ON, OFF).
PAPER_EXAMPLES = {"4.1": (2, 3), "4.2": (4, 5), "4.3": (6, 7), "4.4": (8, 9)}
PAPER_PACKS = 10
QUICK_PACKS = 2

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 128 + signal.SIGTERM
#: Longest error message printed whole; longer ones are cut in the middle.
MAX_MESSAGE = 600
#: The lock file of an output folder (see `_locked`).
LOCK_NAME = ".granpack.lock"


class _Terminated(KeyboardInterrupt):
    """Raised by the SIGTERM handler: a batch scheduler's stop is handled like Ctrl-C."""


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error as one line (no usage dump, no traceback)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        message = _cut(message)
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _cut(message: str, limit: int = MAX_MESSAGE) -> str:
    """A message cut in the middle when longer than `limit` (a huge value in it is not
    echoed whole)."""
    if len(message) <= limit:
        return message
    return (
        f"{message[: limit - 100]} ...[{len(message) - limit + 40} characters]... "
        + (message[-60:])
    )


class _Console:
    """Where the command talks: results to stdout, progress to stderr; --quiet keeps
    only errors."""

    def __init__(self, quiet: bool) -> None:
        self.quiet = quiet
        self._notes: dict[str, list[tuple[str, str]]] = {}

    def say(self, text: str) -> None:
        if not self.quiet:
            print(text, flush=True)

    def progress_mode(self) -> str | bool:
        return False if self.quiet else "auto"

    def note(self, message: str, where: str) -> None:
        """Collects a note about `where` (e.g. a pack); `flush_notes` prints each kind
        of note once (the first message in full), with the places it applies to."""
        kind = re.sub(r"\(.*?\)", "", message)  # details (numbers) differ between packs
        self._notes.setdefault(kind, []).append((message, where))

    def flush_notes(self) -> None:
        for items in self._notes.values():
            if self.quiet:
                continue
            message, where = items[0]
            more = f" and {len(items) - 1} more" if len(items) > 1 else ""
            print(f"granpack: note: {message} ({where}{more})", file=sys.stderr, flush=True)
        self._notes.clear()


# -- arguments ---------------------------------------------------------------------------------


def _on_off(value: str) -> bool:
    v = value.lower()
    if v in ("on", "true", "yes", "1"):
        return True
    if v in ("off", "false", "no", "0"):
        return False
    raise argparse.ArgumentTypeError(f"invalid value {_short(value)!r}: use on or off")


def _short(text: str, limit: int = 40) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _positive_int(value: str) -> int:
    try:
        v = int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"invalid value {_short(value)!r}: expected an integer"
        ) from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"invalid value {_short(str(v))}: must be >= 1")
    return v


def _count(hi: int, what: str):
    """An argparse type: an integer in [1, hi]; the bound keeps a typo (an extra digit
    or twenty) from starting a run that never ends."""

    def parse(value: str) -> int:
        v = _positive_int(value)
        if v > hi:
            raise argparse.ArgumentTypeError(
                f"invalid value {_short(str(v))}: {what} must lie in [1, {hi}]"
            )
        return v

    return parse


def _packs(value: str) -> int:
    from .ensemble import MAX_PACKS

    return _count(MAX_PACKS, "packs")(value)


def _workers(value: str) -> int:
    from .ensemble import max_workers

    return _count(max_workers(), "workers (four per core)")(value)


def _seed(value: str) -> int:
    try:
        v = int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"invalid seed {_short(value)!r}: expected an integer"
        ) from None
    if not 0 <= v < 2**64:
        raise argparse.ArgumentTypeError(
            f"invalid seed {_short(str(v))}: must lie in [0, 2^64 - 1]"
        )
    return v


def _positive_float(value: str) -> float:
    try:
        v = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"invalid value {_short(value)!r}: expected a number"
        ) from None
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"invalid value {_short(value)!r}: must be > 0")
    return v


def _add_run_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--workers",
        type=_workers,
        default=None,
        help="local worker processes (default: one per core)",
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        default=None,
        help="run the packs on this Dask distributed scheduler (e.g. tcp://host:8786) "
        "instead of local processes; needs granpack[dask]",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    p.add_argument(
        "--fast",
        action="store_true",
        help="PackScene.fast(): adaptive settling, freezing of buried settled particles, "
        "a larger dt where the scene's is below 0.55 of the stable step (3D presets), "
        "and 0.75 of it once each layer has landed (ensemble statistics within one sd, "
        "see the README)",
    )
    # Development and test knobs (not the paper's physics): hidden from --help.
    p.add_argument("--settle-time", type=_positive_float, default=None, help=argparse.SUPPRESS)
    p.add_argument("--scale", type=_positive_float, default=None, help=argparse.SUPPRESS)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``granpack`` command."""
    from . import __version__

    parser = _Parser(
        prog="granpack",
        description="Dense random packs of discs and spheres, layer by layer (RSA + DEM "
        "jamming), and their microstructure.",
        epilog="Start with: granpack paper --quick",
    )
    from ._core import cpu_level

    parser.add_argument(
        "--version",
        action="version",
        version=f"granpack {__version__} (kernels for {cpu_level()})",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    g = sub.add_parser(
        "generate",
        help="make an ensemble of packs of a scene, with microstructure, tables, pictures",
        description="Makes N packs of a scene (a preset 4.1-4.4 or a TOML file) and writes "
        "each pack (packs/), its microstructure (micro/), the ensemble tables (tables/), "
        "the pictures (figures/) and report.md under --out.",
    )
    g.add_argument("scene", metavar="SCENE", help="preset name (4.1, 4.2, 4.3, 4.4) or TOML file")
    g.add_argument("--packs", type=_packs, default=1, help="ensemble size (default 1)")
    g.add_argument("--seed", type=_seed, default=None, help="master seed (default: the scene's, 0)")
    g.add_argument(
        "--rotations",
        type=_on_off,
        default=None,
        metavar="on|off",
        help="integrate spins during jamming (default: the scene's, on)",
    )
    g.add_argument(
        "--container",
        choices=["box", "periodic", "cylinder"],
        default=None,
        help="what bounds the pack laterally: the walled box, periodic horizontal axes, "
        "or a vertical cylinder (3D) (default: the scene's, box)",
    )
    g.add_argument(
        "--cylinder-radius",
        type=_positive_float,
        default=None,
        metavar="R",
        help="radius of the cylinder (m); the base becomes (2R, 2R) (default: half the "
        "scene's base)",
    )
    g.add_argument(
        "--trim",
        action="store_true",
        default=None,
        help="a flat top: after the last layer remove every particle above the desired "
        "height and relax the rest (default: the scene's, off)",
    )
    g.add_argument("--out", type=Path, default=None, help="output folder (default: granpack-SCENE)")
    g.add_argument("--no-figures", action="store_true", help="skip the pictures")
    _add_run_options(g)

    pp = sub.add_parser(
        "paper",
        help="reproduce the paper's section 4 (examples 4.1-4.4, rotations on and off)",
        description="Runs the paper's examples 4.1-4.4 with rotations ON and OFF, n packs "
        "each, and writes tables 2-13 with the paper's numbers beside ours, the extra "
        "microstructure tables, the figures, and report.md under --out.",
    )
    pp.add_argument(
        "--out",
        type=Path,
        default=Path("granpack-paper"),
        help="output folder (default: granpack-paper)",
    )
    pp.add_argument(
        "--packs",
        type=_packs,
        default=None,
        help=f"packs per case (default {PAPER_PACKS}, as in the paper; {QUICK_PACKS} with --quick)",
    )
    pp.add_argument(
        "--quick",
        action="store_true",
        help=f"{QUICK_PACKS} packs per case instead of {PAPER_PACKS} (same scenes and physics): "
        "a first look in a fifth of the time",
    )
    pp.add_argument(
        "--examples",
        nargs="+",
        choices=sorted(PAPER_EXAMPLES),
        default=sorted(PAPER_EXAMPLES),
        metavar="EX",
        help="examples to run (default: all of 4.1 4.2 4.3 4.4)",
    )
    pp.add_argument("--seed", type=_seed, default=0, help="master seed (default 0)")
    _add_run_options(pp)

    a = sub.add_parser(
        "analyze",
        help="microstructure of a saved pack or of particles from another code",
        description="Prints the microstructure of a granpack pack (.npz), a LAMMPS or "
        "LIGGGHTS dump custom file (columns x y z or xs ys zs, radius or diameter, id), a "
        "LAMMPS data file (atom_style sphere), YADE's text export (#format x_y_z_r), "
        "extended XYZ with a radius property, a gsd file (HOOMD-blue's schema), a CSV or "
        "Parquet table with columns x y (z) "
        "and r, radius or diameter, or a plain text file with columns x y r (2D) or "
        "x y z r (3D; lines starting with # are comments). The format is detected from the "
        "content and the suffix, and printed. --contacts adds another code's contact "
        "forces.",
    )
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
        choices=CONTAINER_KINDS,
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
    a.add_argument("--json", action="store_true", help="print JSON instead of a table")
    a.add_argument("--figures", type=Path, default=None, metavar="DIR", help="also draw pictures")
    a.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")

    e = sub.add_parser(
        "export",
        help="write a pack for ParaView (vtk), LAMMPS, LIGGGHTS, YADE, OVITO/ASE (xyz), "
        "OVITO/freud/HOOMD-blue (gsd), csv, parquet, or the DEM codes Kratos, MercuryDPM, "
        "PFC and DEM-Engine",
        description="Writes a saved pack as a VTK XML unstructured grid (.vtu: particles "
        "with radius, layer, velocity, spin, contact count; contacts as lines with their "
        "forces; the container in <stem>.container.vtu), a LAMMPS data file for atom_style "
        "sphere with in.granpack, the input that continues the run in LAMMPS (lammps) or "
        "LIGGGHTS (liggghts), YADE's text format (yade), extended XYZ (xyz), a gsd file "
        "for OVITO, freud and HOOMD-blue (gsd), CSV/Parquet tables of particles and "
        "contacts, or the particles for another DEM code: a Kratos DEM model part (kratos, "
        ".mdpa), a MercuryDPM .data file (mercurydpm), a PFC 7 command file (pfc) or "
        "DEM-Engine's clump CSV with its sphere templates (demengine).",
    )
    e.add_argument("pack", type=Path, metavar="PACK", help="a pack file (.npz)")
    e.add_argument(
        "--format",
        choices=(
            *("vtk", "lammps", "liggghts", "yade", "xyz", "csv", "parquet", "gsd"),
            *("kratos", "mercurydpm", "pfc", "demengine"),
        ),
        default=None,
        help="output format (default: from the suffix of --out)",
    )
    e.add_argument("--out", type=Path, default=None, help="output file (default: beside PACK)")
    e.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")

    t = sub.add_parser(
        "tile",
        help="copy a periodic pack nx x ny times into one larger periodic pack",
        description="Copies a pack made in a periodic cell (container = 'periodic') NX "
        "times along x and NY times along y (3D; NX alone in 2D) into one pack file: the "
        "contacts across the junctions are those of the original's seam, with their "
        "forces, so Z, phi, the fabric and the force tensors are the original's. The "
        "tiled pack repeats exactly, with the original cell as its period.",
    )
    t.add_argument("pack", type=Path, metavar="PACK", help="a periodic pack file (.npz)")
    t.add_argument(
        "counts",
        type=_positive_int,
        nargs="+",
        metavar="COUNT",
        help="copies along x (and y in 3D), each >= 1",
    )
    t.add_argument(
        "--out",
        type=Path,
        default=None,
        help="output pack file (default: <PACK stem>_tiled_NXxNY.npz beside PACK)",
    )
    t.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    return parser


# -- shared pieces -------------------------------------------------------------------------------


def _scene_from_arg(text: str):
    from .scene import PRESETS, PackScene

    if text in PRESETS:
        return PackScene.preset(text), text
    path = Path(text)
    if path.suffix.lower() == ".toml" or path.exists():
        return PackScene.from_toml(path), path.stem
    raise GranpackError(
        f"unknown scene {text!r}: give a preset ({', '.join(sorted(PRESETS))}) or a TOML file"
    )


def _dev_changes(scene, args) -> dict:
    """Scene changes from the hidden development options (--scale, --settle-time)."""
    changes = {}
    if args.settle_time is not None:
        changes["settle_time"] = args.settle_time
    if args.scale is not None:
        changes["base"] = tuple(b * args.scale for b in scene.base)
        changes["height"] = scene.height * args.scale
        if scene.cylinder_radius is not None:
            changes["cylinder_radius"] = scene.cylinder_radius * args.scale
    return changes


def _dev_note(args) -> dict:
    """The hidden development options in force, for the report's warning."""
    note = {}
    if args.settle_time is not None:
        note["settle_time"] = f"{args.settle_time:g} s per layer"
    if args.scale is not None:
        note["base and height scaled by"] = f"{args.scale:g}"
    return note


@contextlib.contextmanager
def _locked(out: Path) -> Iterator[None]:
    """Holds the output folder's lock (an exclusive flock on out/.granpack.lock) while
    a run writes into it: a second run into the same folder is refused at once, instead
    of mixing its packs, tables and report with the first one's. The kernel drops the
    lock when the process ends, however it ends."""
    import fcntl

    out.mkdir(parents=True, exist_ok=True)
    path = out / LOCK_NAME
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno not in (errno.EWOULDBLOCK, errno.EACCES, errno.EAGAIN):
                raise
            try:
                holder = os.pread(fd, 64, 0).decode(errors="replace").strip()
            except OSError:
                holder = ""
            who = f" (process {holder})" if holder.isdigit() else ""
            raise GranpackError(
                f"another granpack run{who} is writing into {out}; wait for it to finish "
                "or choose another --out"
            ) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        os.close(fd)


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def _sweep_temporaries(out: Path, console: _Console) -> None:
    """Removes, and names, the temporaries that writes cut off by a kill left in the
    output folder (only files named as granpack's atomic writes name them). Called
    under the folder's lock: no other run is writing there."""
    from .pack import remove_stale_temporaries

    _say_removed(remove_stale_temporaries(out), out, console)


def _say_removed(removed: list[Path], out: Path, console: _Console) -> None:
    """A note naming the stale temporaries removed under `out`, if any."""
    if removed:
        names = ", ".join(str(p.relative_to(out)) for p in removed[:5])
        more = f" and {len(removed) - 5} more" if len(removed) > 5 else ""
        console.note(
            f"removed {len(removed)} stale temporary file(s) that an interrupted run left: "
            f"{names}{more}",
            str(out),
        )
        console.flush_notes()


@contextlib.contextmanager
def _unsettled_as_notes(console: _Console) -> Iterator[None]:
    """UnsettledPackWarnings raised while a run makes its packs become console notes
    (one line per kind, with the packs it concerns), not warnings with a source line."""
    from .pack import UnsettledPackWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UnsettledPackWarning)
        try:
            yield
        finally:
            for w in caught:
                if issubclass(w.category, UnsettledPackWarning):
                    label, _, message = str(w.message).partition(": ")
                    console.note(f"unsettled pack: {message}", label)
                else:
                    warnings.warn(w.message, w.category, stacklevel=2)
            console.flush_notes()


def _fresh(target: Path, source: Path) -> bool:
    """True if `target` exists and is not older than `source` (work to skip on rerun)."""
    return target.exists() and target.stat().st_mtime >= source.stat().st_mtime


def _micro_record(pack, m, k: int) -> dict:
    """The per-pack record written to micro/pack_k.json: identity, size, and the
    microstructure's scalars."""
    rec = {
        "pack": k,
        "seed": pack.scene.seed,
        "stream": pack.scene.stream,
        "rotations": pack.scene.rotations,
        "n_particles": len(pack),
        "n_layers": pack.n_layers,
        "height": pack.height,
        "wall_time": pack.wall_time,
    }
    if pack.trim is not None:
        rec.update(
            trim_removed=pack.trim["removed"], trim_top=pack.trim["top"], phi_hd=pack.trim["phi_hd"]
        )
    rec.update(_jsonable(m.to_dict()))
    return rec


def _jsonable(d: dict) -> dict:
    out = {}
    for k, v in d.items():
        if isinstance(v, np.generic):
            v = v.item()
        elif isinstance(v, np.ndarray):
            v = v.tolist()
        out[k] = v
    return out


def _json_text(d: dict) -> str:
    """Strict JSON of a flat dict: an undefined (NaN) quantity is null, so that any JSON
    reader (jq, JavaScript, polars) takes the file."""
    clean = {k: None if isinstance(v, float) and not math.isfinite(v) else v for k, v in d.items()}
    return json.dumps(clean, indent=1, allow_nan=False) + "\n"


def _microstructure(console: _Console, label: str, *args, **kwargs):
    """granpack.microstructure(...), with its MicrostructureWarnings (an undefined
    quantity, e.g. an empty core window in a small pack) turned into notes that the
    console prints once per message, instead of warnings with a source line."""
    from . import analysis as ms

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ms.MicrostructureWarning)
        m = ms.microstructure(*args, **kwargs)
    for w in caught:
        if issubclass(w.category, ms.MicrostructureWarning):
            console.note(str(w.message), label)
        else:
            warnings.warn(w.message, w.category, stacklevel=2)
    return m


def _analyze_packs(paths: Sequence[Path], micro_dir: Path, console: _Console) -> list:
    """Loads each pack, computes its microstructure and writes micro/pack_k.json.
    Returns [(pack, microstructure, record)] in order."""
    from .pack import atomic_write, load_pack

    out = []
    for k, path in enumerate(paths):
        pack = load_pack(path)
        m = _microstructure(console, f"{path.parent.name}/{path.stem}", pack)
        rec = _micro_record(pack, m, k)
        target = micro_dir / (path.stem + ".json")
        atomic_write(target, _json_text(rec).encode())
        out.append((pack, m, rec))
    console.flush_notes()
    return out


def _pack_figures(pack, path: Path, fig_dir: Path, label: str) -> list[Path]:
    """pack_k.png, normals_k.png, forces_k.png for one pack (skipped when newer than
    the pack file)."""
    from . import plot

    stem = path.stem
    made = []
    jobs = [
        (fig_dir / f"{stem}.png", lambda: plot.pack_figure(pack, title=label)),
        (
            fig_dir / f"{stem}_normals.png",
            lambda: plot.normals_figure(pack.contacts.particle_pairs().normal, title=label),
        ),
        (fig_dir / f"{stem}_forces.png", lambda: plot.force_chain_figure(pack, title=label)),
    ]
    for target, build in jobs:
        if not _fresh(target, path):
            plot.save(build(), target)
        made.append(target)
    return made


# -- generate ------------------------------------------------------------------------------------


def cmd_generate(args, console: _Console) -> int:
    scene, name = _scene_from_arg(args.scene)
    if args.rotations is not None:
        scene = scene.replace(rotations=args.rotations)
    if args.cylinder_radius is not None and (args.container or scene.container) != "cylinder":
        raise InvalidParameterError(
            "invalid --cylinder-radius: only --container cylinder has a radius",
            parameter="cylinder_radius",
            value=args.cylinder_radius,
            expected="--container cylinder",
        )
    if args.container is not None or args.cylinder_radius is not None:
        changes: dict = {"container": args.container or scene.container}
        if args.cylinder_radius is not None:
            R = args.cylinder_radius
            changes.update(cylinder_radius=R, base=(2 * R, 2 * R))
        elif changes["container"] != "cylinder":
            changes["cylinder_radius"] = None
        scene = scene.replace(**changes)
    if args.trim:
        scene = scene.replace(trim=True)
    dev = _dev_changes(scene, args)
    if dev:
        scene = scene.replace(**dev)
    if args.fast:
        scene = scene.fast()
    seed = scene.seed if args.seed is None else args.seed
    if scene.stream != 0:
        # An ensemble numbers its packs' streams itself: the scene's is replaced, said.
        console.note(
            f"the scene's stream = {scene.stream} is not used: pack k of the ensemble takes "
            "stream k (0, 1, ...) of the master seed; to vary the packs, give --seed",
            name,
        )
        console.flush_notes()
    scene = scene.replace(seed=seed, stream=0)
    out = args.out if args.out is not None else Path(f"granpack-{name}")
    scene_text = scene.to_toml().encode()
    scene_file = out / "scene.toml"
    # The resolved scene goes to out/scene.toml: when that is the scene file given (a
    # rerun from the folder's own record), it is rewritten only if unchanged.
    source = Path(args.scene)
    if _same_file(scene_file, source) and source.read_bytes() != scene_text:
        raise InvalidParameterError(
            f"invalid --out = {str(out)!r}: it would overwrite the scene file {source} with "
            "the resolved scene (out/scene.toml); choose another --out",
            parameter="out",
            value=str(out),
            expected="a folder whose scene.toml is not the scene file given",
        )
    _refuse_scene_among_outputs(source, out)
    with _locked(out):
        _sweep_temporaries(out, console)
        return _generate_into(args, console, scene, name, seed, out, scene_file, scene_text)


#: What generate and paper write under --out, besides scene.toml: files, then folders.
_RUN_FILES = ("report.md", LOCK_NAME)
_RUN_FOLDERS = ("packs", "micro", "tables", "figures")


def _refuse_scene_among_outputs(source: Path, out: Path) -> None:
    """Refuses a scene file that the run would write over: one of the files or inside
    one of the folders a run writes under `out` (out/scene.toml itself is the rerun
    from the folder's record, checked by the caller)."""
    if not source.exists():
        return
    check_outputs([out / f for f in _RUN_FILES], [source], "--out")
    where = source.resolve()
    for folder in _RUN_FOLDERS:
        if where.is_relative_to((out / folder).resolve()):
            raise InvalidParameterError(
                f"invalid --out = {str(out)!r}: the scene file {source} lies in {out / folder}, "
                "where the run writes its results; move it or choose another --out",
                parameter="out",
                value=str(out),
                expected="a folder whose results do not hold the scene file",
            )


def _generate_into(args, console, scene, name, seed, out, scene_file, scene_text) -> int:
    from . import plot, report, tables
    from .ensemble import ensemble_tasks, run_tasks
    from .pack import atomic_write

    t0 = time.perf_counter()
    tasks = ensemble_tasks(scene, args.packs, out / "packs", seed)
    console.say(f"granpack generate: {args.packs} pack(s) of {name} -> {out}")
    with _unsettled_as_notes(console):
        paths = run_tasks(
            tasks, scheduler=args.scheduler, workers=args.workers, progress=console.progress_mode()
        )
    # Written once the packs are there: a refused run (another scene's packs in the
    # folder) leaves the folder's scene.toml as it was.
    if not (scene_file.exists() and scene_file.read_bytes() == scene_text):
        atomic_write(scene_file, scene_text)
    results = _analyze_packs(paths, out / "micro", console)
    ms = [m for _, m, _ in results]
    records = [rec for _, _, rec in results]

    df = tables.ensemble_table(ms)
    numeric = [c for c, t in zip(df.columns, df.dtypes, strict=True) if t.is_numeric()]
    summary = tables.summary(df, [c for c in numeric if c != "pack"])
    table_files = tables.write_tables({"ensemble": df, "summary": summary}, out / "tables")

    figures: list[Path] = []
    if not args.no_figures:
        fig_dir = out / "figures"
        for (pack, _, _), path in zip(results, paths, strict=True):
            label = f"{name}, rotations {'ON' if scene.rotations else 'OFF'}, {path.stem}"
            figures += _pack_figures(pack, path, fig_dir, label)
        figures.append(
            plot.save(
                plot.analysis_figure([p for p, _, _ in results], ms, title=f"{name}: structure"),
                fig_dir / "analysis.png",
            )
        )
        phis = [rec["phi"] for rec in records]
        figures.append(
            plot.save(
                plot.phi_histogram_figure(
                    {f"rotations {'ON' if scene.rotations else 'OFF'}": phis},
                    title=f"{name}: phi over {len(phis)} pack(s)",
                ),
                fig_dir / "phi_histogram.png",
            )
        )
    rep = report.ensemble_report(
        out,
        scene_name=name,
        scene=scene,
        records=records,
        table_files=table_files,
        figures=figures,
        wall_time=time.perf_counter() - t0,
        dev_changes=_dev_note(args),
    )
    phi = np.array([rec["phi"] for rec in records])
    sd = f" ± {phi.std(ddof=1):.4f}" if phi.size > 1 else ""
    console.say(f"phi = {phi.mean():.4f}{sd} over {phi.size} pack(s)")
    console.say(f"report: {rep}")
    return 0


# -- paper ---------------------------------------------------------------------------------------


def _case_dir(example: str, rotations: bool) -> str:
    return f"{example}-{'on' if rotations else 'off'}"


def cmd_paper(args, console: _Console) -> int:
    with _locked(args.out):
        _sweep_temporaries(args.out, console)
        return _paper_into(args, console)


def _paper_into(args, console: _Console) -> int:
    from . import mass2d, plot, report, tables
    from .ensemble import ensemble_tasks, run_tasks
    from .scene import PackScene

    n_packs = args.packs if args.packs is not None else (QUICK_PACKS if args.quick else PAPER_PACKS)
    out: Path = args.out
    examples = sorted(set(args.examples), key=list(PAPER_EXAMPLES).index)
    cases = [(ex, rot) for ex in examples for rot in (True, False)]

    scenes = {}
    for ex, rot in cases:
        base = PackScene.preset(ex).replace(rotations=rot, seed=args.seed, stream=0)
        dev = _dev_changes(base, args)
        scene = base.replace(**dev) if dev else base
        scenes[ex, rot] = scene.fast() if args.fast else scene
    tasks = []
    for (ex, rot), scene in scenes.items():
        label = f"{ex} {'ON' if rot else 'OFF'}"
        tasks += ensemble_tasks(
            scene, n_packs, out / "packs" / _case_dir(ex, rot), args.seed, label
        )

    # The 2D cases again under the other mass convention (docs/physics.md): cheap beside
    # the 3D cases, and the paper does not say which convention it used.
    other = mass2d.other_convention_tasks(scenes, n_packs, out / "packs", args.seed)
    other_tasks = [t for ts in other.values() for t in ts]

    t0 = time.perf_counter()
    console.say(
        f"granpack paper: examples {' '.join(examples)}, rotations ON and OFF, "
        f"{n_packs} pack(s) each ({len(tasks)} packs"
        + (f", and {len(other_tasks)} under the other 2D mass convention" if other_tasks else "")
        + f") -> {out}"
        + (" [quick: fewer packs than the paper's 10, same physics]" if args.quick else "")
    )
    with _unsettled_as_notes(console):
        run_tasks(
            tasks + other_tasks,
            scheduler=args.scheduler,
            workers=args.workers,
            progress=console.progress_mode(),
        )
    t_packs = time.perf_counter() - t0

    console.say("microstructure, tables and figures ...")
    by_case: dict = {}
    records: dict = {}
    figures: dict = {}
    fig_dir = out / "figures"
    for ex, rot in cases:
        case_tasks = [t for t in tasks if t.path.parent.name == _case_dir(ex, rot)]
        paths = [t.path for t in case_tasks]
        results = _analyze_packs(paths, out / "micro" / _case_dir(ex, rot), console)
        by_case[ex, rot] = [m for _, m, _ in results]
        records[ex, rot] = [rec for _, _, rec in results]
        packs = [p for p, _, _ in results]
        fig_no = PAPER_EXAMPLES[ex][0 if rot else 1]
        onoff = "ON" if rot else "OFF"
        name = f"fig{fig_no}_{ex}_{onoff.lower()}"
        f = {}
        f["packs"] = plot.save(
            plot.packs_figure(
                packs,
                title=f"Fig. {fig_no}: example {ex}, rotations {onoff} ({len(packs)} packs)",
                labels=[f"pack {k + 1}: phi = {p.phi:.3f}" for k, p in enumerate(packs)],
            ),
            fig_dir / f"{name}_packs.png",
        )
        if packs[0].dim == 3:
            f["view"] = plot.save(
                plot.pack_figure(packs[0], title=f"example {ex}, rotations {onoff}, pack 1"),
                fig_dir / f"{name}_pack1_view.png",
            )
        normals = np.concatenate([p.contacts.particle_pairs().normal for p in packs])
        f["normals"] = plot.save(
            plot.normals_figure(
                normals, title=f"example {ex}, rotations {onoff}: all {len(packs)} packs"
            ),
            fig_dir / f"{name}_normals.png",
        )
        f["forces"] = plot.save(
            plot.force_chain_figure(packs[0], title=f"example {ex}, rotations {onoff}, pack 1"),
            fig_dir / f"{name}_forces.png",
        )
        f["analysis"] = plot.save(
            plot.analysis_figure(
                packs, by_case[ex, rot], title=f"example {ex}, rotations {onoff}: structure"
            ),
            fig_dir / f"{name}_analysis.png",
        )
        figures[ex, rot] = f

    paper = tables.paper_tables(by_case)
    table_files = tables.write_tables(paper, out / "tables")

    ref_phi = paper_phi()
    other_phi = {
        (ex, rot): [
            rec["phi"]
            for _, _, rec in _analyze_packs(
                [t.path for t in ts],
                out / "micro" / mass2d.case_dir(ex, rot, ts[0].scene.inertia_2d),
                console,
            )
        ]
        for (ex, rot), ts in other.items()
    }
    mass_2d = mass2d.convention_table(
        scenes, {c: [r["phi"] for r in records[c]] for c in other}, other_phi, ref_phi
    )
    if mass_2d.height:
        table_files += tables.write_tables({"mass_2d": mass_2d}, out / "tables")
    for ex in examples:
        ours = {
            f"rotations {'ON' if rot else 'OFF'}": [r["phi"] for r in records[ex, rot]]
            for rot in (True, False)
        }
        ref = {
            f"rotations {'ON' if rot else 'OFF'}": ref_phi[ex, rot]
            for rot in (True, False)
            if (ex, rot) in ref_phi
        }
        figures[ex, "phi"] = plot.save(
            plot.phi_histogram_figure(ours, ref, title=f"example {ex}: phi, ours vs the paper"),
            fig_dir / f"phi_{ex}.png",
        )

    rep = report.paper_report(
        out,
        examples=examples,
        n_packs=n_packs,
        quick=args.quick,
        records=records,
        paper_phi=ref_phi,
        table_files=table_files,
        figures=figures,
        wall_time=time.perf_counter() - t0,
        pack_time=t_packs,
        dev_changes=_dev_note(args),
        seed=args.seed,
        mass_2d=mass_2d,
    )
    console.say(f"report: {rep}")
    return 0


def paper_phi() -> dict[tuple[str, bool], list[float]]:
    """The paper's per-pack phi {(example, rotations): [10 values]} (its tables 2, 5, 8
    and 11, from `granpack.tables.paper_values`)."""
    import polars as pl

    from . import tables

    out: dict[tuple[str, bool], list[float]] = {}
    for ex, (number, _, _) in tables.PRESET_TABLES.items():
        df = tables.paper_values(number).filter(~pl.col("pack").is_in(list(tables.STAT_LABELS)))
        for rot in (True, False):
            out[ex, rot] = [float(v) for v in df[f"rotations {'ON' if rot else 'OFF'}"]]
    return out


# -- analyze -------------------------------------------------------------------------------------


def _load_for_analysis(args, console: _Console):
    """(particles, microstructure kwargs) for any file read_particles reads; kwargs
    replace the file's box when --box is given."""
    from .io import detect_format, read_particles

    path: Path = args.file
    fmt = args.format or detect_format(path)
    if fmt == "npz" and (args.box is not None or args.dim is not None):
        raise GranpackError("--box and --dim apply to text and LAMMPS files, not to packs")
    particles = read_particles(path, format=fmt, snapshot=args.snapshot, dim=args.dim)
    for note in particles.notes:
        console.note(note, path.name)
    if args.contacts is not None:
        from .io import read_contacts

        found = read_contacts(args.contacts, particles, layout=args.contact_layout)
        for note in found.notes:
            console.note(note, args.contacts.name)
        particles = particles.with_contacts(found)
        args.contacts_read = found
    elif args.contact_layout is not None:
        raise GranpackError("--contact-layout needs --contacts FILE")
    where: dict = {}
    if getattr(args, "container", None) is not None:
        where["container"] = args.container
    if getattr(args, "cylinder_radius", None) is not None:
        where["cylinder_radius"] = args.cylinder_radius
    if args.box is None:
        return particles, where
    if particles.contacts is not None and args.contacts is not None:
        raise GranpackError("--box cannot be combined with --contacts: the dump gives the box")
    dim = particles.dim
    if args.box is not None:
        if len(args.box) != 2 * dim:
            raise InvalidParameterError(
                f"invalid --box: {len(args.box)} values, expected {2 * dim} "
                f"(lo hi for each of the {dim} axes)"
            )
        v = np.asarray(args.box, dtype=np.float64)
        box = (v[0::2], v[1::2])
        if np.any(box[1] <= box[0]):
            raise InvalidParameterError("invalid --box: every axis needs lo < hi")
    if "container" not in where and particles.container is not None:
        # --box replaces the file's box, not its container
        where["container"] = particles.container
        if particles.cylinder_radius is not None and "cylinder_radius" not in where:
            where["cylinder_radius"] = particles.cylinder_radius
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


def cmd_analyze(args, console: _Console) -> int:
    particles, kwargs = _load_for_analysis(args, console)
    pack = particles.pack
    if "positions" in kwargs:
        m = _microstructure(console, args.file.name, **kwargs)
    else:
        m = _microstructure(console, args.file.name, particles, **kwargs)
    if m.container_source == "assumed":
        console.note(
            f"the file does not say its container: analysed as a {m.container} "
            f"({'walls at the file box' if particles.box is not None else 'no walls'}); "
            "give --container box|periodic|cylinder to choose",
            args.file.name,
        )
    console.flush_notes()
    d = _jsonable(m.to_dict())
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
        print(_json_text(d), end="")
    elif not args.quiet:
        width = max(len(k) for k in d)
        for k, v in d.items():
            print(f"{k:<{width}}  {_format_value(v)}")
    if args.figures is not None:
        from types import SimpleNamespace

        from . import plot

        subject = pack
        if subject is None:
            subject = SimpleNamespace(positions=particles.positions, radii=particles.radii)
        check_outputs(
            [
                args.figures / f"{args.file.stem}{suffix}.png"
                for suffix in ("", "_normals", "_forces")
            ],
            [args.file, args.contacts],
            "--figures",
        )
        made = [
            plot.save(
                plot.pack_figure(subject, title=args.file.name),
                args.figures / f"{args.file.stem}.png",
            )
        ]
        if pack is not None:
            contacts = pack.contacts
        else:  # the particle-particle contacts the analysis found, for the normals
            from . import _core
            from .contacts import Contacts

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


# -- export --------------------------------------------------------------------------------------


def cmd_export(args, console: _Console) -> int:
    from .io import EXPORT_FORMATS as FORMATS
    from .io import export
    from .pack import load_pack

    fmt = args.format
    if fmt is None and args.out is None:
        raise GranpackError(
            "give --format (vtk, lammps, liggghts, yade, xyz, csv, parquet, gsd, kratos, "
            "mercurydpm, pfc, demengine) or an --out file name"
        )
    out = args.out
    if out is None:
        out = args.pack.with_suffix(FORMATS[fmt])
    pack = load_pack(args.pack)
    files = export(pack, out, fmt, refuse=[args.pack], parameter="--out")
    for f in files:
        console.say(str(f))
    # the temporaries an export of the same files left when it was killed
    from .pack import remove_stale_temporaries

    for folder in sorted({f.parent for f in files}):
        names = [f.name for f in files if f.parent == folder]
        _say_removed(remove_stale_temporaries(folder, of=names), folder, console)
    return 0


# -- tile ----------------------------------------------------------------------------------------


def cmd_tile(args, console: _Console) -> int:
    from .pack import load_pack, remove_stale_temporaries
    from .tile import tile

    counts = tuple(args.counts)
    out = args.out
    if out is None:
        label = "x".join(str(c) for c in counts)
        out = args.pack.with_name(f"{args.pack.stem}_tiled_{label}.npz")
    check_outputs([out], [args.pack], parameter="--out")
    t0 = time.perf_counter()
    pack = load_pack(args.pack)
    tiled = tile(pack, counts)
    path = tiled.save(out)  # atomic: a temporary file, then a rename
    console.say(
        f"{path}: {len(pack)} particles x {math.prod(counts)} copies = {len(tiled)} "
        f"particles, {len(tiled.contacts)} contacts, base "
        f"{' x '.join(f'{b:g}' for b in tiled.scene.base)} m "
        f"({time.perf_counter() - t0:.2f} s)"
    )
    _say_removed(remove_stale_temporaries(path.parent, of=[path.name]), path.parent, console)
    return 0


# -- entry point ---------------------------------------------------------------------------------

_COMMANDS = {
    "generate": cmd_generate,
    "paper": cmd_paper,
    "analyze": cmd_analyze,
    "export": cmd_export,
    "tile": cmd_tile,
}


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the ``granpack`` command with `argv` (default: ``sys.argv[1:]``); returns the
    exit status (0 ok, 1 failure, 2 bad input, 130 interrupted)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    console = _Console(getattr(args, "quiet", False))
    previous = _handle_sigterm()
    try:
        return _COMMANDS[args.command](args, console)
    except GranpackError as exc:
        print(f"granpack {args.command}: error: {_cut(str(exc))}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt as exc:
        where = getattr(args, "out", None)
        hint = f" in {where}" if where and args.command in ("generate", "paper") else ""
        how = "terminated (SIGTERM)" if isinstance(exc, _Terminated) else "interrupted"
        print(
            f"granpack {args.command}: {how}; finished packs are on disk{hint}; "
            "run the same command again to continue",
            file=sys.stderr,
        )
        return EXIT_TERMINATED if isinstance(exc, _Terminated) else EXIT_INTERRUPTED
    except OSError as exc:
        target = f" {exc.filename}" if getattr(exc, "filename", None) else ""
        print(f"granpack {args.command}: error:{target} {exc.strerror or exc}", file=sys.stderr)
        return 1
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _on_sigterm(signum, frame) -> None:
    raise _Terminated()


def _handle_sigterm():
    """Makes SIGTERM (a batch scheduler's stop, `kill`) stop a run the way Ctrl-C does:
    the packs in progress are stopped, the worker processes ended, the finished packs
    kept, and a message printed. Returns the previous handler (None where the handler
    cannot be set: not the main thread)."""
    try:
        return signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:
        return None


if __name__ == "__main__":  # python -m granpack.cli
    sys.exit(main())
