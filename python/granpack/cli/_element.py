"""What the element-test commands (``granpack triaxial``, ``oedometer``, ``isotropic``)
share: their outputs' names, the stresses' list, the errors named by option, and the
writing of the pack, its table, its lab report and its figure."""

from __future__ import annotations

import argparse
import re
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .._console import Console
from .._outputs import sweep_written
from .._validate import check_outputs
from ..errors import InvalidParameterError
from . import _args

#: The suffixes of a test's side outputs, after the stem of its pack file (--out): the
#: table (CSV), the lab report (JSON) and the figure (PNG).
TABLE_SUFFIX = "_table.csv"
LAB_SUFFIX = "_lab.json"
FIGURE_SUFFIX = ".png"


def stresses(value: str) -> list[float]:
    """An argparse type: a comma-separated list of stresses (Pa), e.g. 25e3,50e3,100e3;
    the test checks their range."""
    items = [s.strip() for s in value.split(",")]
    if not value.strip() or any(s == "" for s in items):
        raise argparse.ArgumentTypeError(
            f"invalid value {_args.short(value)!r}: expected stresses (Pa) separated by "
            "commas, e.g. 25e3,50e3,100e3,50e3"
        )
    out = []
    for s in items:
        try:
            out.append(float(s))
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"invalid stress {_args.short(s)!r}: expected a number (Pa)"
            ) from None
    return out


def add_common(p: argparse.ArgumentParser, test: str, *, wall_friction: float) -> None:
    """PACK, --out (-o), --wall-friction (its default the test function's), --quiet."""
    _args.add_pack(p, "a consolidated pack file (.npz; granpack consolidate)")
    p.add_argument(
        "-o",
        "--out",
        type=Path,
        default=None,
        help=f"output pack file (default: <PACK stem>_{test}.npz beside PACK); the table "
        f"(<OUT stem>{TABLE_SUFFIX}), the lab report (<OUT stem>{LAB_SUFFIX}) and the "
        f"figure (<OUT stem>{FIGURE_SUFFIX}) are written beside it",
    )
    p.add_argument(
        "--wall-friction",
        type=float,
        default=wall_friction,
        metavar="MU",
        help=f"the walls' Coulomb friction during the test, >= 0 (default {wall_friction:g}: "
        "smooth platens and side walls)",
    )
    _args.add_quiet(p)


def outputs(pack: Path, out: Path | None, test: str) -> list[Path]:
    """The pack file, table, lab report and figure a test writes, in that order."""
    if out is None:
        out = pack.with_name(f"{pack.stem}_{test}.npz")
    stem = out.stem
    return [
        out,
        out.with_name(stem + TABLE_SUFFIX),
        out.with_name(stem + LAB_SUFFIX),
        out.with_name(stem + FIGURE_SUFFIX),
    ]


def _by_option(exc: InvalidParameterError, options: dict[str, str]) -> InvalidParameterError:
    """`exc` naming the command's option (``--axial-strain``) rather than the function's
    argument (``axial_strain``), where the argument has one."""
    name = exc.parameter or ""
    key = re.sub(r"\[\d+\]$", "", name)
    option = options.get(key)
    if option is None:
        return exc
    text = str(exc)
    if text.startswith(f"invalid {name}"):
        text = f"invalid {option}{name[len(key) :]}" + text[len(f"invalid {name}") :]
    else:
        text = f"{option}: {text}"
    return InvalidParameterError(text, parameter=option, value=exc.value, expected=exc.expected)


