"""Medians over the rounds of run.sh's search.txt, ns a particle per search, as a
Markdown table: bounded and periodic, one and two threads, before and after.

    python studies/periodic_search/summary.py studies/periodic_search/search.txt
"""

import re
import statistics
import sys
from collections import defaultdict


def main(path: str) -> None:
    line = re.compile(
        r"tiles (\d+) periodic (\d) threads (\d) build (\w+): (\d+) particles, (\d+) pairs,"
        r" [\d.]+ ms per search, ([\d.]+) ns a particle"
    )
    ns = defaultdict(list)
    size = {}
    for text in open(path):
        m = line.search(text)
        if m is None:
            continue
        tiles, periodic, threads, build, n, pairs, t = m.groups()
        ns[(int(tiles), int(periodic), int(threads), build)].append(float(t))
        size[(int(tiles), int(periodic))] = (int(n), int(pairs))
    print("| spheres | cell | threads | before | after | after / before |")
    print("|---|---|---|---|---|---|")
    for tiles in sorted({k[0] for k in ns}):
        for periodic in (0, 1):
            for threads in (1, 2):
                b = statistics.median(ns[(tiles, periodic, threads, "before")])
                a = statistics.median(ns[(tiles, periodic, threads, "after")])
                n = size[(tiles, periodic)][0]
                cell = "periodic" if periodic else "bounded"
                row = f"| {n:,} | {cell} | {threads} | {b:.1f} | {a:.1f} | {a / b:.2f} |"
                print(row.replace(",", " "))


if __name__ == "__main__":
    main(sys.argv[1])
