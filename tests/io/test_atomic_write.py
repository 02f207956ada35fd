"""Atomic writes: a write cut off at any point leaves the old file whole and no
temporary file behind (the promise every pack, table and export relies on)."""

from __future__ import annotations

import os

import pytest

from granpack._files import atomic_write


def test_a_write_cut_off_before_the_rename_keeps_the_old_file(tmp_path, monkeypatch):
    path = tmp_path / "pack.npz"
    atomic_write(path, b"old contents")

    def interrupted(src, dst):
        raise KeyboardInterrupt  # Ctrl-C between the write and the rename

    monkeypatch.setattr(os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        atomic_write(path, b"new contents that never land")
    assert path.read_bytes() == b"old contents"
    assert [p.name for p in tmp_path.iterdir()] == ["pack.npz"]


def test_a_failed_write_leaves_no_file_and_no_temporary(tmp_path, monkeypatch):
    path = tmp_path / "sub" / "table.csv"

    def full_disk(fd):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fsync", full_disk)
    with pytest.raises(OSError, match="No space left"):
        atomic_write(path, b"x" * 1000)
    assert not path.exists()
    assert list(path.parent.iterdir()) == []


def test_a_finished_write_replaces_the_file_whole(tmp_path):
    path = tmp_path / "report.md"
    atomic_write(path, b"first")
    atomic_write(path, b"second, longer than the first")
    assert path.read_bytes() == b"second, longer than the first"
    assert [p.name for p in tmp_path.iterdir()] == ["report.md"]


def test_a_writer_that_fails_half_way_keeps_the_old_file(tmp_path):
    """A pack streams its archive into the temporary file: a failure after part of it
    is written leaves the old file whole and no temporary."""
    path = tmp_path / "pack.npz"
    atomic_write(path, b"old contents")

    def half_then_fail(f):
        f.write(b"part of a new archive")
        raise MemoryError

    with pytest.raises(MemoryError):
        atomic_write(path, half_then_fail)
    assert path.read_bytes() == b"old contents"
    assert [p.name for p in tmp_path.iterdir()] == ["pack.npz"]
    atomic_write(path, lambda f: f.write(b"streamed"))
    assert path.read_bytes() == b"streamed"
