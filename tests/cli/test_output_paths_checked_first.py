"""Outputs that cannot be written are refused before the work, naming the output's own
path; a write that fails anyway (a full disk) names the file asked for, never the
temporary file the write goes through."""

from __future__ import annotations

import errno
import os
import tempfile
import warnings

import pytest
from scenes import tiny_periodic_2d

import granpack as gp
from granpack._files import atomic_write
from granpack._validate import check_outputs
from granpack.cli import main


def _blocked(tmp_path):
    """An output whose folder cannot be made: its parent is a regular file."""
    block = tmp_path / "block"
    block.write_text("a file, not a folder")
    return block / "sub" / "out.npz"


# -- atomic_write ------------------------------------------------------------------------


def test_a_full_disk_names_the_file_asked_for(tmp_path):
    path = tmp_path / "pack.npz"

    def full_disk(f):
        f.write(b"x" * 10)
        raise OSError(errno.ENOSPC, "No space left on device")  # as write(2) gives it

    with pytest.raises(OSError) as err:
        atomic_write(path, full_disk)
    assert err.value.errno == errno.ENOSPC
    assert err.value.filename == str(path)
    assert ".tmp" not in str(err.value) and str(path) in str(err.value)
    assert list(tmp_path.iterdir()) == []


def test_a_folder_refusing_the_temporary_names_the_file_asked_for(tmp_path, monkeypatch):
    path = tmp_path / "table.csv"

    def read_only(dir, prefix, suffix):
        # what mkstemp raises in a read-only folder: the temporary's name
        raise PermissionError(errno.EACCES, "Permission denied", f"{dir}/{prefix}abc{suffix}")

    monkeypatch.setattr(tempfile, "mkstemp", read_only)
    with pytest.raises(PermissionError) as err:
        atomic_write(path, b"x")
    assert err.value.filename == str(path)
    assert ".tmp" not in str(err.value)


def test_a_rename_that_fails_names_the_file_asked_for(tmp_path, monkeypatch):
    path = tmp_path / "pack.npz"

    def refused(src, dst):
        raise OSError(errno.EROFS, "Read-only file system", src, None, dst)

    monkeypatch.setattr(os, "replace", refused)
    with pytest.raises(OSError) as err:
        atomic_write(path, b"x")
    assert err.value.errno == errno.EROFS and err.value.filename == str(path)
    assert list(tmp_path.iterdir()) == []  # the temporary is gone


def test_a_file_where_a_folder_should_be_names_the_file_asked_for(tmp_path):
    path = _blocked(tmp_path)
    with pytest.raises(NotADirectoryError) as err:
        atomic_write(path, b"x")
    assert err.value.filename == str(path)


# -- the check before the work -------------------------------------------------------------


def test_outputs_under_a_file_are_refused_before_the_work(tmp_path):
    path = _blocked(tmp_path)
    with pytest.raises(gp.InvalidParameterError) as err:
        check_outputs([path], [], "--out")
    assert err.value.parameter == "out"
    assert f"cannot write {path}" in str(err.value)
    assert "block is not a folder" in str(err.value)


def test_an_output_that_is_a_folder_is_refused(tmp_path):
    (tmp_path / "x.npz").mkdir()
    with pytest.raises(gp.InvalidParameterError, match="not a regular file"):
        check_outputs([tmp_path / "x.npz"], [], "--out")


def test_an_unwritable_folder_is_refused_naming_it(tmp_path, monkeypatch):
    real = os.access
    ro = tmp_path / "ro"
    ro.mkdir()

    def access(p, mode, **kw):  # a read-only mount: access(2) answers EROFS
        return False if os.fspath(p) == str(ro) and mode & os.W_OK else real(p, mode, **kw)

    monkeypatch.setattr(os, "access", access)
    with pytest.raises(gp.InvalidParameterError) as err:
        check_outputs([ro / "new" / "x.json"], [], "--json")
    assert err.value.parameter == "json"
    assert f"the folder {ro} is not writable" in str(err.value)
    assert f"cannot write {ro / 'new' / 'x.json'}" in str(err.value)
    # a writable folder beside it passes
    check_outputs([tmp_path / "ok" / "x.json"], [], "--json")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into any folder")
def test_a_folder_without_write_permission_is_refused(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        with pytest.raises(gp.InvalidParameterError, match="not writable"):
            check_outputs([ro / "x.npz"], [], "--out")
    finally:
        ro.chmod(0o755)


# -- the commands: refused before the stage runs --------------------------------------------


@pytest.fixture(scope="module")
def periodic_pack(tmp_path_factory):
    sc = tiny_periodic_2d()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gp.UnsettledPackWarning)
        pack = gp.generate(sc)
    path = tmp_path_factory.mktemp("pack") / "pack.npz"
    pack.save(path)
    return path


@pytest.mark.parametrize(
    ("argv", "stage"),
    [
        (
            ["consolidate", "{pack}", "--stress", "1e3", "--out", "{out}"],
            "consolidate",
        ),
        (["tile", "{pack}", "2", "--out", "{out}"], "tile"),
    ],
)
def test_commands_refuse_an_unwritable_output_before_the_stage(
    periodic_pack, tmp_path, monkeypatch, capsys, argv, stage
):
    import importlib

    def never(*args, **kwargs):
        raise AssertionError(f"{stage} ran although its output cannot be written")

    module = {"consolidate": "granpack.consolidation", "tile": "granpack.tiling"}[stage]
    monkeypatch.setattr(importlib.import_module(module), stage, never)
    out = _blocked(tmp_path)
    argv = [a.format(pack=periodic_pack, out=out) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"cannot write {out}" in err and ".tmp" not in err


@pytest.mark.parametrize("command", ["generate", "paper"])
def test_runs_into_a_folder_that_cannot_be_made_are_refused_before_the_work(
    tmp_path, capsys, command
):
    out = _blocked(tmp_path).parent  # block/sub: under a regular file
    argv = ["generate", "4.1"] if command == "generate" else ["paper", "--quick"]
    assert main([*argv, "--out", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert f"cannot write {out / 'report.md'}" in err and "is not a folder" in err
