"""Every script in examples/ runs as a user runs it (`python examples/NAME.py FOLDER`),
exits 0, and prints its result line. A new script needs its line in EXPECTED.

Scripts that run a peer program name its fixture in PEERS: the test then skips where the
program is missing, and fails instead where GRANPACK_PEERS=required (as .ci/run sets it
where it could install the peers), so CI runs them."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
SCRIPTS = sorted(EXAMPLES.glob("*.py"))

#: A line each script prints when it worked (a regular expression, searched in stdout).
EXPECTED = {
    "first_pack.py": r"^phi = 0\.\d+ +phi_core = 0\.\d+ +Z = \d\.\d+$",
    "sieve_curve.py": r"^passing +50 mm: +\d+\.\d %$",
    "liggghts_round_trip.py": r"^step 0: \d+ spheres, positions and radii identical: True$",
    "batch_cluster.py": r"^3 packs written by the workers, phi = 0\.\d+ ± 0\.\d+$",
}
#: The fixture (tests/conftest.py) of the peer program a script runs.
PEERS = {"liggghts_round_trip.py": "liggghts"}


def test_every_example_has_its_expected_line():
    assert SCRIPTS, f"no scripts in {EXAMPLES}"
    names = {p.name for p in SCRIPTS}
    assert names == set(EXPECTED), (
        f"examples without an expected line: {sorted(names - set(EXPECTED))}; "
        f"expected lines without a script: {sorted(set(EXPECTED) - names)}"
    )


@pytest.mark.slow
@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_example_runs_and_prints_its_result(script, tmp_path, request):
    if script.name in PEERS:
        request.getfixturevalue(PEERS[script.name])
    done = subprocess.run(
        [sys.executable, str(script), str(tmp_path / "out")],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    pattern = EXPECTED[script.name]
    assert re.search(pattern, done.stdout, flags=re.MULTILINE), (pattern, done.stdout[-3000:])
    # each writes into the folder it is given, nowhere else
    assert any((tmp_path / "out").iterdir())
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
