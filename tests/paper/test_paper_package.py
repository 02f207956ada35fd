"""The paper's reproduction is a library call: `granpack.paper.reproduce`, documented,
with the old homes of its pieces still importable."""

from __future__ import annotations

import inspect
from pathlib import Path

import pytest

import granpack
from granpack.errors import InvalidParameterError
from granpack.paper import reproduce

ROOT = Path(__file__).resolve().parents[2]


def test_reproduce_is_importable_and_documents_each_parameter():
    doc = inspect.getdoc(reproduce)
    assert doc and "report.md" in doc
    params = inspect.signature(reproduce).parameters
    assert list(params)[0] == "out"
    for name in params:
        assert name in doc, f"reproduce's docstring does not document {name}"
    assert "::: granpack.paper" in (ROOT / "docs" / "api.md").read_text()


def test_reproduce_refuses_an_unknown_example_before_any_work(tmp_path):
    out = tmp_path / "paper"
    with pytest.raises(InvalidParameterError, match="5.1"):
        reproduce(out, examples=["5.1"])
    assert not out.exists()


def test_reproduce_returns_the_report(tmp_path):
    out = tmp_path / "paper"
    # tiny scenes (the development options) so that the test runs in seconds
    report = reproduce(
        out, examples=["4.1"], packs=1, scale=0.2, settle_time=0.3, workers=1, quiet=True
    )
    assert report == out / "report.md" and report.is_file()
    assert (out / "tables" / "table2.csv").is_file()
    assert isinstance(granpack.load_pack(out / "packs" / "4.1-on" / "pack_000.npz"), granpack.Pack)
