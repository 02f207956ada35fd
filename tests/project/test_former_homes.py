"""The former homes of the API's names still work until the next release, each with one
`DeprecationWarning` that names the new home.

Each case runs in a fresh interpreter: a module warns when it is first imported, and an
old attribute name when it is first read, so only a process that has not yet loaded them
shows the warning (and shows that a second use does not repeat it)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

# (what the old name is used like, twice; the check that it is the new name; new home)
CASES = {
    "granpack.export": (
        "import granpack.export\nfrom granpack.export import FORMATS, export, write_lammps",
        "import granpack.io, granpack.io.lammps\n"
        "assert export is granpack.io.export\n"
        "assert FORMATS is granpack.io.EXPORT_FORMATS\n"
        "assert write_lammps is granpack.io.lammps.write_lammps",
        "granpack.io",
    ),
    "granpack.particles": (
        "import granpack.particles\nfrom granpack.particles import FORMATS, read_particles",
        "import granpack.io\n"
        "assert read_particles is granpack.io.read_particles\n"
        "assert FORMATS is granpack.io.FORMATS",
        "granpack.io",
    ),
    "granpack.contact_files": (
        "import granpack.contact_files\nfrom granpack.contact_files import read_contacts",
        "import granpack.io\nassert read_contacts is granpack.io.read_contacts",
        "granpack.io",
    ),
    "granpack.mass2d": (
        "import granpack.mass2d\nfrom granpack.mass2d import OTHER, convention_table",
        "import granpack.paper.mass2d as new\n"
        "assert convention_table is new.convention_table\n"
        "assert OTHER == {'sphere': 'disc', 'disc': 'sphere'}",
        "granpack.paper.mass2d",
    ),
    "granpack.engine": (
        "import granpack.engine\nfrom granpack.engine import Material, Simulation",
        "import granpack\n"
        "assert Simulation is granpack.Simulation and Material is granpack.Material\n"
        "assert Simulation(dim=2).dim == 2",
        "granpack.simulation",
    ),
    "granpack.report.paper_report": (
        "import granpack.report\nold = granpack.report.paper_report\n"
        "from granpack.report import paper_report",
        "import granpack.paper.report\n"
        "assert old is paper_report is granpack.paper.report.paper_report",
        "granpack.paper.report.paper_report",
    ),
    "granpack.analysis.prepare.Prepared": (
        "import granpack.analysis.prepare as prepare\nold = prepare.Prepared\n"
        "from granpack.analysis.prepare import Prepared",
        "import granpack.analysis\nassert old is Prepared is granpack.analysis.System",
        "granpack.analysis.system.System",
    ),
}


def _script(use: str, check: str, new_home: str) -> str:
    return textwrap.dedent(
        """\
        import warnings
        import granpack, granpack.io, granpack.paper, granpack.analysis  # the new homes: quiet
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
        {use}
        {use}
        {check}
        kinds = [w.category for w in caught]
        assert kinds == [DeprecationWarning], [str(w.message) for w in caught]
        text = str(caught[0].message)
        assert {new_home!r} in text and "removed in the next release" in text, text
        """
    ).format(
        use=textwrap.indent(use, "    "),
        check=check,
        new_home=new_home,
    )


@pytest.mark.parametrize("old", sorted(CASES))
def test_a_former_home_still_works_and_warns_once(old):
    use, check, new_home = CASES[old]
    run = subprocess.run(
        [sys.executable, "-W", "error", "-c", _script(use, check, new_home)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr


def test_the_new_homes_import_without_a_warning():
    code = (
        "import granpack, granpack.io, granpack.io.lammps, granpack.paper.mass2d, "
        "granpack.paper.report, granpack.analysis.system, granpack.simulation, "
        "granpack.report, granpack.analysis.prepare, granpack.tiling"
    )
    run = subprocess.run(
        [sys.executable, "-W", "error", "-c", code], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, run.stderr
