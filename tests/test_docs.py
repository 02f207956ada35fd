"""The documentation keeps up with the product: every scene key is in the scene
reference, and the product speaks of the product (no work diary in its files)."""

from __future__ import annotations

import dataclasses
import re
import subprocess
from pathlib import Path

import pytest

from granpack import Material, PackScene

ROOT = Path(__file__).resolve().parents[1]
SCENE_PAGE = ROOT / "docs" / "scene.md"

#: Words of a work diary, not of a product: numbered work sessions and tracker issues, and
#: the virtual machines that measurements were once taken on. A measurement names its CPU
#: model and date instead (benchmarks/results/*/manifest.json).
BANNED = [
    re.compile(r"\bsessions? \d+", re.IGNORECASE),
    re.compile(r"\bsessions \d+\s*(-|to|and)\s*\d+", re.IGNORECASE),
    # "issue 7", "Issue #6", "issues #6"; not the verb ("it issues 5 square roots")
    re.compile(r"\bissue #?\d+|\bissues #\d+", re.IGNORECASE),
    re.compile(r"\bVMs?\b"),
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
    for line in ("in session 16 we", "Sessions 3 to 5", "see issue 6", "the Zen 5 VM", "VMs"):
        assert any(p.search(line) for p in BANNED), line
    for line in ("a session of work", "it issues 5 roots", "VMD reads it", "the Zen 5 CPU"):
        assert not any(p.search(line) for p in BANNED), line
