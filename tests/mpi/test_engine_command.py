"""``granpack generate --engine lammps --ranks N``: an ensemble whose layer loops run on
LAMMPS over MPI, and the options' errors."""

from __future__ import annotations

import numpy as np
import pytest

import granpack as gp
from granpack.cli import main

SCENE = """preset = "4.3"
base = [0.3, 0.3]
height = 0.15
"""


def test_generate_on_lammps_writes_packs_that_record_the_engine(lammps_mpi, tmp_path, capsys):
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE)
    out = tmp_path / "out"
    args = ["generate", str(scene), "--packs", "2", "--engine", "lammps", "--ranks", "2"]
    code = main([*args, "--no-figures", "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    packs = [gp.load_pack(out / "packs" / f"pack_{k:03d}.npz") for k in range(2)]
    for k, pack in enumerate(packs):
        assert pack.engine == {"name": "lammps", "version": 20250722, "ranks": 2}
        assert pack.scene.stream == k
        assert len(pack) == sum(rep["added"] for rep in pack.layers)
    # two streams, two packs
    assert not np.array_equal(packs[0].positions[:10], packs[1].positions[:10])
    assert (out / "report.md").is_file()


@pytest.mark.parametrize(
    ("options", "words"),
    [
        (["--ranks", "2"], "ranks"),
        (["--engine", "lammps", "--ranks", "0"], "ranks"),
        (["--engine", "lammps", "--mpiexec", "no-such-launcher"], "mpiexec"),
    ],
)
def test_bad_engine_options_exit_2_naming_them(tmp_path, capsys, options, words):
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE)
    out = tmp_path / "out"
    code = main(["generate", str(scene), *options, "--no-figures", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert words in err
    assert not (out / "packs").exists() or not any((out / "packs").iterdir())
