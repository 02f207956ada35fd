"""Ctrl-C and SIGTERM at random moments of every stage stop the command promptly, with
the documented exit status (130 for Ctrl-C, 143 for SIGTERM).

Each case first runs its command once to the end to learn how long it takes (T), then
signals it many times at moments drawn uniformly from (0.02 T, 0.9 T): inside the
layer loop's adaptive settle, its last chunk, the placement, a stage, the density
search's generations, or the Python between them. A signal that lands on the chunk that
ends an engine call is the case that used to be lost (the layer ran on, or the whole
pack did). The command runs in this process (one worker: no pool), so that a try costs
its own run and nothing else; the signal comes from a timer thread, as the kernel
delivers Ctrl-C or `kill`.
"""

from __future__ import annotations

import gc
import os
import random
import signal
import threading
import time
from pathlib import Path

import pytest

import granpack as gp
from granpack import cli

#: the bound the command promises, with room for a loaded machine: the engine polls
#: for signals every 0.1 s of wall time
STOP_WITHIN_S = 0.5
EXPECTED = {signal.SIGINT: cli.EXIT_INTERRUPTED, signal.SIGTERM: cli.EXIT_TERMINATED}


def _raise_interrupt(signum, frame):
    raise KeyboardInterrupt


def _signalled_run(argv: list[str], sig: int | None, delay: float) -> tuple[int | None, float]:
    """Runs ``granpack argv`` in this process and sends `sig` to it after `delay` s.
    Returns (exit status, seconds from the signal to the command's return); the
    latency is -1 when the command returned before the signal was sent, and the status
    None when the signal escaped the command as an exception."""
    sent: list[float] = []
    lock = threading.Lock()
    finished = threading.Event()

    def fire() -> None:
        with lock:
            if finished.is_set():
                return
            sent.append(time.perf_counter())
            os.kill(os.getpid(), sig)

    # Outside the command, either signal raises KeyboardInterrupt here (a late one is
    # caught below); the command sets its own SIGTERM handler and restores this one.
    old = {s: signal.signal(s, _raise_interrupt) for s in EXPECTED}
    # A handler that runs inside a Python gc callback (hypothesis registers one) raises
    # where Python can only report it as unraisable, and the signal is lost: the
    # command's own runs have no such callbacks, so the test removes them meanwhile.
    callbacks = gc.callbacks[:]
    gc.callbacks.clear()
    timer = threading.Timer(delay, fire) if sig is not None else None
    status: int | None = None
    ended = float("nan")
    try:
        try:
            if timer is not None:
                timer.start()
            status = cli.main(argv)
            ended = time.perf_counter()
            with lock:
                finished.set()
            if timer is not None:
                timer.join()
            time.sleep(0.05)  # a signal sent just now raises here, not in pytest
        except KeyboardInterrupt:
            # a signal sent as the command returned raises here, not in pytest; one
            # that escaped the command itself leaves the status None
            if status is None:
                ended = time.perf_counter()
    finally:
        if timer is not None:
            timer.cancel()
        for s, h in old.items():
            signal.signal(s, h)
        gc.callbacks.extend(callbacks)
    if not sent or ended < sent[0]:
        return status, -1.0
    return status, ended - sent[0]


def _scene_file(tmp_path: Path, name: str, scene: gp.PackScene) -> str:
    path = tmp_path / f"{name}.toml"
    path.write_text(scene.to_toml())
    return str(path)


def _cases(tmp_path: Path) -> dict[str, list[str]]:
    """Each case's command: reduced paper scenes that run for about 1.5 to 8 s."""
    preset = gp.PackScene.preset
    s3 = _scene_file(tmp_path, "s3", preset("4.3").replace(base=(0.45, 0.45), height=0.25))
    s2 = _scene_file(tmp_path, "s2", preset("4.1").replace(base=(0.5,), height=0.2))
    common = ["--packs", "1", "--workers", "1", "--no-figures", "-q"]
    return {
        "generate --fast": ["generate", s3, "--fast", *common],
        "generate, the paper's settings": ["generate", s2, *common],
        "generate with a flat top and a consolidation": [
            "generate",
            s2,
            "--trim",
            "--consolidate",
            "1e4",
            *common,
        ],
        "generate with a density search": [
            "generate",
            s2,
            "--fast",
            "--target-phi",
            "0.87",
            "--density-tol",
            "0.01",
            *common,
        ],
        "limits": ["limits", s2, "--packs", "1", "--fast", "-q"],
    }


#: tries per signal: the commands a user stops most often get the most (the study
#: studies/signal_latency/ sends 20 of each signal to each command, as processes)
TRIES = {
    "generate --fast": 20,
    "limits": 20,
    "generate with a density search": 10,
    "generate, the paper's settings": 6,
    "generate with a flat top and a consolidation": 6,
}


@pytest.mark.slow
@pytest.mark.parametrize("case", list(TRIES))
def test_ctrl_c_and_sigterm_at_random_moments_stop_within_half_a_second(case, tmp_path):
    argv = _cases(tmp_path)[case]
    out = ["--out", str(tmp_path / "out")] if argv[0] == "generate" else []

    def run(k: int, sig: int | None, delay: float) -> tuple[int | None, float]:
        where = ["--out", str(tmp_path / f"out{k}")] if out else []
        return _signalled_run([*argv, *where], sig, delay)

    t0 = time.perf_counter()
    status, _ = run(0, None, 0.0)
    whole = time.perf_counter() - t0
    assert status == 0, f"{case}: the unsignalled run exited {status}"
    rng = random.Random(f"{case}")
    late: list[str] = []
    stopped = 0
    for sig in EXPECTED:
        for k in range(TRIES[case]):
            delay = rng.uniform(0.02, 0.9) * whole
            status, latency = run(1 + k + 100 * int(sig), sig, delay)
            if latency < 0:
                continue  # the command ended before the signal: nothing to stop
            stopped += 1
            name = signal.Signals(sig).name
            if status != EXPECTED[sig] or latency > STOP_WITHIN_S:
                late.append(f"{name} at {delay:.2f} s: exit {status} after {latency:.2f} s")
    assert not late, f"{case} (whole run {whole:.2f} s): {late}"
    # most moments fall inside the run (a moment past its end is no stop to test)
    assert stopped >= TRIES[case], f"{case}: only {stopped} signals landed inside the run"
