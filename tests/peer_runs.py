"""Runs of the peer programs (LAMMPS, LIGGGHTS) that several test modules share (imported
by them; not a test module)."""

from __future__ import annotations

import re
import subprocess


def run(program: str, run_dir, text: str) -> str:
    """Runs `program` on the input `text` in `run_dir`; returns its log."""
    (run_dir / "in.test").write_text(text)
    done = subprocess.run(
        [program, "-in", "in.test", "-log", "log.test"],
        cwd=run_dir,
        capture_output=True,
        text=True,
        timeout=120,
    )
    log = (run_dir / "log.test").read_text() if (run_dir / "log.test").exists() else ""
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    return log


def lid_force_in(program: str, run_dir, steps: int) -> float:
    """Runs ``in.granpack`` for `steps` steps in `program`; returns its v_lid_force."""
    (run_dir / "in.test").write_text(
        f'variable steps index {steps}\ninclude in.granpack\nprint "LID ${{lid_force}}"\n'
    )
    return lid_printed(program, run_dir, "in.test")


def lid_printed(program: str, run_dir, script: str) -> float:
    """Runs the input file `script` in `run_dir`; the last lid force it printed (N)."""
    log = run(program, run_dir, (run_dir / script).read_text())
    return float(re.findall(r"^LID (\S+)", log, re.MULTILINE)[-1])
