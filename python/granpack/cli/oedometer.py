"""``granpack oedometer``: oedometric loading and unloading of a consolidated pack, with
its table, lab report and figure."""

from __future__ import annotations

import argparse

from .._console import Console
from . import _element

HELP = "oedometric loading and unloading of a consolidated pack"
DESCRIPTION = (
    "Takes the lid of a consolidated pack (granpack consolidate) through each of "
    "--stresses in turn with its servo, each held to equilibrium, the side walls fixed "
    "(a periodic cell keeps its periods). Writes the pack at the last stress (its "
    "history holds the test's record), the table (CSV: the sample at the start, then "
    "one row per stress), the lab report (JSON: Cc, Cs, K0) and the figure (PNG: e "
    "against log sigma_v); "
    "docs/element_tests.md defines each quantity."
)

#: The function's arguments and the options that give them, for the errors.
OPTIONS = _element.PATH_OPTIONS


def add_arguments(parser: argparse.ArgumentParser) -> None:
    _element.add_path_arguments(parser, "oedometer")


def run(args: argparse.Namespace, console: Console) -> int:
    return _element.run_path(args, console, "oedometer")
