"""Ensembles on a Dask cluster whose workers save their packs themselves
(``write_on_workers``): the same packs as made here, written by the workers, only their
numbers sent back, reruns that skip them, and errors that name the pack."""

from __future__ import annotations

import os
import types

import numpy as np
import pytest

import granpack as gp
from granpack import ensemble
from granpack.cli import main
from granpack.ensemble import PackSummary, ensemble_tasks, pack_path, run_ensemble, run_tasks

distributed = pytest.importorskip("distributed")

SEED = 5


@pytest.fixture(scope="module")
def scene() -> gp.PackScene:
    # 0.3 s per layer is a little less than the 0.316 s a layer needs to fall through
    # its slab: every pack warns (UnsettledPackWarning), which checks that the warning
    # comes back from the worker's summary.
    return gp.PackScene.preset("4.1").replace(base=(0.2,), height=0.06, settle_time=0.3)


@pytest.fixture(scope="module")
def reference(scene, tmp_path_factory) -> list[gp.Pack]:
    """Three packs made one after the other in this process."""
    out = tmp_path_factory.mktemp("here")
    with pytest.warns(gp.UnsettledPackWarning):
        paths = run_ensemble(scene, 3, SEED, out, workers=1, progress=False)
    return [gp.load_pack(p) for p in paths]


@pytest.fixture(scope="module")
def cluster():
    """Two worker processes (as a batch cluster's jobs would be), one thread each."""
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as c:
        yield c


def test_workers_write_the_same_packs_and_send_back_only_summaries(
    scene, reference, cluster, tmp_path, monkeypatch
):
    received: list = []

    def finish_summary(task, summary, prog):
        received.append(summary)
        real_finish_summary(task, summary, prog)

    def no_pack_here(task, pack, prog):
        raise AssertionError(f"{task.label}: a Pack came back to the client")

    real_finish_summary = ensemble._finish_summary
    monkeypatch.setattr(ensemble, "_finish_summary", finish_summary)
    monkeypatch.setattr(ensemble, "_finish", no_pack_here)
    events: list[dict] = []
    with pytest.warns(gp.UnsettledPackWarning) as caught:
        paths = run_ensemble(
            scene,
            3,
            SEED,
            tmp_path,
            scheduler=cluster.scheduler_address,
            write_on_workers=True,
            progress=events.append,
        )
    assert paths == [pack_path(tmp_path, k) for k in range(3)]

    # bit-identical to the packs made here, one after the other
    for path, ref in zip(paths, reference, strict=True):
        got = gp.load_pack(path)
        assert got.scene == ref.scene
        for name in ("positions", "radii", "velocities", "spins", "layer"):
            np.testing.assert_array_equal(getattr(got, name), getattr(ref, name), err_msg=name)
        assert got.height == ref.height

    # the client got one summary per pack, with the pack's own numbers, and no pack
    assert all(type(s) is PackSummary for s in received)
    by_path = {s.path: s for s in received}
    assert sorted(by_path) == sorted(os.path.abspath(p) for p in paths)
    for path, ref in zip(paths, reference, strict=True):
        s = by_path[os.path.abspath(path)]
        assert (s.n, s.phi, s.height) == (len(ref), ref.phi, ref.height)
        assert s.issue == gp.pack.settling_issue(ref) and s.issue is not None
        assert s.wall_time > 0
    packs = [e for e in events if e["event"] == "pack"]
    assert sorted(e["label"] for e in packs) == ["#0", "#1", "#2"]
    assert sorted(e["n"] for e in packs) == sorted(len(p) for p in reference)
    # each pack's settling warning, from its summary, names the pack
    texts = [str(w.message) for w in caught if w.category is gp.UnsettledPackWarning]
    assert sorted(t.split(":")[0] for t in texts) == ["#0", "#1", "#2"]
    # nothing half-written left behind by the workers' atomic writes
    assert sorted(p.name for p in tmp_path.iterdir()) == [p.name for p in paths]

    # a second run skips every pack (the check runs here, on the shared folder)
    mtimes = [p.stat().st_mtime_ns for p in paths]
    events.clear()
    received.clear()
    run_ensemble(
        scene,
        3,
        SEED,
        tmp_path,
        scheduler=cluster.scheduler_address,
        write_on_workers=True,
        progress=events.append,
    )
    assert sorted(e["label"] for e in events if e["event"] == "skip") == ["#0", "#1", "#2"]
    assert not [e for e in events if e["event"] == "pack"] and not received
    assert [p.stat().st_mtime_ns for p in paths] == mtimes


