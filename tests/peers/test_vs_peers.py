"""studies/vs_peers/vs_peers.py --quick: granpack and the peers on two layers of the paper's
jobs, one run, with a manifest. Needs LAMMPS and LIGGGHTS (Debian packages `lammps`,
`liggghts`) and the peers' inputs beside the checkout; skipped otherwise."""

from __future__ import annotations

import csv
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "studies" / "vs_peers" / "vs_peers.py"
PEERS = Path(os.environ.get("GRANPACK_PEERS_DIR", ROOT.parent / "shared" / "peers"))

missing = [b for b in ("lmp", "liggghts", "taskset") if shutil.which(b) is None]
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(
        bool(missing), reason=f"peers not installed: {', '.join(missing)} not on PATH"
    ),
    pytest.mark.skipif(
        not (PEERS / "lammps" / "in.pack2d").is_file(),
        reason=f"no peer inputs under {PEERS} (set GRANPACK_PEERS_DIR)",
    ),
]


def test_quick_side_by_side_writes_rows_ratios_and_manifest(tmp_path):
    out = tmp_path / "vs"
    run = subprocess.run(
        [sys.executable, str(SCRIPT), "--quick", "--peers-dir", str(PEERS), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr
    with open(out / "vs_peers.csv") as f:
        rows = list(csv.DictReader(f))
    by = {(r["job"], r["code"], r["variant"].split(",")[0]): r for r in rows}
    # each job: its peer and granpack three ways
    for job, peer in (("4.3", "liggghts"), ("4.1", "lammps")):
        assert (job, peer, "1 core") in by
        for variant in ("1 thread", "fast()"):
            assert (job, "granpack", variant) in by
        assert len([r for r in rows if r["job"] == job]) == 4
    for r in rows:
        assert int(r["layers"]) == 2, r  # --quick: two layers on every side
        assert float(r["wall_s"]) > 0
        ns = float(r["ns_per_particle_step"])
        assert math.isclose(ns, 1e9 * float(r["wall_s"]) / int(r["particle_steps"]), rel_tol=1e-9)
        assert 1.0 < ns < 1e5, r
        # two settled layers of the same job: similar packs on both sides
        assert 0.3 < float(r["phi"]) < 0.9, r
        assert 2.0 < float(r["z"]) < 6.0, r
    # the peers place as many particles per layer as granpack, within RSA's spread
    for job, peer in (("4.3", "liggghts"), ("4.1", "lammps")):
        n_peer = int(by[(job, peer, "1 core")]["particles"])
        n_gp = int(by[(job, "granpack", "1 thread")]["particles"])
        assert abs(n_peer - n_gp) < 0.05 * n_gp, (job, n_peer, n_gp)
    table = (out / "vs_peers.md").read_text()
    assert "x (liggghts)" in table and "x (lammps)" in table
    m = json.loads((out / "manifest.json").read_text())
    assert m["quick"] is True
    assert m["seeds"]["granpack"] == 1
    assert "vs_peers.py --quick" in m["command"]
    assert m["cpu_model"] and m["date"].endswith("Z")
    assert set(m["peers"]) == {"lammps", "liggghts"}
