"""No command writes one of its outputs over another, or over one of its inputs. Every
output path is computed first; a collision (the same name, a name through ``..`` or a
symbolic link, a hard link) is an InvalidParameterError naming the option that chose
the name, before anything is written."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

import granpack as gp
from granpack.cli import main
from granpack.io import EXPORT_FORMATS, export, output_paths

TINY = gp.PackScene.preset("4.1").replace(base=(0.2,), height=0.06, settle_time=0.5)
TINY_3D = gp.PackScene.preset("4.3").replace(base=(0.2, 0.2), height=0.06, settle_time=0.5)


@pytest.fixture(scope="module")
def pack() -> gp.Pack:
    return gp.generate(TINY)


@pytest.fixture(scope="module")
def pack_3d() -> gp.Pack:
    return gp.generate(TINY_3D)


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()
    }


@pytest.mark.parametrize("fmt", ["lammps-data", "liggghts"])
def test_a_data_file_named_as_its_input_script_is_refused(pack, pack_3d, fmt, tmp_path):
    subject = pack_3d if fmt == "liggghts" else pack  # LIGGGHTS runs 3D packs only
    for name in ("in.granpack", "sub/../in.granpack", "./in.granpack"):
        if "sub" in name:
            (tmp_path / "sub").mkdir(exist_ok=True)
        with pytest.raises(gp.InvalidParameterError, match="one file") as e:
            export(subject, tmp_path / name, fmt)
        assert e.value.parameter == "path"
    # through a symbolic link to the script's name
    (tmp_path / "alias.data").symlink_to(tmp_path / "in.granpack")
    with pytest.raises(gp.InvalidParameterError, match="one file"):
        export(subject, tmp_path / "alias.data", fmt)
    assert [p.name for p in tmp_path.iterdir() if p.is_file() and not p.is_symlink()] == []
    # a name of its own is fine, and writes both files
    written = export(subject, tmp_path / "pack.data", fmt)
    assert [p.name for p in written] == ["pack.data", "in.granpack"]


@pytest.mark.parametrize("fmt", sorted(EXPORT_FORMATS))
def test_no_format_writes_over_its_input(pack, pack_3d, fmt, tmp_path):
    subject = pack_3d if fmt == "liggghts" else pack
    outputs = output_paths(tmp_path / f"out{EXPORT_FORMATS[fmt]}", fmt)
    assert len({os.path.abspath(p) for p in outputs}) == len(outputs)
    for target in outputs:
        # the pack file read lies where one of the outputs would go
        subject.save(target)
        before = _snapshot(tmp_path)
        with pytest.raises(gp.InvalidParameterError, match="would be overwritten") as e:
            export(subject, tmp_path / f"out{EXPORT_FORMATS[fmt]}", fmt, refuse=[target])
        assert e.value.parameter == "path"
        assert _snapshot(tmp_path) == before
        # the same file under another name (a hard link) is the same input
        link = tmp_path / "hard.npz"
        os.link(target, link)
        with pytest.raises(gp.InvalidParameterError, match="would be overwritten"):
            export(subject, tmp_path / f"out{EXPORT_FORMATS[fmt]}", fmt, refuse=[link])
        link.unlink()
        target.unlink()
    written = export(subject, tmp_path / f"out{EXPORT_FORMATS[fmt]}", fmt)
    assert sorted(written) == sorted(outputs)


def _export(*argv: str) -> int:
    return main(["export", *argv, "-q"])


@pytest.mark.parametrize("fmt", ["lammps-data", "liggghts"])
def test_the_command_line_refuses_the_reported_case(pack, pack_3d, fmt, tmp_path, capsys):
    subject = pack_3d if fmt == "liggghts" else pack
    src = subject.save(tmp_path / "pack.npz")
    out = tmp_path / "dir"
    out.mkdir()
    assert _export(str(src), "--format", fmt, "--out", str(out / "in.granpack")) == 2
    err = capsys.readouterr().err
    assert "invalid --out" in err and "in.granpack" in err and err.count("\n") == 1
    assert list(out.iterdir()) == []
    assert _export(str(src), "--format", fmt, "--out", str(out / "pack.data")) == 0
    assert sorted(p.name for p in out.iterdir()) == ["in.granpack", "pack.data"]


@pytest.mark.parametrize("fmt", sorted(EXPORT_FORMATS))
def test_the_command_line_refuses_every_format_over_its_input(pack, pack_3d, fmt, tmp_path, capsys):
    subject = pack_3d if fmt == "liggghts" else pack
    for target in output_paths(tmp_path / f"x{EXPORT_FORMATS[fmt]}", fmt):
        src = subject.save(target)  # the pack file is named as an output
        before = _snapshot(tmp_path)
        assert (
            _export(str(src), "--format", fmt, "--out", str(tmp_path / f"x{EXPORT_FORMATS[fmt]}"))
            == 2
        )
        assert "would be overwritten" in capsys.readouterr().err
        assert _snapshot(tmp_path) == before
        src.unlink()
    if fmt in ("csv", "parquet"):
        return  # their default names are the tables', never the pack's
    # the default name beside a pack whose own name is that default
    disguised = subject.save(tmp_path / f"p{EXPORT_FORMATS[fmt]}")
    before = _snapshot(tmp_path)
    assert _export(str(disguised), "--format", fmt) == 2
    assert _snapshot(tmp_path) == before


def test_analyze_figures_never_overwrite_an_input(pack, tmp_path, capsys):
    src = pack.save(tmp_path / "p.npz")
    figures = tmp_path / "fig"
    figures.mkdir()
    # the particle file itself, then the contact file, named as a figure
    inputs = figures / "p.png"
    inputs.write_bytes(src.read_bytes())
    assert main(["analyze", str(inputs), "--figures", str(figures), "-q"]) == 2
    assert "invalid --figures" in capsys.readouterr().err
    assert inputs.read_bytes() == src.read_bytes()


def test_generate_never_overwrites_its_scene_file(tmp_path, capsys):
    out = tmp_path / "out"
    scene_file = tmp_path / "s.toml"
    scene_file.write_text(TINY.to_toml())
    argv = ["--out", str(out), "--no-figures", "-q"]
    assert main(["generate", str(scene_file), *argv]) == 0
    # the scene file kept where the run writes its report, tables or packs
    for rel in ("report.md", "tables/s.toml", "packs/s.toml", "micro/s.toml", "figures/s.toml"):
        hidden = out / rel
        hidden.parent.mkdir(parents=True, exist_ok=True)
        hidden.write_text(TINY.to_toml())
        before = _snapshot(out)
        assert main(["generate", str(hidden), *argv]) == 2
        assert "invalid --out" in capsys.readouterr().err
        assert _snapshot(out) == before
        hidden.unlink()
    # beside the results is fine: nothing is written there
    beside = out / "mine.toml"
    beside.write_text(TINY.to_toml())
    assert main(["generate", str(beside), *argv]) == 0
    assert beside.read_text() == TINY.to_toml()
