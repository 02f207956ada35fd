"""The documentation keeps up with the product: every scene key is in the scene
reference, every module is on the architecture map, and the product speaks of the
product (no work diary in its files)."""

from __future__ import annotations

import dataclasses
import json
import re
import subprocess
from pathlib import Path

import pytest

from granpack import Material, PackScene

ROOT = Path(__file__).resolve().parents[2]
SCENE_PAGE = ROOT / "docs" / "scene.md"
MAP = ROOT / "ARCHITECTURE.md"
STUDIES = ROOT / "studies"

#: Words of a work diary, not of a product: numbered work sessions and tracker issues, the
#: virtual machines that measurements were once taken on, and the tools and machines that a
#: piece of work was or was not given. A measurement names its CPU model and date instead
#: (studies/*/manifest.json), and what it measured. The product's own words stay
#: allowed: a session of work, pytest's session scope, a process's new session, the step
#: team's helper threads, the verb "issues".
BANNED = [
    re.compile(r"\bsessions? \d+", re.IGNORECASE),
    re.compile(r"\bsessions \d+\s*(-|to|and)\s*\d+", re.IGNORECASE),
    # a tracker's numbered issue, with or without "#" or a hyphen; not the verb
    re.compile(r"\bissue[ -]?#?\d+|\bissues #\d+", re.IGNORECASE),
    re.compile(r"\bVMs?\b"),
    # what a piece of work was or was not lent to measure with, rather than the CPU measured
    re.compile(r"\bdevice machines?\b", re.IGNORECASE),
    re.compile(r"\bstatus\W{0,3}:?\W{0,3}not drawn|\bnot drawn\)", re.IGNORECASE),
    # a machine, device or task that was (not) drawn or lent; a figure is not drawn
    re.compile(
        r"\b(machines?|devices?|GPUs?|accelerators?|tasks?)\b[^.\n]{0,40}\bnot drawn\b"
        r"|\bdrawn (by chance|for (this|the|a|each) (task|session|piece of work))\b",
        re.IGNORECASE,
    ),
    re.compile(r"\bno device\b|\bdevice (time|checks?|runs?|budget|loans?)\b", re.IGNORECASE),
    re.compile(
        r"\b(was|were|is|are|been|not|none|never) lent\b|\blent (to|for) (this|the|a|one|each)"
        r" (task|session|piece of work|run)\b|\b(machines?|devices?|GPUs?) (was |were )?lent\b",
        re.IGNORECASE,
    ),
    re.compile(r"\b(in|for|of) this task\b", re.IGNORECASE),
    # a session as a stretch of someone's work, not a session of the product's tools
    re.compile(r"\b(this|last|next|previous|earlier|later|current|that) session\b", re.IGNORECASE),
    # a helper as a person or program doing the work, not the team's helper threads
    re.compile(
        r"\bhelpers?(\'s)? (agents?|sessions?|engineers?|reports?|briefs?)\b", re.IGNORECASE
    ),
    re.compile(r"\b(a|the) helper (found|wrote|measured|ran|said|reported)\b", re.IGNORECASE),
]
#: Files whose bytes are not prose: lock files, binary data, recorded regressions.
SKIP_SUFFIXES = {".lock", ".png", ".npz", ".parquet", ".whl"}


