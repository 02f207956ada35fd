"""The Python package's import graph keeps the shape ARCHITECTURE.md draws: no circle
between its modules, nor between its packages (the contract in pyproject.toml's
``[tool.importlinter]``)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_import_graph_has_no_circle():
    exe = shutil.which("lint-imports", path=str(Path(sys.executable).parent)) or shutil.which(
        "lint-imports"
    )
    assert exe, "lint-imports is part of the test extra: pip install '.[test]'"
    run = subprocess.run(
        [exe, "--no-cache", str(ROOT / "pyproject.toml")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stdout + run.stderr


def test_import_granpack_loads_no_heavy_library():
    # `import granpack` stays fast: numpy, polars, matplotlib and the rest load on first use
    heavy = ("numpy", "polars", "matplotlib", "scipy", "dask", "tqdm", "tomli_w")
    code = f"import sys, granpack; print([m for m in {heavy!r} if m in sys.modules])"
    run = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True
    )
    assert run.stdout.strip() == "[]"


def test_the_names_of_the_api_load_on_first_use():
    code = (
        "import granpack as gp; "
        "assert all(getattr(gp, n) is not None for n in gp.__all__); "
        "assert gp.profiles.__module__ == 'granpack.analysis.profiles'; "
        "assert gp.analysis.microstructure is gp.microstructure; "
        "import granpack.tiling; "
        "assert callable(gp.tile) and gp.tile.__module__ == 'granpack.tiling'"
    )
    subprocess.run([sys.executable, "-c", code], timeout=120, check=True)


def test_every_invalid_parameter_error_names_its_parameter():
    # the package names the parameter where it raises; reading it back from the message
    # is left to code outside the package that gives none
    import ast

    missing = []
    for path in sorted((ROOT / "python" / "granpack").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if (
                isinstance(node, ast.Call)
                and getattr(node.func, "id", getattr(node.func, "attr", None))
                == "InvalidParameterError"
                and not any(k.arg == "parameter" for k in node.keywords)
            ):
                missing.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not missing, missing
