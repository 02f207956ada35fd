"""Every study can be read and rerun: each folder of studies/ has an entry page with the
question, the command that reruns it from a clean clone, the result, the date and the
commit, and at least one script; patches of experiments are not kept in the tree (the
commit that holds each is cited in studies/HISTORY.md)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

STUDIES = Path(__file__).resolve().parents[2] / "studies"

#: The headings every study's README.md carries, as level-2 Markdown headings.
SECTIONS = ("Question", "Command", "Result", "Date", "Commit")
#: Folders of studies/ that are not studies: the helpers the scripts share.
NOT_STUDIES = {"_common", "__pycache__"}


def study_folders(root: Path = STUDIES) -> list[Path]:
    """The study folders: the top-level folders of `root`, less the shared helpers."""
    return sorted(p for p in root.iterdir() if p.is_dir() and p.name not in NOT_STUDIES)


def layout_faults(folder: Path) -> list[str]:
    """What a study folder lacks: its README.md, any of its sections, a script."""
    faults = []
    readme = folder / "README.md"
    if not readme.is_file():
        faults.append("no README.md")
    else:
        headings = set(re.findall(r"^## +(.+?)\s*$", readme.read_text(), flags=re.MULTILINE))
        faults += [f"no '## {s}' section" for s in SECTIONS if s not in headings]
    scripts = [p for p in folder.rglob("*") if p.is_file() and p.suffix in (".py", ".sh")]
    if not scripts:
        faults.append("no script (*.py or *.sh)")
    return faults


def test_there_are_studies():
    # the layout checks below must see the folders they check
    assert len(study_folders()) >= 20


@pytest.mark.parametrize("folder", study_folders(), ids=lambda p: p.name)
def test_every_study_has_an_entry_page_and_a_script(folder):
    faults = layout_faults(folder)
    assert not faults, f"studies/{folder.name}: {', '.join(faults)}"


def test_no_patch_is_kept_under_studies():
    patches = sorted(p.relative_to(STUDIES).as_posix() for p in STUDIES.rglob("*.patch"))
    assert not patches, f"cite the commit in studies/HISTORY.md and remove: {patches}"


def test_the_layout_check_sees_each_fault(tmp_path):
    good = tmp_path / "good"
    good.mkdir()
    (good / "run.sh").write_text("#!/usr/bin/env bash\n")
    (good / "README.md").write_text(
        "# A study\n\n" + "".join(f"## {s}\n\ntext\n\n" for s in SECTIONS)
    )
    assert layout_faults(good) == []

    no_readme = tmp_path / "no_readme"
    no_readme.mkdir()
    (no_readme / "study.py").write_text("")
    assert layout_faults(no_readme) == ["no README.md"]

    # a section only as a level-3 heading, or only named in the text, is not a section
    partial = tmp_path / "partial"
    partial.mkdir()
    (partial / "study.py").write_text("")
    (partial / "README.md").write_text(
        "# A study\n\n## Question\n\n## Command\n\n### Result\n\nThe Date and the Commit.\n"
    )
    assert layout_faults(partial) == [
        "no '## Result' section",
        "no '## Date' section",
        "no '## Commit' section",
    ]

    no_script = tmp_path / "no_script"
    no_script.mkdir()
    (no_script / "README.md").write_text((good / "README.md").read_text())
    (no_script / "results.md").write_text("")
    assert layout_faults(no_script) == ["no script (*.py or *.sh)"]

    (tmp_path / "_common").mkdir()
    assert [p.name for p in study_folders(tmp_path)] == [
        "good",
        "no_readme",
        "no_script",
        "partial",
    ]