def product_files() -> list[Path]:
    """Tracked and new (not ignored) files of the checkout."""
    try:
        out = subprocess.run(
            ["git", "ls-files", "--cached", "--others", "--exclude-standard"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout: the product's file list is git's")
    names = out.splitlines()
    # A virtual environment the user made in the checkout under a name .gitignore does not
    # know (`python -m venv env`) is not the product: leave out every folder that holds a
    # pyvenv.cfg.
    venvs = tuple(n[: -len("pyvenv.cfg")] for n in names if n.endswith("/pyvenv.cfg"))
    paths = [ROOT / n for n in names if not n.startswith(venvs)]
    return [p for p in paths if p.is_file() and p.suffix not in SKIP_SUFFIXES]


def scene_keys() -> list[str]:
    """Every key a scene takes: PackScene's fields, `preset`, and the [material] table."""
    keys = [f.name for f in dataclasses.fields(PackScene)] + ["preset"]
    return keys + [f"material.{f.name}" for f in dataclasses.fields(Material)]


def test_every_scene_key_is_in_the_scene_reference():
    text = SCENE_PAGE.read_text()
    # a key counts as documented where it is a row of a table: | `key` | ...
    rows = set(re.findall(r"^\|\s*`([a-z_0-9.]+)`", text, flags=re.MULTILINE))
    missing = [k for k in scene_keys() if k not in rows]
    assert not missing, f"scene keys missing from {SCENE_PAGE.name}: {missing}"
    stale = sorted(rows - set(scene_keys()))
    assert not stale, f"{SCENE_PAGE.name} documents keys the scene does not take: {stale}"


def test_the_scene_reference_gives_each_default():
    text = SCENE_PAGE.read_text()
    # defaults as declared: r_min's None, not the value derived from r_mean
    declared = [(f.name, f.default) for f in dataclasses.fields(PackScene)]
    declared += [(f"material.{f.name}", f.default) for f in dataclasses.fields(Material)]
    for name, value in declared:
        if not isinstance(value, int | float | str):
            continue  # material (a factory), base (a tuple), None (unset or derived)
        row = re.search(rf"^\|\s*`{re.escape(name)}`\s*\|(.*)$", text, flags=re.MULTILINE)
        assert row, name
        cells = row.group(1)
        if isinstance(value, bool):
            assert str(value).lower() in cells.lower(), (name, value, cells)
        elif isinstance(value, str):
            assert f'"{value}"' in cells, (name, value, cells)
        else:
            numbers = re.findall(r"\d[\d_]*(?:\.\d*)?(?:e-?\d+)?", cells)
            assert value in [float(x.replace("_", "")) for x in numbers], (name, value, cells)


def test_no_product_file_speaks_of_sessions_issues_or_vms():
    me = Path(__file__).resolve()
    found = []
    for path in product_files():
        rel = path.relative_to(ROOT).as_posix()
        for pat in BANNED:
            if pat.search(rel):
                found.append(f"{rel}: file name")
        if path.resolve() == me:
            continue
        try:
            text = path.read_text()
        except UnicodeDecodeError:
            continue
        for n, line in enumerate(text.splitlines(), 1):
            if any(p.search(line) for p in BANNED):
                found.append(f"{rel}:{n}: {line.strip()[:100]}")
    assert not found, "diary words in product files:\n" + "\n".join(found)


def test_the_banned_words_are_caught():
    # the check above would pass vacuously if the patterns matched nothing
    diary = (
        "in session 16 we",
        "Sessions 3 to 5",
        "see issue 6",
        "fixes issue-12",
        "the Zen 5 VM",
        "VMs",
        "No device machine for this task (`status`: not drawn), so 1 and 2 threads",
        "(status: not drawn)",
        "the GPU was not drawn)",
        "the device machine was not drawn for this work",
        "a GPU machine is not drawn, so the CPU figures stand",
        "the task's accelerator, not drawn, so no GPU run",
        "machines are drawn by chance for each task",
        "No device for this work, so 1 and 2 threads",
        "no device: the figures are the CPU's",
        "within the device time left",
        "the device checks were not run",
        "no GPU was lent",
        "a machine lent to this task",
        "the accelerator machines were lent to some tasks only",
        "machines lent",
        "measured in this task",
        "as in the last session",
        "this session's time",
        "the helper session measured it",
        "the helper's report says",
        "a helper found that",
    )
    for line in diary:
        assert any(p.search(line) for p in BANNED), line
    product = (
        "a session of work",
        "it issues 5 roots",
        "VMD reads it",
        "the Zen 5 CPU",
        '@pytest.fixture(scope="session")',
        "`granpack ARGS` in a new session (its own process group)",
        "the session's example_4_3, a fixture shared by the peer checks",
        "the master spawns one helper job per other thread; the helpers spin",
        "a helper that never starts leaves its items to the master",
        "a large sphere drawn late in a layer",
        "each task of the ensemble is a pack",
        'raise OSError(28, "No space left on device")',
        "a rename would replace a device (/dev/null), a pipe or a folder",
        "the periodic images are not drawn; the seam is",
        "a contact across a periodic seam is drawn as its short segment",
        "the spheres drawn back to front, coloured by layer",
    )
    for line in product:
        assert not any(p.search(line) for p in BANNED), line


def _named(text: str, name: str) -> bool:
    """`name` (a file name, or a folder as ``name/``) is a word of `text`, not the tail of
    a longer path or name (``io/tables.py`` does not name the top-level ``tables.py``)."""
    return re.search(rf"(?<![\w./-]){re.escape(name)}(?![\w])", text) is not None


def unmapped_modules(text: str) -> list[str]:
    """The modules of python/granpack and src/ that `text` (the map) does not name.

    Python: a top-level module is named by its file name (``scene.py``); a module inside a
    package is named by the package's folder (``io/``, ``analysis/``, ``cli/``,
    ``paper/``), which then covers all its modules, private ones (``io/_text.py``,
    ``cli/_console.py``) included, or else by its path in the package (``io/registry.py``).
    ``__init__.py`` and ``__main__.py`` are their package. No module is exempt:
    ``_validate.py`` is named like the rest, and ``_core`` is the extension, not a ``.py``.

    Rust: every folder under src/ (``pipeline/``, ``world/``) and every file by its name
    (``forces.rs``, written alone or after its folder, ``world/forces.rs``); ``mod.rs`` is
    its folder."""
    missing = []
    py_root = ROOT / "python" / "granpack"
    for path in sorted(py_root.rglob("*.py")):
        rel = path.relative_to(py_root)
        folders = [f"{'/'.join(rel.parts[: k + 1])}/" for k in range(len(rel.parts) - 1)]
        if path.name in ("__init__.py", "__main__.py"):
            names = folders[-1:] or [path.name]
        elif folders:
            names = [*folders, rel.as_posix(), f"{rel.parts[-2]}/{path.name}"]
        else:
            names = [path.name]
        if not any(_named(text, n) for n in names):
            missing.append(f"python/granpack/{rel.as_posix()}")
    rs_root = ROOT / "src"
    for path in sorted(rs_root.rglob("*")):
        rel = path.relative_to(rs_root)
        if path.is_dir():
            name = f"{path.name}/"
            ok = _named(text, name) or _named(text, f"{rel.as_posix()}/")
        elif path.suffix == ".rs":
            if path.name == "mod.rs":
                continue
            ok = re.search(rf"(?<![\w.-]){re.escape(path.name)}\b", text) is not None
        else:
            continue
        if not ok:
            missing.append(f"src/{rel.as_posix()}")
    return missing


def test_every_module_is_on_the_architecture_map():
    missing = unmapped_modules(MAP.read_text())
    assert not missing, f"modules that {MAP.name} does not name: {missing}"


def test_the_architecture_map_check_sees_a_missing_module():
    # the same check on a map without one line: the modules of that line are flagged
    lines = MAP.read_text().splitlines()
    without_world = "\n".join(ln for ln in lines if not ln.startswith("- `pipeline/world/`"))
    assert "src/pipeline/world/forces.rs" in unmapped_modules(without_world)
    without_io = "\n".join(ln for ln in lines if "`io/`" not in ln)
    assert "python/granpack/io/registry.py" in unmapped_modules(without_io)
    # a module named only inside another folder's path is not named: the top-level
    # tables.py is not named by io/tables.py
    text = re.sub(r"(?<![\w./-])tables\.py", "tables", MAP.read_text()) + "\n`io/tables.py`"
    assert "python/granpack/tables.py" in unmapped_modules(text)


def _keys(value) -> set[str]:
    """Every key of a JSON value, at any depth (a reconstructed manifest lists its runs)."""
    if isinstance(value, dict):
        return set(value) | {k for v in value.values() for k in _keys(v)}
    if isinstance(value, list):
        return {k for v in value for k in _keys(v)}
    return set()


def test_every_study_folder_with_results_has_a_manifest():
    # a folder of studies/ that holds results (anything but its scripts) says where they
    # came from: the commit, the CPU, the date and the command
    folders = [STUDIES, *sorted(p for p in STUDIES.rglob("*") if p.is_dir())]
    checked = 0
    for folder in folders:
        if folder == STUDIES or folder.name in ("_common", "__pycache__"):
            continue
        # its scripts and its entry page (README.md) are not results
        results = [
            f
            for f in folder.iterdir()
            if f.is_file() and f.suffix not in (".py", ".pyc") and f.name != "README.md"
        ]
        if not results:
            continue
        manifests = sorted(folder.glob("manifest*.json"))
        assert manifests, f"{folder.relative_to(ROOT)} holds results without a manifest"
        for m in manifests:
            keys = _keys(json.loads(m.read_text()))
            for want in ("commit", "cpu_model", "date", "command"):
                assert any(k.startswith(want) for k in keys), (m.relative_to(ROOT), want)
        checked += 1
    assert checked >= 10, checked
