"""The hot kernels are compiled for several x86-64 levels and chosen at run time: every
level this CPU runs gives the same bits, and GRANPACK_CPU_LEVEL forces one or is refused
by name."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import granpack as gp

CHECK = Path(__file__).resolve().parents[2] / "tools" / "cpu_check.py"


def run_check(level: str | None) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ)
    env.pop("GRANPACK_CPU_LEVEL", None)
    if level is not None:
        env["GRANPACK_CPU_LEVEL"] = level
    return subprocess.run(
        [sys.executable, str(CHECK)], env=env, capture_output=True, text=True, timeout=120
    )


def test_the_default_is_the_cpus_highest_level():
    assert gp.cpu_levels()[-1] == gp.cpu_level() or "GRANPACK_CPU_LEVEL" in os.environ
    assert gp.cpu_levels()[0] in ("x86-64", "baseline")


def test_every_level_gives_the_same_bits():
    out = {}
    for level in gp.cpu_levels():
        p = run_check(level)
        assert p.returncode == 0, p.stderr
        name, checksum = p.stdout.split()[1], p.stdout.split()[3]
        assert name == level
        out[level] = checksum
    assert len(set(out.values())) == 1, out


@pytest.mark.parametrize("bad", ["avx9000", "x86-64-v5", "x" * 5000])
def test_a_bad_level_fails_the_import_by_name(bad):
    p = run_check(bad)
    assert p.returncode != 0
    last = p.stderr.strip().splitlines()[-1]
    assert last.startswith("granpack.errors.InvalidParameterError: invalid GRANPACK_CPU_LEVEL")
    assert "x86-64-v3" in last and len(last) < 300


def test_importing_granpack_leaves_polars_out():
    """polars' wheels need AVX2 and crash on import without it; granpack's engine runs on
    any x86-64 CPU (tools/cpu_check.py under qemu's Nehalem in CI), so `import granpack`
    must not import polars: the tables import it when they are made."""
    import subprocess
    import sys

    code = "import sys, granpack; print('polars' in sys.modules)"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert res.stdout.strip() == "False"


def test_native_names_the_cpus_highest_level():
    p = run_check("native")
    assert p.returncode == 0, p.stderr
    assert p.stdout.split()[1] == gp.cpu_levels()[-1]


def test_a_level_that_is_not_utf8_fails_the_import_by_name():
    env = {k: v for k, v in os.environb.items() if k != b"GRANPACK_CPU_LEVEL"}
    env[b"GRANPACK_CPU_LEVEL"] = b"x86-64-v\xff"
    p = subprocess.run(
        [sys.executable, str(CHECK)], env=env, capture_output=True, text=True, timeout=120
    )
    assert p.returncode != 0
    last = p.stderr.strip().splitlines()[-1]
    assert last.startswith("granpack.errors.InvalidParameterError: invalid GRANPACK_CPU_LEVEL")
    assert "not UTF-8" in last and "native" in last and "\\xff" in last.lower()
