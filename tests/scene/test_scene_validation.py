"""How often a scene is validated, and that a bad scene gets the same typed error, naming
the same parameter, from every door: `PackScene`, the engine's `LayerPacker` (which reads
any object with the scene's fields) and the command line."""

from __future__ import annotations

import collections

import pytest

import granpack as gp
from granpack import _core
from granpack.cli import main


@pytest.fixture
def counted(monkeypatch):
    """Counts the scene's validations: `resolve_scene` (once per PackScene built) and
    the engine's own (once per LayerPacker, that is per pack)."""
    calls: collections.Counter = collections.Counter()
    validate, packer = _core.resolve_scene, _core.LayerPacker

    def counting_validate(scene):
        calls["scene"] += 1
        return validate(scene)

    def counting_packer(scene, *args, **kwargs):
        calls["engine"] += 1
        return packer(scene, *args, **kwargs)

    monkeypatch.setattr(_core, "resolve_scene", counting_validate)
    monkeypatch.setattr(_core, "LayerPacker", counting_packer)
    return calls


def test_generate_validates_the_scene_a_counted_number_of_times(counted, tmp_path):
    packs = 3
    argv = ["generate", "4.1", "--packs", str(packs), "--workers", "1", "--fast", "-q"]
    argv += ["--scale", "0.2", "--settle-time", "0.2", "--no-figures", "--out", str(tmp_path)]
    assert main(argv) == 0
    # the preset, the development options' scaled scene and --fast's: three scenes
    # built; each pack's seed and stream are checked alone; each pack read back for its
    # analysis is a scene read from a file, validated
    assert counted["scene"] == 3 + packs
    assert counted["engine"] == packs


def test_a_new_seed_or_stream_checks_those_alone(counted):
    scene = gp.PackScene.preset("4.1")
    assert counted["scene"] == 1
    other = scene.replace(seed=7, stream=2)
    assert counted["scene"] == 1
    assert (other.seed, other.stream) == (7, 2)
    with pytest.raises(gp.InvalidParameterError) as err:
        scene.replace(stream=-1)
    assert err.value.parameter == "stream"
    scene.replace(rotations=False)
    assert counted["scene"] == 2


class _Fields:
    """Any object with a scene's fields: what the engine's LayerPacker reads, by
    attribute, from a scene that Python did not build."""

    def __init__(self, preset: str, changes: dict) -> None:
        self.__dict__.update(vars(gp.PackScene.preset(preset)))
        self.__dict__.update(changes)


#: (preset, changes, error class, parameter): one rule of the scene each.
RULES = [
    ("4.1", {"dt": 1.0}, gp.UnstableTimeStepError, "dt"),
    ("4.1", {"phi_layer": 0.6}, gp.InvalidParameterError, "phi_layer"),
    ("4.3", {"phi_layer": 0.4}, gp.InvalidParameterError, "phi_layer"),
    ("4.1", {"gravity": 0.0}, gp.InvalidParameterError, "gravity"),
    ("4.1", {"gravity": -2.0}, gp.InvalidParameterError, "gravity"),
    ("4.1", {"h_layer": -0.1}, gp.InvalidParameterError, "h_layer"),
    ("4.1", {"height": 0.0}, gp.InvalidParameterError, "height"),
    ("4.1", {"base": (0.01,)}, gp.InvalidParameterError, "base"),
    ("4.1", {"settle_time": 1e9}, gp.InvalidParameterError, "settle_time"),
    ("4.1", {"max_layers": _core.MAX_LAYERS + 1}, gp.InvalidParameterError, "max_layers"),
    ("4.1", {"max_attempts": _core.MAX_ATTEMPTS + 1}, gp.InvalidParameterError, "max_attempts"),
    ("4.1", {"container": "sphere"}, gp.InvalidParameterError, "container"),
    ("4.1", {"drag": -1.0}, gp.InvalidParameterError, "drag"),
    ("4.1", {"skin_ratio": 11.0}, gp.InvalidParameterError, "skin_ratio"),
    ("4.1", {"max_overlap_ratio": 0.0}, gp.InvalidParameterError, "max_overlap_ratio"),
    ("4.2", {"r_std": -0.001}, gp.InvalidParameterError, "r_std"),
    (
        "4.3",
        {"container": "cylinder", "cylinder_radius": 0.03, "base": (0.06, 0.06)},
        gp.InvalidParameterError,
        "cylinder_radius",
    ),
    # the rules the engine's validator took over from the Python layer
    ("4.3", {"container": "cylinder", "base": (1.0, 0.8)}, gp.InvalidParameterError, "base"),
    (
        "4.3",
        {"container": "cylinder", "cylinder_radius": 0.5, "base": (1.2, 1.2)},
        gp.InvalidParameterError,
        "base",
    ),
    ("4.1", {"container": "cylinder"}, gp.InvalidParameterError, "container"),
    ("4.3", {"cylinder_radius": 0.5}, gp.InvalidParameterError, "cylinder_radius"),
    ("4.3", {"trim": True, "height": 0.03}, gp.InvalidParameterError, "height"),
    ("4.3", {"base": (400.0, 400.0)}, gp.InvalidParameterError, "scene"),
    ("4.3", {"rest_tol": 1.0}, gp.InvalidParameterError, "rest_tol"),
    ("4.3", {"target_phi": 1.0}, gp.InvalidParameterError, "target_phi"),
    ("4.3", {"target_void_ratio": 0.0}, gp.InvalidParameterError, "target_void_ratio"),
    (
        "4.3",
        {"target_relative_density": 1.5},
        gp.InvalidParameterError,
        "target_relative_density",
    ),
    (
        "4.3",
        {"target_phi": 0.6, "target_void_ratio": 0.6},
        gp.InvalidParameterError,
        "target_void_ratio",
    ),
    ("4.3", {"target_phi": 0.6, "density_tol": 0.5}, gp.InvalidParameterError, "density_tol"),
    ("4.3", {"density_method": "fast"}, gp.InvalidParameterError, "density_method"),
    (
        "4.3",
        {"target_phi": 0.6, "density_method": "servo"},
        gp.InvalidParameterError,
        "density_method",
    ),
    ("4.1", {"seed": -1}, gp.InvalidParameterError, "seed"),
    ("4.1", {"inertia_2d": "ring"}, gp.InvalidParameterError, "inertia_2d"),
    ("4.2", {"radius_law": "normal"}, gp.InvalidParameterError, "radius_law"),
]
IDS = [f"{p}-{'-'.join(c)}" for p, c, _, _ in RULES]


