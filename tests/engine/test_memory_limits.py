"""The memory checks take the smallest of the machine's memory, the address-space limit
(RLIMIT_AS) and the control group's memory limit, so that work too large for a limited
process is refused before it starts instead of dying in an allocation."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from scenes import tiny_periodic_2d

import granpack as gp
from granpack._memory import memory_limit

resource = pytest.importorskip("resource")

GIB = 2**30


def _cgroup_tree(tmp_path: Path, v1: str | None, v2: str | None) -> tuple[Path, Path]:
    """A fake /proc/self/cgroup and /sys/fs/cgroup: the process in group /job/step of
    both hierarchies, with memory limits `v1` (on /job) and `v2` (on /job/step)."""
    root = tmp_path / "cgroup"
    (root / "memory" / "job" / "step").mkdir(parents=True)
    (root / "job" / "step").mkdir(parents=True)
    (root / "memory" / "memory.limit_in_bytes").write_text("9223372036854771712\n")
    if v1 is not None:
        (root / "memory" / "job" / "memory.limit_in_bytes").write_text(v1 + "\n")
    (root / "job" / "memory.max").write_text("max\n")
    if v2 is not None:
        (root / "job" / "step" / "memory.max").write_text(v2 + "\n")
    proc = tmp_path / "cgroup.txt"
    proc.write_text("4:memory:/job/step\n0::/job/step\n")
    return proc, root


def test_a_cgroup_v2_limit_below_the_machine_is_the_limit(tmp_path):
    proc, root = _cgroup_tree(tmp_path, None, str(2 * GIB))
    limit = memory_limit(proc_cgroup=proc, cgroup_root=root)
    assert limit is not None and limit.bytes == 2 * GIB
    assert "control group" in limit.source and "memory.max" in limit.source


def test_a_cgroup_v1_limit_on_a_parent_group_counts(tmp_path):
    proc, root = _cgroup_tree(tmp_path, str(3 * GIB), None)
    limit = memory_limit(proc_cgroup=proc, cgroup_root=root)
    assert limit is not None and limit.bytes == 3 * GIB
    assert "memory.limit_in_bytes" in limit.source


def test_the_smallest_limit_wins_and_unlimited_groups_do_not_count(tmp_path):
    proc, root = _cgroup_tree(tmp_path, str(3 * GIB), str(2 * GIB))
    assert memory_limit(proc_cgroup=proc, cgroup_root=root).bytes == 2 * GIB
    proc, root = _cgroup_tree(tmp_path / "none", None, None)
    physical = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    if soft == resource.RLIM_INFINITY:
        assert memory_limit(proc_cgroup=proc, cgroup_root=root).bytes == physical


def test_a_scene_beyond_a_cgroup_limit_is_refused_naming_it(tmp_path, monkeypatch):
    from granpack.pack import BYTES_PER_PARTICLE, check_memory

    proc, root = _cgroup_tree(tmp_path, None, str(2 * GIB))
    monkeypatch.setattr(
        "granpack.pack.memory_limit", lambda: memory_limit(proc_cgroup=proc, cgroup_root=root)
    )
    scene = gp.PackScene.preset("4.3").replace(base=(20.0, 20.0))
    need = scene.estimated_particles() * BYTES_PER_PARTICLE
    physical = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    if need >= 0.8 * physical:
        pytest.skip("the scene is beyond this machine's memory too")
    assert need > 0.8 * 2 * GIB  # beyond the group's limit
    with pytest.raises(gp.InvalidParameterError, match="control group's memory limit"):
        check_memory(scene)


def _limited(argv: list[str], limit: int, cwd: Path) -> subprocess.CompletedProcess:
    """The granpack command run under RLIMIT_AS = `limit` bytes."""

    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    return subprocess.run(
        [sys.executable, "-m", "granpack.cli", *argv],
        preexec_fn=cap,
        capture_output=True,
        text=True,
        cwd=cwd,
        env=env,
        timeout=300,
    )


@pytest.mark.skipif(sys.platform != "linux", reason="RLIMIT_AS as Linux applies it")
def test_tile_under_an_address_space_limit_is_refused_before_the_work(tmp_path):
    sc = tiny_periodic_2d()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gp.UnsettledPackWarning)
        gp.generate(sc).save(tmp_path / "pack.npz")
    # some 30 million discs: ~7 GiB to build, within the particle cap, beyond a 2 GiB
    # address space
    if os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") < 10 * GIB:
        pytest.skip("the tiled pack is beyond this machine's memory too")
    run = _limited(["tile", "pack.npz", "4000000"], 2 * GIB, tmp_path)
    assert run.returncode == 2, run.stderr
    assert "RLIMIT_AS (2.00 GiB)" in run.stderr and "give smaller counts" in run.stderr
    assert "Traceback" not in run.stderr and "MemoryError" not in run.stderr
    assert not (tmp_path / "pack_tiled_4000000.npz").exists()
