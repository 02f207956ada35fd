"""studies/_common/alternate.py: the numbers it reports are those the commands printed."""

from __future__ import annotations

import shlex
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "studies" / "_common" / "alternate.py"


def printer(*values: float) -> str:
    """A command that prints `total X s` for each value."""
    body = "; ".join(f"print('total {v} s')" for v in values)
    return f"{shlex.quote(sys.executable)} -c {shlex.quote(body)}"


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args], capture_output=True, text=True, check=False
    )


def test_reports_each_series_and_counts_rounds_below_the_baseline():
    res = run(
        "--rounds", "3", "--pattern", r"total ([0-9.]+) s",
        "--run", "old", printer(2.0, 40.0),
        "--run", "new", printer(1.5, 50.0),
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert sum(line.startswith("round ") for line in lines) == 6
    summary = {tuple(line.split()[:2]): line for line in lines if " min " in line}
    assert "min          2  median          2" in summary[("old", "#0")]
    assert "below" not in summary[("old", "#0")]
    assert "min        1.5" in summary[("new", "#0")]
    assert "below old in 3 of 3 rounds" in summary[("new", "#0")]
    assert "below old in 0 of 3 rounds" in summary[("new", "#1")]
    # the ratio to the baseline, round by round: 1.5 / 2 and 50 / 40 each round
    assert "ratio median 0.750 (0.750-0.750)" in summary[("new", "#0")]
    assert "ratio median 1.250 (1.250-1.250)" in summary[("new", "#1")]
    assert "ratio" not in summary[("old", "#0")]
    assert summary[("new", "#1")].endswith("| 50 50 50")


def test_refuses_a_pattern_without_one_group_and_output_without_a_match():
    res = run("--pattern", "total", "--run", "a", printer(1.0))
    assert res.returncode != 0 and "exactly one group" in res.stderr
    res = run("--pattern", r"speed (\d+)", "--run", "a", printer(1.0))
    assert res.returncode != 0 and "found nothing" in res.stderr
