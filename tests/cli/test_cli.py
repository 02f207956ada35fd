"""The ``granpack`` command end to end on tiny scenes: the files it writes and what is in
them, reruns that skip finished packs, the same packs on Dask, one-line errors."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import polars as pl
import pytest

import granpack as gp
from granpack.cli import main
from granpack.io.lammps import read_lammps_data, write_lammps

PNG = b"\x89PNG\r\n\x1a\n"
TINY_TOML = """\
preset = "4.1"
base = [0.2]
height = 0.06
settle_time = 0.5
"""


def _links(report: Path) -> list[str]:
    return re.findall(r"\]\(([^)]+)\)", report.read_text())


def _assert_links_resolve(report: Path) -> list[str]:
    links = _links(report)
    assert links
    missing = [link for link in links if not (report.parent / link).is_file()]
    assert not missing, missing
    return links


@pytest.fixture
def tiny_toml(tmp_path) -> Path:
    path = tmp_path / "tiny.toml"
    path.write_text(TINY_TOML)
    return path


def _generate(toml: Path, out: Path, *extra: str) -> int:
    argv = ["generate", str(toml), "--packs", "2", "--seed", "3", "--rotations", "off"]
    return main([*argv, "--out", str(out), *extra])


def test_generate_writes_packs_microstructure_tables_figures_and_report(
    tiny_toml, tmp_path, capsys
):
    out = tmp_path / "out"
    assert _generate(tiny_toml, out, "--workers", "1") == 0
    stdout, stderr = capsys.readouterr()
    assert f"report: {out / 'report.md'}" in stdout
    # Not a terminal: plain progress lines, no bar.
    assert "[1/2] #0 done: N=" in stderr and "[2/2] #1 done" in stderr and "\r" not in stderr

    scene = gp.PackScene.from_toml(tiny_toml).replace(seed=3, rotations=False)
    assert gp.PackScene.from_toml(out / "scene.toml") == scene
    packs = [gp.load_pack(out / "packs" / f"pack_00{k}.npz") for k in range(2)]
    for k, pack in enumerate(packs):
        assert pack.scene == scene.replace(stream=k)
        assert np.all(pack.spins == 0.0)  # rotations off
        text = (out / "micro" / f"pack_00{k}.json").read_text()
        rec = json.loads(text)
        assert rec["pack"] == k and rec["seed"] == 3 and rec["stream"] == k
        # Strict JSON: the undefined core fraction of so small a pack is null, not NaN.
        assert "NaN" not in text and rec["phi_core"] is None
        assert rec["n_particles"] == len(pack)
        assert rec["phi"] == pytest.approx(pack.phi, rel=1e-12)
        assert rec["n_contacts"] == int((pack.contacts.j >= 0).sum())
        for stem in (f"pack_00{k}", f"pack_00{k}_normals", f"pack_00{k}_forces"):
            assert (out / "figures" / f"{stem}.png").read_bytes()[:8] == PNG
    assert (out / "figures" / "phi_histogram.png").read_bytes()[:8] == PNG

    table = pl.read_csv(out / "tables" / "ensemble.csv")
    np.testing.assert_allclose(table["phi"].to_numpy(), [p.phi for p in packs], rtol=1e-12)
    summ = pl.read_csv(out / "tables" / "summary.csv")
    mean = summ.filter(pl.col("statistic") == "mean")["phi"].item()
    assert mean == pytest.approx(np.mean([p.phi for p in packs]), rel=1e-12)
    assert (out / "tables" / "ensemble.md").read_text().startswith("| pack |")

    links = _assert_links_resolve(out / "report.md")
    assert "packs/pack_001.npz" in links and "tables/summary.md" in links


def test_generate_rerun_skips_finished_packs(tiny_toml, tmp_path, capsys):
    out = tmp_path / "out"
    assert _generate(tiny_toml, out, "--workers", "1", "--no-figures") == 0
    files = sorted((out / "packs").iterdir())
    mtimes = [f.stat().st_mtime_ns for f in files]
    capsys.readouterr()
    assert _generate(tiny_toml, out, "--workers", "1", "--no-figures") == 0
    stderr = capsys.readouterr().err
    assert "2 packs, 2 already on disk" in stderr and "done" not in stderr
    assert [f.stat().st_mtime_ns for f in files] == mtimes
    # A different seed into the same folder is refused, not silently overwritten.
    assert main(["generate", str(tiny_toml), "--seed", "4", "--out", str(out)]) == 2
    assert "different scene" in capsys.readouterr().err
    assert [f.stat().st_mtime_ns for f in files] == mtimes


def test_generate_on_a_dask_cluster_gives_the_local_packs(tiny_toml, tmp_path, capsys):
    distributed = pytest.importorskip("distributed")
    local, remote = tmp_path / "local", tmp_path / "dask"
    assert _generate(tiny_toml, local, "--workers", "2", "--no-figures", "-q") == 0
    with distributed.LocalCluster(
        processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        argv = ["--scheduler", cluster.scheduler_address, "--no-figures", "-q"]
        assert _generate(tiny_toml, remote, *argv) == 0
    for k in range(2):
        a = gp.load_pack(local / "packs" / f"pack_00{k}.npz")
        b = gp.load_pack(remote / "packs" / f"pack_00{k}.npz")
        np.testing.assert_array_equal(a.positions, b.positions)
        np.testing.assert_array_equal(a.contacts.force_normal, b.contacts.force_normal)
    assert capsys.readouterr() == ("", "")


def test_quiet_prints_nothing(tmp_path, capsys):
    out = tmp_path / "q"
    argv = ["generate", "4.1", "--scale", "0.2", "--settle-time", "0.2", "--no-figures"]
    assert main([*argv, "--out", str(out), "--quiet", "--workers", "1"]) == 0
    assert capsys.readouterr() == ("", "")
    assert (out / "packs" / "pack_000.npz").exists() and (out / "report.md").exists()
    # The development knobs are flagged in the report.
    assert "Development run" in (out / "report.md").read_text()


def test_paper_quick_writes_the_papers_tables_figures_and_report(tmp_path, capsys):
    out = tmp_path / "paper"
    argv = ["paper", "--quick", "--examples", "4.1", "4.3", "--out", str(out)]
    # Tiny scenes (hidden development options) so that the test runs in seconds.
    assert main([*argv, "--scale", "0.2", "--settle-time", "0.3", "--workers", "1"]) == 0
    assert f"report: {out / 'report.md'}" in capsys.readouterr().out
    report = (out / "report.md").read_text()
    assert "**Quick run:** 2 packs per case instead of the paper's 10" in report
    assert "Development run, not the paper's scenes" in report
    links = _assert_links_resolve(out / "report.md")
    for name in ("table2", "table3", "table4", "table8", "table9", "table10", "extra_4.1"):
        assert f"tables/{name}.md" in links and (out / "tables" / f"{name}.csv").is_file()
    assert not (out / "tables" / "table5.csv").exists()  # 4.2 was not asked for
    for fig in ("fig2_4.1_on_packs", "fig3_4.1_off_normals", "fig7_4.3_off_forces", "phi_4.3"):
        assert f"figures/{fig}.png" in links

    # Table 2: our phi per pack (= the micro records) beside the paper's, as printed.
    t2 = pl.read_csv(out / "tables" / "table2.csv", schema_overrides={"pack": pl.Utf8})
    for rot, col in ((True, "rotations ON"), (False, "rotations OFF")):
        micro = out / "micro" / f"4.1-{'on' if rot else 'off'}"
        ours = [json.loads((micro / f"pack_00{k}.json").read_text())["phi"] for k in range(2)]
        np.testing.assert_allclose(t2[col].to_numpy()[:2], ours, rtol=1e-12)
    paper = dict(zip(t2["pack"], t2["paper rotations ON"], strict=True))
    assert paper["1"] == 0.854 and paper["mean"] == 0.861
    # Pack k of a case uses the master seed (0) and stream k.
    pack = gp.load_pack(out / "packs" / "4.3-off" / "pack_001.npz")
    assert (pack.scene.seed, pack.scene.stream, pack.scene.rotations) == (0, 1, False)


def _tiny_pack(dim: int) -> gp.Pack:
    if dim == 2:
        scene = gp.PackScene.preset("4.1").replace(base=(0.2,), height=0.06, settle_time=0.5)
    else:
        scene = gp.PackScene.preset("4.3").replace(base=(0.2, 0.2), height=0.1, settle_time=0.5)
    return gp.generate(scene)


@pytest.mark.parametrize("dim", [2, 3])
def test_analyze_pack_text_file_and_lammps_data(dim, tmp_path, capsys):
    pack = _tiny_pack(dim)
    pack.save(tmp_path / "p.npz")
    # x y (z) r from "another code"; 2D as LAMMPS writes it: x y 0 r.
    cols = [pack.positions[:, k] for k in range(dim)]
    if dim == 2:
        cols.append(np.zeros(len(pack)))
    text = "# x y z r\n" + "\n".join(
        " ".join(repr(float(v)) for v in row) for row in np.column_stack([*cols, pack.radii])
    )
    (tmp_path / "p.txt").write_text(text + "\n")
    write_lammps(pack, tmp_path / "p.data")

    results = {}
    for name in ("p.npz", "p.txt", "p.data"):
        assert main(["analyze", str(tmp_path / name), "--json"]) == 0
        results[name] = json.loads(capsys.readouterr().out)
    for r in results.values():
        assert r["n_particles"] == len(pack) and r["dim"] == dim
    assert results["p.npz"]["phi"] == pytest.approx(pack.phi, rel=1e-12)
    assert results["p.npz"]["has_forces"] is True
    # From positions only: the same contacts are found (forces unknown).
    n_pp = int((pack.contacts.j >= 0).sum())
    assert results["p.txt"]["n_contacts"] == n_pp and results["p.txt"]["has_forces"] is False
    assert results["p.txt"]["f0"] is None  # no forces in a text file: null in JSON
    assert results["p.data"]["n_contacts"] == n_pp
    # The data file's box is the pack's, so phi is the pack's.
    assert results["p.data"]["phi"] == pytest.approx(pack.phi, rel=1e-12)

    # The table form and the figures.
    assert main(["analyze", str(tmp_path / "p.npz"), "--figures", str(tmp_path / "f")]) == 0
    table = capsys.readouterr().out
    assert re.search(r"^phi\s+0\.\d+", table, re.M)
    assert (tmp_path / "f" / "p.png").read_bytes()[:8] == PNG


def test_export_command_writes_files_that_read_back(tmp_path, capsys):
    meshio = pytest.importorskip("meshio")
    pack = _tiny_pack(3)
    pack.save(tmp_path / "p.npz")
    assert main(["export", str(tmp_path / "p.npz"), "--format", "vtk"]) == 0
    assert capsys.readouterr().out.split() == [
        str(tmp_path / "p.vtu"),
        str(tmp_path / "p.container.vtu"),
    ]
    mesh = meshio.read(tmp_path / "p.vtu")
    np.testing.assert_array_equal(mesh.points[: len(pack)], pack.positions)
    np.testing.assert_array_equal(mesh.point_data["radius"][: len(pack)], pack.radii)

    target = tmp_path / "lmp" / "in.data"
    assert main(["export", str(tmp_path / "p.npz"), "--out", str(target), "-q"]) == 0
    data = read_lammps_data(target)
    np.testing.assert_array_equal(data["positions"], pack.positions)
    np.testing.assert_array_equal(data["diameter"], 2 * pack.radii)

    assert main(["export", str(tmp_path / "p.npz"), "--format", "parquet", "-q"]) == 0
    parts = pl.read_parquet(tmp_path / "p.particles.parquet")
    np.testing.assert_array_equal(parts["z"].to_numpy(), pack.positions[:, 2])


@pytest.mark.parametrize(
    "argv, message",
    [
        (["generate", "4.9"], "unknown scene '4.9'"),
        (["generate", "4.1", "--packs", "0"], "--packs: invalid value 0"),
        (["generate", "4.1", "--rotations", "maybe"], "use on or off"),
        (["generate", "BAD_TOML"], "unknown scene key 'hieght'; did you mean 'height'?"),
        (["paper", "--examples", "5.1"], "invalid choice: '5.1'"),
        (["export", "missing.npz", "--format", "vtk"], "no such file"),
        (["export", "BAD_PACK", "--format", "vtk"], "corrupt or truncated"),
        (["analyze", "missing.txt"], "no such file"),
        (["analyze", "BAD_TEXT"], "expected 4 numbers"),
        (["analyze", "BAD_PACK", "--dim", "2"], "--box and --dim apply to text"),
        (["frobnicate"], "invalid choice: 'frobnicate'"),
    ],
)
def test_bad_input_is_one_line_on_stderr_and_status_2(argv, message, tmp_path, capsys):
    (tmp_path / "bad.toml").write_text('preset = "4.1"\nhieght = 0.3\n')
    (tmp_path / "bad.npz").write_bytes(b"PK\x03\x04 not really a zip")
    (tmp_path / "bad.txt").write_text("0.1 0.2 0.3 0.01\n0.1 0.2\n")
    subst = {"BAD_TOML": "bad.toml", "BAD_PACK": "bad.npz", "BAD_TEXT": "bad.txt"}
    argv = [str(tmp_path / subst[a]) if a in subst else a for a in argv]
    try:
        status = main(argv)
    except SystemExit as exc:  # argparse's own errors
        status = exc.code
    assert status == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("granpack") and message in err


def test_installed_command_reports_errors_without_traceback(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "granpack.cli", "generate", "4.1", "--seed", "-1"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "granpack generate: error: argument --seed: invalid seed -1: must lie in [0, 2^64 - 1] "
        "(see granpack generate --help)"
    ]
    assert not list(tmp_path.iterdir())  # nothing written


def test_fast_flag_uses_the_fast_settings(tmp_path):
    out = tmp_path / "f"
    argv = ["generate", "4.1", "--scale", "0.2", "--settle-time", "0.4", "--no-figures"]
    assert main([*argv, "--fast", "--out", str(out), "--quiet", "--workers", "1"]) == 0
    pack = gp.load_pack(out / "packs" / "pack_000.npz")
    assert pack.scene.settle_tol == gp.scene.FAST_SETTLE_TOL
    assert pack.scene.freeze_depth == gp.scene.FAST_FREEZE_LAYERS * pack.scene.h_layer