def test_a_pack_that_fails_on_a_worker_is_named(cluster, tmp_path):
    # A layer fraction near the RSA limit saturates during the build, on the worker.
    bad = gp.PackScene.preset("4.1").replace(
        base=(0.1,), phi_layer=0.54, max_attempts=2000, settle_time=0.0
    )
    with pytest.raises(gp.GranpackError, match=r"^#\d: .*saturated"):
        run_ensemble(
            bad,
            2,
            0,
            tmp_path,
            scheduler=cluster.scheduler_address,
            write_on_workers=True,
            progress=False,
        )
    assert not list(tmp_path.iterdir())


def test_a_pack_a_worker_cannot_write_is_named(scene, cluster, tmp_path):
    # the output folder's path runs through a regular file: the worker cannot write there
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    tasks = ensemble_tasks(scene, 1, blocker / "packs", SEED, label="blocked")
    with pytest.raises(
        gp.GranpackError, match=r"^blocked #0: the worker on \S+ cannot write the pack: .*packs"
    ):
        run_tasks(tasks, scheduler=cluster.scheduler_address, write_on_workers=True, progress=False)
    assert blocker.read_text() == "not a folder"


def test_packs_this_process_cannot_see_are_an_error(scene, tmp_path):
    # as when the workers' folder is not the one this process sees (no shared file system)
    tasks = ensemble_tasks(scene, 4, tmp_path, SEED)
    pack_path(tmp_path, 3).write_bytes(b"seen")
    written = [(t, PackSummary(str(t.path), 10, 0.8, 0.05, 1.0, None, "node17")) for t in tasks]
    with pytest.raises(gp.GranpackError) as err:
        ensemble._check_written(written, wait=0.0)
    text = str(err.value)
    assert text.startswith("3 pack(s) the Dask workers wrote are not visible here")
    assert "#0 (" in text and "#2 (" in text and "#3" not in text
    assert "node17" in text and "share" in text
    ensemble._check_written(written[3:], wait=0.0)  # the one this process sees passes


def test_write_on_workers_needs_a_scheduler(scene, tmp_path, capsys):
    with pytest.raises(gp.InvalidParameterError, match="write_on_workers") as err:
        run_ensemble(scene, 1, SEED, tmp_path / "a", write_on_workers=True, progress=False)
    assert err.value.parameter == "write_on_workers"
    with pytest.raises(gp.InvalidParameterError, match="must be True or False"):
        run_ensemble(scene, 1, SEED, tmp_path / "a", write_on_workers="yes", progress=False)
    # the command refuses it before it writes anything
    argv = ["generate", "4.1", "--out", str(tmp_path / "b"), "--write-on-workers"]
    assert main(argv) == 2
    assert "--scheduler" in capsys.readouterr().err
    argv = ["paper", "--quick", "--out", str(tmp_path / "c"), "--write-on-workers"]
    assert main(argv) == 2
    assert "invalid write_on_workers = True without a scheduler" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_generate_command_with_write_on_workers(scene, reference, cluster, tmp_path, capsys):
    toml = tmp_path / "scene.toml"
    toml.write_text(scene.to_toml())
    out = tmp_path / "out"
    argv = ["generate", str(toml), "--packs", "2", "--seed", str(SEED), "--out", str(out)]
    argv += ["--scheduler", cluster.scheduler_address, "--write-on-workers", "--no-figures"]
    assert main([*argv, "-q"]) == 0
    for k in range(2):
        got = gp.load_pack(out / "packs" / f"pack_00{k}.npz")
        np.testing.assert_array_equal(got.positions, reference[k].positions)
    assert (out / "report.md").exists()
    assert capsys.readouterr() == ("", "")


def test_a_pack_whose_workers_died_is_named(scene, tmp_path, monkeypatch):
    # Dask gives up on a task once the workers that ran it died (the batch job's walltime,
    # the out-of-memory killer): KilledWorker, as the task's result here.
    def killed(scene, path, engine=()):
        last = types.SimpleNamespace(address="tcp://node17:40000")
        raise distributed.KilledWorker("task", last, 3)

    monkeypatch.setattr(ensemble, "_build_and_save", killed)
    with distributed.LocalCluster(
        processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0"
    ) as local:
        with pytest.raises(gp.GranpackError, match=r"^#0: the Dask workers that ran it died"):
            run_ensemble(
                scene,
                1,
                SEED,
                tmp_path,
                scheduler=local.scheduler_address,
                write_on_workers=True,
                progress=False,
            )
    assert not list(tmp_path.iterdir())
