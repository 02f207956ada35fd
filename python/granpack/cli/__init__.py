"""The ``granpack`` command.

::

    granpack paper --quick                 # the paper's section 4, 2 packs per case
    granpack paper --out DIR [--packs 10]  # the full reproduction
    granpack generate 4.3 --packs 10 --seed 1 --rotations off --out DIR
    granpack generate my_scene.toml --out DIR
    granpack analyze DIR/packs/pack_000.npz          # or a dump, data, text, CSV file
    granpack export DIR/packs/pack_000.npz --format vtk   # vtk | lammps | csv | parquet
    granpack tile DIR/packs/pack_000.npz 4 4 --out big.npz  # a periodic pack, 4 x 4 copies
    granpack consolidate DIR/packs/pack_000.npz --stress 1e5 --mode oedometric
    granpack triaxial sample.npz -o tri.npz --axial-strain 0.2   # on a consolidated pack
    granpack oedometer sample.npz --stresses 50e3,100e3,200e3,100e3 -o oed.npz
    granpack generate 4.3 --consolidate 1e5 --target-phi 0.62   # a density target
    granpack limits 4.3 --packs 5 --fast             # the model's e_min and e_max

Packs run in local worker processes (all cores) or, with ``--scheduler ADDRESS``, on a
Dask cluster (``--write-on-workers``: its workers save the packs themselves, on a batch
cluster's shared file system); the results are the same for the same master seed. Every
finished pack is on disk at once, and running the same command again skips what is there.

Bad input gives one line on stderr and exit status 2; an interrupted run exits with 130
(Ctrl-C) or 143 (SIGTERM), after the same clean stop: the packs in progress are
stopped, the finished ones are on disk. One run at a time writes into an output folder
(a second one is refused while the first holds the folder's lock), and no command
writes over one of its own input files.
"""

from __future__ import annotations

import argparse
import importlib
import signal
import sys
from collections.abc import Sequence

from .._console import Console
from .._malloc import one_arena
from .._outputs import LOCK_NAME as LOCK_NAME
from .._validate import GranpackError

__all__ = ["main", "build_parser"]

#: The commands, in the order of ``granpack --help``; each is the module of that name in
#: this package, with HELP, DESCRIPTION, ``add_arguments(parser)`` and ``run(args, console)``.
COMMANDS = (
    "generate",
    "paper",
    "analyze",
    "export",
    "tile",
    "consolidate",
    "triaxial",
    "oedometer",
    "isotropic",
    "limits",
)

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 128 + signal.SIGTERM
#: Longest error message printed whole; longer ones are cut in the middle.
MAX_MESSAGE = 600


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


def _command(name: str):
    """The module of command `name`: ``granpack.cli.<name>``."""
    return importlib.import_module(f"{__name__}.{name}")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``granpack`` command."""
    from .._core import __version__, cpu_level

    parser = _Parser(
        prog="granpack",
        description="Dense random packs of discs and spheres, layer by layer (RSA + DEM "
        "jamming), and their microstructure.",
        epilog="Start with: granpack paper --quick",
    )
    parser.add_argument(
        "--version",
        action="version",
        version=f"granpack {__version__} (kernels for {cpu_level()})",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in COMMANDS:
        command = _command(name)
        p = sub.add_parser(name, help=command.HELP, description=command.DESCRIPTION)
        command.add_arguments(p)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the ``granpack`` command with `argv` (default: ``sys.argv[1:]``); returns the
    exit status (0 ok, 1 failure, 2 bad input, 130 interrupted)."""
    if argv is None:
        # the command itself, not a caller in its own process: glibc's one arena (see
        # granpack._malloc), before any engine thread starts
        one_arena()
    parser = build_parser()
    args = parser.parse_args(argv)
    console = Console(getattr(args, "quiet", False))
    previous = _handle_sigterm()
    try:
        return _command(args.command).run(args, console)
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