def run_test(
    args: argparse.Namespace,
    console: Console,
    test: str,
    apply: Callable[[Any], Any],
    options: dict[str, str],
) -> int:
    """Runs `test` (`apply(pack)` gives the tested pack) on ``args.pack`` and writes its
    four outputs; the outputs' names are checked before the work, each file is written
    atomically, and none is written where the test fails. `options`: the function's
    argument -> the command's option, for the errors."""
    from ..element import element_table
    from ..element.figures import compression_plot, triaxial_plot
    from ..pack import load_pack
    from ..plot import save

    files = outputs(args.pack, args.out, test)
    check_outputs(files, [args.pack], parameter="--out")
    t0 = time.perf_counter()
    pack = load_pack(args.pack)
    try:
        done = apply(pack)
    except InvalidParameterError as exc:
        raise _by_option(exc, options) from None
    rec = done.record(test)
    assert rec is not None
    table = element_table(done, test)
    label = {args.pack.stem: table}
    # the figure is drawn before any file is written: a table it refuses leaves none
    if test == "triaxial":
        figure = triaxial_plot(label, dim=done.dim)
    else:
        figure = compression_plot(label, dim=done.dim)
    from .._files import atomic_write
    from .._outputs import json_text

    path = done.save(files[0])  # atomic: a temporary file, then a rename
    atomic_write(files[1], table.write_csv().encode())
    atomic_write(files[2], json_text(dict(rec.report["lab"])).encode())
    save(figure, files[3])
    console.say(f"{path}: {len(done)} particles, {summary(test, rec, table)}")
    console.say(
        f"table {files[1].name}, lab report {files[2].name}, figure {files[3].name} "
        f"({time.perf_counter() - t0:.1f} s)"
    )
    sweep_written(files, console)
    return 0


def _g(x: Any, fmt: str = ".4g") -> str:
    return "n/a" if x is None else format(x, fmt)


def summary(test: str, rec: Any, table: Any) -> str:
    """One line of what the test measured."""
    lab = rec.report["lab"]
    last = table.row(-1, named=True)
    if test == "triaxial":
        s = rec.settings
        return (
            f"triaxial at sigma_3 {s['confining']:g} Pa to eps_a {last['eps_a']:.4f} in "
            f"{rec.steps} steps (dt {s['dt']:.3g} s); phi_peak {_g(lab.get('phi_peak'), '.2f')} "
            f"deg, phi_cs {_g(lab.get('phi_cs'), '.2f')} deg, psi_max "
            f"{_g(lab.get('psi_max'), '.2f')} deg, E_50 {_g(lab.get('E_50'))} Pa; "
            f"eps_v {last['eps_v']:.4f}, e {last['e']:.4f}"
        )
    what = "oedometer" if test == "oedometer" else "isotropic compression"
    indices = f"Cc {_g(lab.get('Cc'))}, Cs {_g(lab.get('Cs'))}"
    if test == "oedometer":
        indices += f", K0 {_g(lab.get('k0_virgin'), '.3f')}"
    return (
        f"{what} through {len(rec.settings['stresses'])} stresses in {rec.steps} steps; "
        f"{indices}; "
        f"e {table['e'][0]:.4f} -> {last['e']:.4f}"
    )


#: The stress-path commands' arguments and the options that give them, for the errors.
PATH_OPTIONS = {
    "stresses": "--stresses",
    "stress_tol": "--stress-tol",
    "unbalanced_tol": "--unbalanced-tol",
    "max_steps": "--max-steps",
    "wall_friction": "--wall-friction",
}


def add_path_arguments(parser: argparse.ArgumentParser, test: str) -> None:
    """The options of ``granpack oedometer`` and ``granpack isotropic`` (`test`:
    "oedometer" or "isotropic"), their defaults the functions'."""
    from .. import _core
    from ..element_settings import PATH_DEFAULTS

    c = _core.DEFAULT_CONSOLIDATE
    add_common(parser, test, wall_friction=PATH_DEFAULTS["wall_friction"])
    parser.add_argument(
        "--stresses",
        type=stresses,
        required=True,
        metavar="LIST",
        help="the stresses (Pa; N/m in 2D) to hold in turn, separated by commas, e.g. "
        "25e3,50e3,100e3,200e3,100e3,50e3",
    )
    for option, key, kind in (
        ("--stress-tol", "stress_tol", float),
        ("--unbalanced-tol", "unbalanced_tol", float),
        ("--max-steps", "max_steps", int),
    ):
        parser.add_argument(
            option, type=kind, default=c[key], help=f"per stress; default: {c[key]:g}"
        )


def run_path(args: argparse.Namespace, console: Console, test: str) -> int:
    """``granpack oedometer`` or ``granpack isotropic`` on the parsed `args`."""
    from ..element import isotropic_compression, oedometer

    function = oedometer if test == "oedometer" else isotropic_compression
    return run_test(
        args,
        console,
        test,
        lambda pack: function(
            pack,
            args.stresses,
            stress_tol=args.stress_tol,
            unbalanced_tol=args.unbalanced_tol,
            max_steps=args.max_steps,
            wall_friction=args.wall_friction,
        ),
        PATH_OPTIONS,
    )
