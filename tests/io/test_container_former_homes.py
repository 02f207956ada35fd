"""The container's former homes: `granpack.container_tag` and `granpack.dem_input` still
import, warn once with a DeprecationWarning naming the new home, and give what the new
names give."""

from __future__ import annotations

import importlib
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from scenes import small_scene

import granpack as gp
from granpack.analysis.container import Container, ContainerTag, wall_names
from granpack.io import lammps_input

PYTHON_DIR = Path(gp.__file__).resolve().parent.parent


def _import_fresh(name: str) -> tuple[object, list[warnings.WarningMessage]]:
    sys.modules.pop(name, None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        module = importlib.import_module(name)
        importlib.import_module(name)  # a second import is the cached module: no warning
    return module, [w for w in caught if issubclass(w.category, DeprecationWarning)]


@pytest.mark.parametrize(
    ("old", "new"),
    [
        ("granpack.container_tag", "granpack.analysis.container"),
        ("granpack.dem_input", "granpack.io.lammps_input"),
    ],
)
def test_a_former_home_warns_once_naming_the_new_one(old, new):
    _, caught = _import_fresh(old)
    assert len(caught) == 1
    text = str(caught[0].message)
    assert f"{old} is now {new}" in text and "next release" in text


@pytest.mark.parametrize("old", ["granpack.container_tag", "granpack.dem_input"])
def test_a_former_home_warns_once_in_a_fresh_interpreter(old):
    # the first import in a process, as a user's script meets it
    code = (
        "import warnings; warnings.simplefilter('always')\n"
        f"with warnings.catch_warnings(record=True) as w:\n"
        f"    warnings.simplefilter('always')\n"
        f"    import {old}\n    import {old}\n"
        "print(sum(issubclass(x.category, DeprecationWarning) and 'next release' in str(x.message)"
        " for x in w))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env={"PYTHONPATH": str(PYTHON_DIR), "PATH": ""},
    )
    assert out.stdout.strip() == "1"


def test_the_former_tag_functions_give_what_container_gives(tmp_path):
    old, _ = _import_fresh("granpack.container_tag")
    words = old.container_tag("cylinder", 0.1, [0.0, 0.0, 0.0], [0.2, 0.2, 0.5], lid=0.5)
    c = Container.from_tag(words, tmp_path / "f", 1, 3)
    assert c is not None and c.tag_words() == words
    assert c.kind == "cylinder" and c.radius == 0.1 and c.lid_height == 0.5
    tag = old.parse_container_tag(words, tmp_path / "f", 1, 3)
    assert tag.words() == ContainerTag.parse(words, tmp_path / "f", 1, 3).words() == words
    assert old.CONTAINER_KINDS == gp.analysis.CONTAINERS
    assert old.ContainerTag is ContainerTag


def test_container_of_a_pack_is_the_former_container_of():
    old, _ = _import_fresh("granpack.dem_input")
    pack = gp.generate(small_scene(3, container="cylinder").replace(height=0.2).fast())
    c = Container.of_pack(pack)
    assert old.container_of(pack) == (c.kind, c.radius) == ("cylinder", pack.scene.base[0] / 2)
    assert old.lid_height is lammps_input.lid_height and c.lid_height is None
    lo, hi = pack.box
    assert (c.lo == lo).all() and (c.hi == hi).all()


@pytest.mark.parametrize(
    ("kind", "dim", "names"),
    [
        ("box", 3, ["floor", "x_lo", "x_hi", "y_lo", "y_hi", "lid"]),
        ("box", 2, ["floor", "x_lo", "x_hi", "lid"]),
        ("periodic", 3, ["floor", "lid"]),
        ("cylinder", 3, ["floor", "cylinder", "lid"]),
    ],
)
def test_the_wall_names_follow_the_wall_ids(kind, dim, names):
    assert wall_names(kind, dim) == names
    radius = 0.1 if kind == "cylinder" else None
    flags = (kind == "periodic",) * (dim - 1)
    c = Container(kind, np.zeros(dim), np.full(dim, 0.2), flags, radius, lid=True)
    assert c.wall_names == names
    # the engine's order is that of the wall ids: -1 the floor, -2, -3, ... the sides, -6 the lid
    assert len(c.wall_ids()) == len(names)
