"""No file of the repository (README, docs, package, benchmarks, examples) cites a path outside it: a user who clones
it can open everything it refers to. The paper itself is cited by its reference (Oliveri et al., PNAS 2021)."""

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CHECKED = ("README.md", "pyproject.toml", "docs", "morphbench", "benchmarks", "examples")
TEXT = (".md", ".py", ".toml", ".txt", ".cfg")
OUTSIDE = re.compile(r"shared/|robotic-matter|/work/|/home/|\b(?:the|our) spec(?:ification)?\b|\bspec(?:ification)?'s\b"
                     r"|\bspec section\b", re.IGNORECASE)
"""where the project's notes outside the repository lived, and the ways they were cited."""
RELATIVE = re.compile(r"(?:\.\./)+[\w./-]+")
LINK = re.compile(r"\]\(([^)\s]+)\)")
TOP_LEVEL = ("benchmarks", "examples")
"""where a suite or run file written as an example in a document would sit: its '../' paths start there."""


def repository_files() -> list[Path]:
    listed = subprocess.run(["git", "ls-files", *CHECKED], cwd=ROOT, capture_output=True, text=True, check=True)
    return [ROOT / name for name in listed.stdout.split() if name.endswith(TEXT)]


def outside(path: Path) -> bool:
    return not path.resolve().is_relative_to(ROOT)


def cited_outside(file: Path, text: str) -> list[str]:
    """Every citation in ``text`` (of ``file``) of a place outside the repository."""
    found = [match.group(0) for match in OUTSIDE.finditer(text)]
    for match in RELATIVE.finditer(text):
        target = match.group(0).rstrip(".,)")
        if outside(file.parent / target) and not any((ROOT / top / target).resolve().is_file()
                                                     for top in TOP_LEVEL):
            found.append(target)
    if file.suffix == ".md":
        for match in LINK.finditer(text):
            target = match.group(1).split("#")[0]
            if not target or re.match(r"[a-z]+:", target):
                continue  # a web address, a data URI or an anchor
            if outside(file.parent / target) or not (file.parent / target).exists():
                found.append(target)
    return found


def test_no_file_of_the_repository_cites_a_path_outside_it():
    files = repository_files()
    assert len(files) > 50 and ROOT / "docs" / "paper.md" in files
    cited = {str(f.relative_to(ROOT)): c for f in files if (c := cited_outside(f, f.read_text(encoding="utf-8")))}
    assert not cited


@pytest.mark.parametrize("text", [
    "see shared/spec/robotic-matter.md, section 3",
    "chain follows the quasi-static evolution (../shared/spec, section 3b)",
    "the spec's rule: 25% of trials",
    "as the spec suggests",
    "[notes](../notes.md)",
    "[gone](missing-file.md)",
    "read /work/shared/paper/oliveri-2021.txt",
])
def test_a_citation_outside_is_caught(text):
    assert cited_outside(ROOT / "docs" / "paper.md", text)


@pytest.mark.parametrize("text", [
    'shape = "../shapes/chain-3.toml"   # relative to this file',
    "[the results](results.md) and [the paper's account](paper.md#protocol)",
    "Oliveri et al., PNAS 2021, Fig. 2B; https://doi.org/10.1073/pnas.2017015118",
    "the learner spec as given by --learner",
])
def test_a_citation_inside_passes(text):
    assert not cited_outside(ROOT / "docs" / "paper.md", text)
