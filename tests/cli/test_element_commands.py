"""``granpack triaxial``, ``oedometer`` and ``isotropic`` on a consolidated pack file:
the tested pack, its table as CSV (the pack's own table, value for value), its lab
report as JSON and its figure; a bad value is one line naming the option, before any
file is written."""

from __future__ import annotations

import json
from pathlib import Path

import polars as pl
import pytest
from polars.testing import assert_frame_equal

import granpack as gp
from granpack.cli import main

SCENE = gp.PackScene.preset("4.3").replace(seed=3, base=(0.3, 0.3), height=0.2).fast()
STRESS = 1e5


@pytest.fixture(scope="module")
def packs(tmp_path_factory) -> dict[str, Path]:
    """The deposit, its isotropic consolidation and its oedometric one, as pack files."""
    folder = tmp_path_factory.mktemp("element_packs")
    dep = gp.generate(SCENE)
    files = {
        "deposit": dep,
        "sample": gp.consolidate(dep, STRESS, "isotropic", gravity=False),
        "oedometric": gp.consolidate(dep, STRESS, gravity=False),
    }
    return {name: pack.save(folder / f"{name}.npz") for name, pack in files.items()}


def _run(argv: list[str]) -> int:
    """main's exit status, an argparse refusal (SystemExit) included."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code or 0)


def _same_table(csv: Path, pack: gp.Pack, test: str) -> None:
    """The CSV holds the pack's table: its columns, in order, and every value exactly."""
    written = pl.read_csv(csv)
    table = gp.element_table(pack, test)
    assert written.columns == table.columns
    assert_frame_equal(written, table, check_exact=True)


def test_triaxial_writes_the_tested_pack_its_table_lab_report_and_figure(packs, tmp_path):
    out = tmp_path / "tri.npz"
    argv = ["triaxial", str(packs["sample"]), "-o", str(out), "--axial-strain", "0.05"]
    argv += ["--checks", "6", "--confining", str(STRESS), "--wall-friction", "0.1", "-q"]
    assert _run(argv) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "tri.npz",
        "tri.png",
        "tri_lab.json",
        "tri_table.csv",
    ]
    tested = gp.load_pack(out)
    assert [r.stage for r in tested.history][-2:] == ["consolidate", "triaxial"]
    rec = tested.record("triaxial")
    assert rec is not None
    assert rec.settings["confining"] == STRESS
    assert rec.settings["wall_friction"] == 0.1
    assert rec.settings["axial_strain"] == 0.05
    _same_table(tmp_path / "tri_table.csv", tested, "triaxial")
    table = gp.element_table(tested)
    assert table.height == 6
    # the lid went down by the strain asked (to the step), the side walls held sigma_3
    assert table["eps_a"][-1] == pytest.approx(0.05, rel=0.02)
    assert (table["sigma_3"] / STRESS - 1.0).abs().max() < 0.02
    assert json.loads((tmp_path / "tri_lab.json").read_text()) == rec.report["lab"]
    assert (tmp_path / "tri.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("test", ["oedometer", "isotropic"])
def test_a_stress_path_writes_one_row_per_stress_beside_the_default_name(packs, test):
    stresses = [150e3, 200e3, 150e3]
    sample = packs["sample"]
    argv = [test, str(sample), "--stresses", ",".join(f"{s:g}" for s in stresses), "-q"]
    assert _run(argv) == 0
    out = sample.with_name(f"sample_{test}.npz")
    files = [out, *(sample.with_name(f"sample_{test}{s}") for s in ("_table.csv", "_lab.json"))]
    files.append(sample.with_name(f"sample_{test}.png"))
    try:
        assert all(f.is_file() for f in files)
        tested = gp.load_pack(out)
        rec = tested.record(test)
        assert rec is not None and rec.settings["stresses"] == stresses
        _same_table(files[1], tested, test)
        table = gp.element_table(tested)
        # the sample as consolidated, then one row per stress
        assert table["target"].to_list()[1:] == stresses
        assert table["target"][0] == pytest.approx(STRESS, rel=1e-3)
        # each row is the servo's equilibrium at its target, within the stress tolerance
        held = table["sigma_1"] if test == "oedometer" else table["p"]
        assert ((held / table["target"] - 1.0).abs() <= 1e-3 * (1 + 1e-9)).all()
        assert json.loads(files[2].read_text()) == rec.report["lab"]
    finally:
        for f in files:
            f.unlink(missing_ok=True)


@pytest.mark.parametrize(
    ("pack", "argv", "named"),
    [
        ("sample", ["triaxial", "--confining", "-1"], "--confining"),
        ("sample", ["triaxial", "--axial-strain", "1"], "--axial-strain"),
        ("sample", ["triaxial", "--checks", "1"], "--checks"),
        ("sample", ["triaxial", "--wall-friction", "-0.5"], "--wall-friction"),
        ("sample", ["oedometer", "--stresses", ""], "--stresses"),
        ("sample", ["oedometer", "--stresses", "1e5,,2e5"], "--stresses"),
        ("sample", ["isotropic", "--stresses", "1e5,-3"], "--stresses"),
        ("sample", ["isotropic", "--stresses", "1e5,2e5", "--stress-tol", "2"], "--stress-tol"),
        ("deposit", ["triaxial"], "consolidate"),
        ("deposit", ["oedometer", "--stresses", "1e5,2e5"], "consolidate"),
        ("oedometric", ["triaxial", "--axial-strain", "0.05"], "--confining"),
    ],
)
def test_a_bad_value_is_one_line_naming_the_option_and_writes_nothing(
    packs, tmp_path, capsys, pack, argv, named
):
    out = tmp_path / "out" / "tested.npz"
    status = _run([argv[0], str(packs[pack]), "-o", str(out), *argv[1:]])
    err = capsys.readouterr().err
    assert status == 2
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"granpack {argv[0]}: error:")
    assert named in err
    assert not out.parent.exists() or list(out.parent.iterdir()) == []


def test_an_output_that_is_the_input_is_refused_before_the_test(packs, capsys):
    sample = packs["sample"]
    before = sample.read_bytes()
    status = _run(["triaxial", str(sample), "-o", str(sample)])
    err = capsys.readouterr().err
    assert status == 2 and "--out" in err and "would be overwritten" in err
    assert sample.read_bytes() == before
    assert not sample.with_name("sample_table.csv").exists()


def test_the_commands_take_the_functions_defaults():
    import inspect

    from granpack.cli import build_parser

    parser = build_parser()
    tri = parser.parse_args(["triaxial", "sample.npz"])
    defaults = {k: v.default for k, v in inspect.signature(gp.triaxial).parameters.items()}
    for key in ("confining", "axial_strain", "inertial_number", "constant_p", "checks"):
        assert getattr(tri, key) == defaults[key], key
    assert tri.wall_friction == defaults["wall_friction"]
    for test, func in (("oedometer", gp.oedometer), ("isotropic", gp.isotropic_compression)):
        args = parser.parse_args([test, "sample.npz", "--stresses", "1e5,2e5"])
        defaults = {k: v.default for k, v in inspect.signature(func).parameters.items()}
        assert args.stresses == [1e5, 2e5]
        for key in ("stress_tol", "unbalanced_tol", "max_steps", "wall_friction"):
            assert getattr(args, key) == defaults[key], (test, key)
