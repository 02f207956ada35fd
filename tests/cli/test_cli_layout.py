"""The ``granpack`` command is one module per command, each small enough to read whole."""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest

import granpack.cli
from granpack.cli import COMMANDS, build_parser

CLI_DIR = Path(granpack.cli.__file__).parent
#: The longest a module of the command may grow before it is split.
MAX_LINES = 300


@pytest.mark.parametrize("name", COMMANDS)
def test_each_command_module_has_add_arguments_and_run(name):
    module = importlib.import_module(f"granpack.cli.{name}")
    assert callable(module.add_arguments)
    assert callable(module.run)
    assert module.HELP and module.DESCRIPTION


def test_every_command_module_is_a_command_of_the_parser():
    modules = {p.stem for p in CLI_DIR.glob("*.py") if not p.stem.startswith("_")}
    assert modules == set(COMMANDS)
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    assert list(sub.choices) == list(COMMANDS)


def test_no_module_of_the_command_exceeds_300_lines():
    lengths = {p.name: len(p.read_text().splitlines()) for p in CLI_DIR.glob("*.py")}
    too_long = {name: n for name, n in lengths.items() if n > MAX_LINES}
    assert not too_long, f"split these modules of granpack.cli: {too_long}"
