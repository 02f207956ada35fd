"""Runs commands alternately and compares a number they print: the way to time a change
on a machine whose speed drifts by 20-30 % over an hour (see DEVELOPERS.md).

    cp target/release/examples/pack_profile /tmp/pp_old      # before the change
    cargo build --release --examples                         # after it
    python studies/_common/alternate.py --rounds 4 --pattern 'total ([0-9.]+) s' \\
        --run old '/tmp/pp_old 2d' --run new 'target/release/examples/pack_profile 2d'

Each round runs every command once, in the order given, so that drift hits all of them
alike. `--pattern` is a regular expression with one group; every match in a command's
output is a series of its own (`step_min` prints one line for 3D and one for 2D). The
report gives each series' values by round, their minimum and median, in how many
rounds each command printed less than the first one (lower is better: times), and the
ratio to the first one taken round by round (its median and range), which a drift of
the machine between rounds does not move.
"""

from __future__ import annotations

import argparse
import re
import shlex
import statistics
import subprocess


def run_once(cmd: str, pattern: re.Pattern[str]) -> list[float]:
    """The numbers `pattern` finds in the output of `cmd` (stdout and stderr)."""
    out = subprocess.run(shlex.split(cmd), capture_output=True, text=True, check=True)
    found = [float(m) for m in pattern.findall(out.stdout + out.stderr)]
    if not found:
        raise SystemExit(f"--pattern found nothing in the output of {cmd!r}")
    return found


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--rounds", type=int, default=4, help="rounds (each command once per round)")
    ap.add_argument("--pattern", required=True, help="a regular expression with one group")
    ap.add_argument(
        "--run",
        nargs=2,
        action="append",
        metavar=("LABEL", "COMMAND"),
        required=True,
        help="a label and the command to time (repeat; the first is the baseline)",
    )
    a = ap.parse_args(argv)
    if a.rounds < 1:
        ap.error(f"--rounds must be at least 1, got {a.rounds}")
    pattern = re.compile(a.pattern)
    if pattern.groups != 1:
        ap.error(f"--pattern must have exactly one group, it has {pattern.groups}")
    values: dict[str, list[list[float]]] = {label: [] for label, _ in a.run}
    for r in range(a.rounds):
        for label, cmd in a.run:
            got = run_once(cmd, pattern)
            values[label].append(got)
            print(f"round {r + 1}: {label} {' '.join(f'{x:g}' for x in got)}", flush=True)
    base = a.run[0][0]
    print()
    for label, rounds in values.items():
        for k in range(min(len(v) for v in rounds)):
            series = [v[k] for v in rounds]
            mid = statistics.median(series)
            line = f"{label:12s} #{k}  min {min(series):10.4g}  median {mid:10.4g}"
            if label != base and k < min(len(v) for v in values[base]):
                below = sum(s < b[k] for s, b in zip(series, values[base], strict=True))
                line += f"  below {base} in {below} of {len(series)} rounds"
                ratios = [s / b[k] for s, b in zip(series, values[base], strict=True)]
                line += (
                    f"  ratio median {statistics.median(ratios):.3f}"
                    f" ({min(ratios):.3f}-{max(ratios):.3f})"
                )
            print(line + "  | " + " ".join(f"{x:g}" for x in series))


if __name__ == "__main__":
    main()
