"""Ensembles: the same packs wherever they run (this process, local worker processes, a
Dask cluster), finished packs on disk, reruns that skip them, progress reporting."""

from __future__ import annotations

import io

import numpy as np
import pytest

import granpack as gp
from granpack.ensemble import Progress, ensemble_tasks, pack_path, run_ensemble, run_tasks

SEED = 7

# The scene below gives each layer 0.3 s, a little less than the 0.32 s its top needs to
# fall through the slab, so that these bookkeeping tests stay fast: its packs do not
# settle, and UnsettledPackWarning says so. What is checked here is where packs run and
# how they are stored, not whether they rest (tests/stages/test_reliability.py checks the warning).
pytestmark = pytest.mark.filterwarnings("ignore::granpack.UnsettledPackWarning")


@pytest.fixture(scope="module")
def scene() -> gp.PackScene:
    return gp.PackScene.preset("4.1").replace(base=(0.2,), height=0.06, settle_time=0.3)


@pytest.fixture(scope="module")
def reference(scene, tmp_path_factory) -> list[gp.Pack]:
    """Two packs made one after the other in this process."""
    out = tmp_path_factory.mktemp("here")
    paths = run_ensemble(scene, 2, SEED, out, workers=1, progress=False)
    return [gp.load_pack(p) for p in paths]


def _assert_same_packs(paths, reference) -> None:
    assert len(paths) == len(reference)
    for path, ref in zip(paths, reference, strict=True):
        got = gp.load_pack(path)
        assert got.scene == ref.scene
        for name in ("positions", "radii", "velocities", "spins", "layer"):
            np.testing.assert_array_equal(getattr(got, name), getattr(ref, name), err_msg=name)
        for name, col in ref.contacts.to_dict().items():
            np.testing.assert_array_equal(getattr(got.contacts, name), col, err_msg=name)
        assert got.height == ref.height


def test_pack_k_uses_the_master_seed_and_stream_k(reference, scene):
    assert [p.scene.seed for p in reference] == [SEED, SEED]
    assert [p.scene.stream for p in reference] == [0, 1]
    assert not np.array_equal(reference[0].positions[:5], reference[1].positions[:5])
    # The same pack as a direct generate() of that scene.
    direct = gp.generate(scene.replace(seed=SEED, stream=1))
    np.testing.assert_array_equal(direct.positions, reference[1].positions)


def test_local_worker_processes_give_the_same_packs(scene, reference, tmp_path):
    paths = run_ensemble(scene, 2, SEED, tmp_path, workers=2, progress=False)
    assert paths == [pack_path(tmp_path, 0), pack_path(tmp_path, 1)]
    _assert_same_packs(paths, reference)


def test_dask_cluster_gives_the_same_packs(scene, reference, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None
    ) as cluster:
        paths = run_ensemble(
            scene, 2, SEED, tmp_path, scheduler=cluster.scheduler_address, progress=False
        )
    _assert_same_packs(paths, reference)


def test_rerun_skips_finished_packs_and_extends_the_ensemble(scene, reference, tmp_path):
    events: list[dict] = []
    first = run_ensemble(scene, 2, SEED, tmp_path, workers=1, progress=events.append)
    mtimes = [p.stat().st_mtime_ns for p in first]
    assert [e["event"] for e in events].count("pack") == 2

    events.clear()
    paths = run_ensemble(scene, 3, SEED, tmp_path, workers=1, progress=events.append)
    made = [e["label"] for e in events if e["event"] == "pack"]
    skipped = [e["label"] for e in events if e["event"] == "skip"]
    assert made == ["#2"] and skipped == ["#0", "#1"]
    assert [p.stat().st_mtime_ns for p in paths[:2]] == mtimes
    _assert_same_packs(paths[:2], reference)
    assert gp.load_pack(paths[2]).scene.stream == 2
    # Nothing half-written is left behind by the atomic writes.
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "pack_000.npz",
        "pack_001.npz",
        "pack_002.npz",
    ]


def test_a_damaged_pack_file_is_made_again(scene, reference, tmp_path):
    pack_path(tmp_path, 0).write_bytes(b"not a pack")
    paths = run_ensemble(scene, 1, SEED, tmp_path, workers=1, progress=False)
    _assert_same_packs(paths, reference[:1])


def test_a_pack_of_another_scene_in_the_folder_is_an_error(scene, tmp_path):
    run_ensemble(scene, 1, SEED, tmp_path, workers=1, progress=False)
    with pytest.raises(gp.GranpackError, match="different scene"):
        run_ensemble(scene, 1, SEED + 1, tmp_path, workers=1, progress=False)


def test_engine_errors_name_the_pack(tmp_path):
    # A layer fraction near the RSA limit saturates: the engine's error, naming the pack.
    bad = gp.PackScene.preset("4.1").replace(
        base=(0.1,), phi_layer=0.54, max_attempts=2000, settle_time=0.0
    )
    for workers in (1, 2):
        with pytest.raises(gp.GranpackError, match=r"^#\d: .*saturated"):
            run_ensemble(bad, 2, 0, tmp_path, workers=workers, progress=False)
    assert not list(tmp_path.iterdir())


def test_plain_progress_lines_when_not_a_terminal(scene, tmp_path):
    stream = io.StringIO()
    tasks = ensemble_tasks(scene, 2, tmp_path, SEED, label="tiny")
    run_tasks(tasks, workers=1, progress=Progress("auto", stream=stream))
    text = stream.getvalue()
    assert "granpack: 2 packs, 0 already on disk" in text
    assert "[1/2] tiny #0 done: N=" in text and "[2/2] tiny #1 done" in text
    assert "tiny #0: layer 0 N=" in text
    assert "\r" not in text  # no bar redraws in a log file

    quiet = io.StringIO()
    run_tasks(tasks, workers=1, progress=Progress(False, stream=quiet))
    assert quiet.getvalue() == ""


def test_progress_bar_on_a_terminal(scene, tmp_path):
    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True

    stream = Tty()
    run_tasks(ensemble_tasks(scene, 1, tmp_path, SEED), workers=1, progress=Progress(True, stream))
    assert "packs: 100%" in stream.getvalue() and "1.0/1" in stream.getvalue()


def test_bad_arguments_are_clear_errors(scene, tmp_path):
    with pytest.raises(gp.GranpackError, match="n_packs"):
        run_ensemble(scene, 0, SEED, tmp_path)
    with pytest.raises(gp.GranpackError, match="workers"):
        run_ensemble(scene, 1, SEED, tmp_path, workers=0)
    with pytest.raises(gp.GranpackError, match="progress"):
        run_ensemble(scene, 1, SEED, tmp_path, progress="sometimes")
