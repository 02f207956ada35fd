"""What a rerun of `granpack generate` into a folder does with what it finds there: a pack
whose scene this version cannot read is an error (never generated over), the scene
file's stream gives way to the ensemble's with a note, and the temporaries of a killed
write are removed, and named."""

from __future__ import annotations

import io
import tempfile

import numpy as np
import pytest

import granpack as gp
from granpack._files import is_temporary
from granpack.cli import main
from granpack.ensemble import ensemble_tasks, pack_path, run_tasks
from granpack.pack import NEWER_FORMAT

TINY = gp.PackScene.preset("4.1").replace(base=(0.2,), height=0.06, settle_time=0.5)


def _generate(scene_file, out, *more) -> int:
    return main(["generate", str(scene_file), "--out", str(out), "--no-figures", "-q", *more])


def _rewrite_scene_record(path, text: str) -> None:
    """The pack file at `path` with its scene record replaced by `text`."""
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["scene.toml"] = np.frombuffer(text.encode(), dtype=np.uint8)
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    path.write_bytes(buf.getvalue())


@pytest.mark.parametrize(
    "addition",
    [
        'layer_shape = "hexagonal"\n',  # a key a newer version has
        'container = "cone"\n',  # a value this version does not know
        "[material]\ncohesion = 1.0\n",  # a material constant of a newer version
    ],
)
def test_a_pack_of_a_newer_version_is_never_generated_over(tmp_path, capsys, addition):
    scene_file = tmp_path / "s.toml"
    scene_file.write_text(TINY.to_toml())
    out = tmp_path / "out"
    assert _generate(scene_file, out) == 0
    path = pack_path(out / "packs", 0)
    record = gp.load_pack(path).scene.to_toml()
    if addition.startswith("container"):
        record = record.replace('container = "box"\n', "") + addition
    elif addition.startswith("[material]"):
        assert "[material]\n" in record
        record = record.replace("[material]\n", addition)
    else:
        record = addition + record  # a top-level key goes before the table
    _rewrite_scene_record(path, record)
    before = path.read_bytes()
    capsys.readouterr()
    assert _generate(scene_file, out) == 2
    err = capsys.readouterr().err
    assert NEWER_FORMAT in err and str(path) in err and err.count("\n") == 1
    assert path.read_bytes() == before
    # from Python too, as a FileFormatError naming the file
    with pytest.raises(gp.FileFormatError, match=NEWER_FORMAT) as e:
        run_tasks(ensemble_tasks(TINY, 1, out / "packs"), workers=1, progress=False)
    assert e.value.path == path
    assert path.read_bytes() == before


def test_a_damaged_pack_is_still_made_again(tmp_path):
    scene_file = tmp_path / "s.toml"
    scene_file.write_text(TINY.to_toml())
    out = tmp_path / "out"
    assert _generate(scene_file, out) == 0
    path = pack_path(out / "packs", 0)
    whole = path.read_bytes()
    path.write_bytes(whole[: len(whole) // 2])  # cut off on disk
    assert _generate(scene_file, out) == 0
    assert len(gp.load_pack(path)) > 0


def test_the_scene_files_stream_gives_way_with_a_note(tmp_path, capsys):
    scene_file = tmp_path / "s.toml"
    scene_file.write_text(TINY.replace(stream=5).to_toml())
    out = tmp_path / "out"
    assert main(["generate", str(scene_file), "--out", str(out), "--no-figures"]) == 0
    err = capsys.readouterr().err
    assert "granpack: note: the scene's stream = 5 is not used" in err
    assert gp.load_pack(pack_path(out / "packs", 0)).scene.stream == 0
    # a scene file without a stream of its own: no note
    scene_file.write_text(TINY.to_toml())
    assert main(["generate", str(scene_file), "--out", str(out), "--no-figures"]) == 0
    assert "stream" not in capsys.readouterr().err


def test_the_next_run_removes_the_temporaries_of_a_killed_write(tmp_path, capsys):
    scene_file = tmp_path / "s.toml"
    scene_file.write_text(TINY.to_toml())
    out = tmp_path / "out"
    assert _generate(scene_file, out) == 0
    # what a write killed between its temporary and its rename leaves (the same names)
    left = []
    for folder, name in (
        (out / "packs", "pack_000.npz"),
        (out, "report.md"),
        (out / "tables", "x.csv"),
    ):
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{name}.", suffix=".tmp")
        with open(fd, "wb") as f:
            f.write(b"half a file")
        left.append(tmp)
    assert all(is_temporary(t.rsplit("/", 1)[1]) for t in left)
    # files of the user's that only look alike stay
    kept = [out / "notes.tmp", out / ".hidden.tmp", out / "run.12345678.tmp", out / ".a.b.tmp"]
    for k in kept:
        k.write_text("mine")
    capsys.readouterr()
    assert main(["generate", str(scene_file), "--out", str(out), "--no-figures"]) == 0
    err = capsys.readouterr().err
    assert "removed 3 stale temporary file(s)" in err and "packs/.pack_000.npz." in err
    assert not any(p.exists() for p in map(type(out), left))
    assert all(k.read_text() == "mine" for k in kept)
    # nothing left: no note
    assert main(["generate", str(scene_file), "--out", str(out), "--no-figures"]) == 0
    assert "temporary" not in capsys.readouterr().err


def test_an_export_removes_the_temporaries_of_its_own_killed_export(tmp_path, capsys):
    src = gp.generate(TINY).save(tmp_path / "pack.npz")
    out = tmp_path / "dir"
    out.mkdir()
    left = []
    for name in ("pack.data", "in.granpack"):
        fd, tmp = tempfile.mkstemp(dir=out, prefix=f".{name}.", suffix=".tmp")
        with open(fd, "wb") as f:
            f.write(b"half")
        left.append(tmp)
    # another file's temporary is not this export's to remove
    fd, other = tempfile.mkstemp(dir=out, prefix=".other.csv.", suffix=".tmp")
    with open(fd, "wb") as f:
        f.write(b"half")
    argv = ["export", str(src), "--format", "lammps-data", "--out", str(out / "pack.data")]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "removed 2 stale temporary file(s)" in err
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["pack.data", "in.granpack", other.rsplit("/", 1)[1]]
    )


def test_a_paper_run_removes_the_temporaries_of_a_killed_one(tmp_path, capsys):
    out = tmp_path / "paper"
    (out / "packs" / "4.1-on").mkdir(parents=True)
    fd, tmp = tempfile.mkstemp(dir=out / "packs" / "4.1-on", prefix=".pack_000.npz.", suffix=".tmp")
    with open(fd, "wb") as f:
        f.write(b"half")
    argv = ["paper", "--examples", "4.1", "--packs", "1", "--out", str(out), "--workers", "1"]
    assert main([*argv, "--scale", "0.2", "--settle-time", "0.3"]) == 0
    err = capsys.readouterr().err
    assert "removed 1 stale temporary file(s)" in err
    assert not any(is_temporary(p.name) for p in out.rglob("*"))
