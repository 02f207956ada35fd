"""The names a scene may give its container and its radius law come from the engine, and
the type stubs spell the same ones."""

from __future__ import annotations

import ast
import typing
from pathlib import Path

import granpack
from granpack import _core
from granpack.analysis import CONTAINERS as ANALYSIS_CONTAINERS
from granpack.cli import build_parser
from granpack.scene import CONTAINERS, RADIUS_LAWS

STUB = Path(granpack.__file__).with_name("_core.pyi")


def _stub_literal(alias: str) -> tuple[str, ...]:
    """The strings of the `Literal` that `_core.pyi` binds to `alias`."""
    for node in ast.parse(STUB.read_text()).body:
        if isinstance(node, ast.AnnAssign) and getattr(node.target, "id", None) == alias:
            literal = eval(ast.unparse(node.value), {"Literal": typing.Literal})  # noqa: S307
            return typing.get_args(literal)
    raise AssertionError(f"{alias} is not in {STUB.name}")


def test_the_stub_literals_equal_the_engine_lists():
    assert _stub_literal("ContainerName") == _core.CONTAINERS
    assert _stub_literal("RadiusLawName") == _core.RADIUS_LAWS


def test_the_package_takes_its_lists_from_the_engine():
    assert CONTAINERS is _core.CONTAINERS
    assert ANALYSIS_CONTAINERS is _core.CONTAINERS
    assert RADIUS_LAWS is _core.RADIUS_LAWS


def test_the_command_offers_the_engine_containers():
    generate = build_parser()._subparsers._group_actions[0].choices["generate"]  # type: ignore[union-attr]
    option = next(a for a in generate._actions if "--container" in a.option_strings)
    assert tuple(option.choices) == _core.CONTAINERS