def _toml(preset: str, changes: dict) -> str:
    lines = [f'preset = "{preset}"']
    for key, value in changes.items():
        if isinstance(value, bool):
            value = "true" if value else "false"
        elif isinstance(value, tuple):
            value = "[" + ", ".join(repr(v) for v in value) + "]"
        elif isinstance(value, str):
            value = f'"{value}"'
        lines.append(f"{key} = {value}")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize(("preset", "changes", "cls", "parameter"), RULES, ids=IDS)
def test_a_bad_scene_gets_one_typed_error_from_every_door(
    preset, changes, cls, parameter, tmp_path, capsys
):
    from granpack._console import Console
    from granpack.cli import build_parser
    from granpack.cli import generate as generate_command

    fields = {**vars(gp.PackScene.preset(preset)), **changes}
    with pytest.raises(cls) as built:
        gp.PackScene(**fields)
    with pytest.raises(cls) as engine:
        _core.LayerPacker(_Fields(preset, changes))
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(_toml(preset, changes))
    argv = ["generate", str(scene_file), "--out", str(tmp_path / "out"), "-q"]
    with pytest.raises(cls) as command:
        generate_command.run(build_parser().parse_args(argv), Console(True))
    for err in (built, engine, command):
        assert type(err.value) is cls
        assert err.value.parameter == parameter
    assert main(argv) == 2
    assert f"invalid {parameter}" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("changes", "cls", "parameter"),
    [
        ({"dt": 1.0}, gp.UnstableTimeStepError, "dt"),
        ({"container": "sphere"}, gp.InvalidParameterError, "container"),
        ({"skin_ratio": 11.0}, gp.InvalidParameterError, "skin_ratio"),
        ({"max_overlap_ratio": 0.0}, gp.InvalidParameterError, "max_overlap_ratio"),
    ],
    ids=["dt", "container", "skin_ratio", "max_overlap_ratio"],
)
def test_the_simulation_gives_the_scene_s_error_for_the_keys_it_shares(changes, cls, parameter):
    scene = gp.PackScene.preset("4.1")
    with pytest.raises(cls) as built:
        gp.PackScene(**{**vars(scene), **changes})
    options = {"dt": scene.dt, **changes}
    with pytest.raises(cls) as simulated:
        sim = gp.Simulation(dim=2, material=scene.material, box=((0, 0), (1, 1)), **options)
        sim.add_particles([[0.5, 0.5]], [scene.r_min])
        sim.step(1)
    assert type(simulated.value) is type(built.value)
    assert simulated.value.parameter == built.value.parameter == parameter
