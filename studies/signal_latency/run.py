"""How fast the `granpack` command stops on Ctrl-C and SIGTERM, at random moments.

Starts a command, sends the signal after a delay drawn uniformly from a window inside the
command's run, and measures the wall time from the signal to the process's exit, with
its exit status. Ctrl-C is sent as a terminal sends it, to the whole process group
(the worker processes ignore it; the command stops them); SIGTERM is sent to the
command alone, as `kill` or a batch scheduler sends it.

    python studies/signal_latency/run.py --tries 20 --out studies/signal_latency/results

Writes latencies.csv (one row a try) and summary.md (per command and signal: tries,
the median and largest latency, the exit statuses, the runs that ended before the
signal) into --out, with a manifest.
"""

from __future__ import annotations

import argparse
import csv
import os
import random
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))

#: name -> (argv after `granpack`, window of signal delays (s) inside the run)
COMMANDS = {
    "generate --fast": (
        ["generate", "4.3", "--fast", "--packs", "1", "--workers", "1", "--no-figures", "-q"],
        (1.0, 10.0),
    ),
    "generate (density search)": (
        [
            "generate",
            "4.1",
            "--fast",
            "--packs",
            "1",
            "--workers",
            "1",
            "--no-figures",
            "-q",
            "--target-phi",
            "0.87",
        ],
        (1.0, 10.0),
    ),
    "limits": (["limits", "4.1", "--packs", "1", "--fast", "-q"], (1.0, 10.0)),
}
SIGNALS = {"SIGINT": (signal.SIGINT, 130), "SIGTERM": (signal.SIGTERM, 143)}


def one_try(argv: list[str], sig: int, delay: float) -> tuple[float | None, int]:
    """Runs `granpack argv`, signals it after `delay` s; returns (latency s, status), the
    latency None when the command ended before the signal."""
    with tempfile.TemporaryDirectory() as tmp:
        out = [] if argv[0] == "limits" else ["--out", str(Path(tmp) / "out")]
        proc = subprocess.Popen(
            [sys.executable, "-m", "granpack.cli", *argv, *out],
            cwd=tmp,
            start_new_session=True,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
        )
        try:
            proc.wait(timeout=delay)
            return None, proc.returncode
        except subprocess.TimeoutExpired:
            pass
        t0 = time.perf_counter()
        if sig == signal.SIGINT:
            os.killpg(proc.pid, sig)  # a terminal's Ctrl-C reaches the whole group
        else:
            os.kill(proc.pid, sig)
        # A blocking wait returns the moment the process exits (wait(timeout=...) polls
        # in steps of up to 50 ms); a watchdog ends a command that does not stop.
        watchdog = threading.Timer(60.0, os.killpg, (proc.pid, signal.SIGKILL))
        watchdog.start()
        status = proc.wait()
        latency = time.perf_counter() - t0
        watchdog.cancel()
        if status == -signal.SIGKILL:
            return float("inf"), status
        proc.stderr.close()
        return latency, status


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tries", type=int, default=20)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    ap.add_argument("--only", default=None, help="run only the commands whose name holds this")
    a = ap.parse_args()
    rng = random.Random(a.seed)
    a.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name, (argv, (lo, hi)) in COMMANDS.items():
        if a.only and a.only not in name:
            continue
        for sname, (sig, want) in SIGNALS.items():
            for k in range(a.tries):
                delay = rng.uniform(lo, hi)
                lat, status = one_try(argv, sig, delay)
                rows.append(
                    {
                        "command": name,
                        "signal": sname,
                        "try": k,
                        "delay_s": round(delay, 3),
                        "latency_s": "" if lat is None else round(lat, 4),
                        "status": status,
                        "expected": want,
                    }
                )
                print(name, sname, k, delay, lat, status, flush=True)
    with open(a.out / "latencies.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = [
        "| command | signal | tries signalled | ended before | median s | max s | exit statuses |",
        "|---|---|---|---|---|---|---|",
    ]
    for name in COMMANDS:
        for sname in SIGNALS:
            rs = [r for r in rows if r["command"] == name and r["signal"] == sname]
            if not rs:
                continue
            lats = sorted(r["latency_s"] for r in rs if r["latency_s"] != "")
            before = sum(r["latency_s"] == "" for r in rs)
            statuses = sorted({r["status"] for r in rs if r["latency_s"] != ""})
            med = lats[len(lats) // 2] if lats else float("nan")
            mx = lats[-1] if lats else float("nan")
            lines.append(
                f"| {name} | {sname} | {len(lats)} | {before} | {med:.3f} | {mx:.3f} | "
                f"{', '.join(map(str, statuses))} |"
            )
    (a.out / "summary.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    from manifest import write_manifest  # type: ignore[import-not-found]

    write_manifest(a.out, seeds=[a.seed], extra={"tries": a.tries})


if __name__ == "__main__":
    main()
