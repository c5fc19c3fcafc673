"""What the documents say the defaults are is what the code has (params.py): a changed default fails here until the
pages that state it are changed with it.

Three kinds of statement are read: the rows of a table with a ``field`` and a ``default`` column (docs/learners.md's
learner fields); a field named in backquotes with its value, `` `cycles_per_step` = 2 ``, on a line that speaks of a
default or in a table whose header has a ``default`` column; and the sentences listed in ``SENTENCES`` (a run's
simulated time, a learning step's cycles), each computed from the defaults."""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path

import pytest

import morphbench.params as P

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted([ROOT / "README.md", *(ROOT / "docs").glob("*.md")])


def parameter_defaults() -> dict[str, list[tuple[str, object]]]:
    """Every parameter field of params.py by name: the (class, default) of each dataclass that has it."""
    found: dict[str, list[tuple[str, object]]] = {}
    for name, owner in vars(P).items():
        if isinstance(owner, type) and dataclasses.is_dataclass(owner) and owner.__module__ == P.__name__:
            for f in dataclasses.fields(owner):
                if "rule" in f.metadata:
                    found.setdefault(f.name, []).append((name, f.default))
    return found


DEFAULTS = parameter_defaults()
UNIQUE = {name: owners[0][1] for name, owners in DEFAULTS.items() if len(owners) == 1}
"""the fields whose name alone says which default it is (``friction`` is a unit's and a dummy's: not here)."""


def same(stated: str, default: object) -> bool:
    """Whether the text ``stated`` is the value ``default`` (numbers compared as numbers)."""
    stated = stated.strip().strip("`").strip('"')
    if isinstance(default, bool) or not isinstance(default, (int, float)):
        return stated == str(default)
    try:
        return math.isclose(float(stated), float(default), rel_tol=1e-9)
    except ValueError:
        return False


def tables(text: str) -> list[tuple[list[str], list[list[str]], int]]:
    """The Markdown tables of ``text``: header cells, rows of cells, and the line number of each table's header."""
    found, lines = [], text.splitlines()
    i = 0
    while i < len(lines) - 1:
        if lines[i].startswith("|") and re.match(r"^\|[\s:|-]+\|$", lines[i + 1].strip()):
            header = [cell.strip() for cell in lines[i].strip().strip("|").split("|")]
            rows, j = [], i + 2
            while j < len(lines) and lines[j].startswith("|"):
                rows.append([cell.strip() for cell in lines[j].strip().strip("|").split("|")])
                j += 1
            found.append((header, rows, i + 1))
            i = j
        else:
            i += 1
    return found


def field_table_mismatches(text: str) -> list[str]:
    """Rows of ``field | ... | default`` tables whose stated default is not the code's (fields named in backquotes,
    several in one row with as many defaults separated by commas)."""
    wrong = []
    for header, rows, line in tables(text):
        if "field" not in header or "default" not in header:
            continue
        for row in rows:
            names = re.findall(r"`(\w+)`", row[header.index("field")])
            values = [v.strip() for v in row[header.index("default")].split(",")]
            for name, value in zip(names, values if len(values) == len(names) else [values[0]] * len(names)):
                owners = DEFAULTS.get(name)
                if owners is None:
                    wrong.append(f"line {line}: `{name}` is no parameter field")
                elif not any(same(value, default) for _, default in owners):
                    wrong.append(f"line {line}: `{name}` stated {value!r}, the code's default is "
                                 f"{' or '.join(repr(d) for _, d in owners)}")
    return wrong


ASSIGNED = re.compile(r"`(\w+)` = (-?[\d.]+(?:e-?\d+)?)")


def assignment_mismatches(text: str) -> list[str]:
    """`` `field` = value `` in a table's default column, or on a line outside tables that speaks of a default, for
    a field whose name is unique among the parameters, where the value is not the code's default."""
    places = [(line, row[header.index("default")]) for header, rows, line in tables(text) if "default" in header
              for row in rows if len(row) == len(header)]
    places += [(number, line) for number, line in enumerate(text.splitlines(), start=1)
               if not line.startswith("|") and "default" in line.lower()]
    return [f"line {number}: `{name}` = {value}, the code's default is {UNIQUE[name]!r}"
            for number, where in places for name, value in ASSIGNED.findall(where)
            if name in UNIQUE and not same(value, UNIQUE[name])]


LEARNER, ACTUATOR = P.LearnerParams(), P.ActuatorParams()
STEP_S = (LEARNER.discard_cycles + LEARNER.cycles_per_step) * ACTUATOR.cycle_time
"""a learning step's simulated seconds at the defaults."""


def simulated_s(steps: int) -> float:
    """What ``morphbench run --steps N`` simulates at the defaults: the warm-up, then steps 0 to N."""
    return LEARNER.warmup_cycles * ACTUATOR.cycle_time + (steps + 1) * STEP_S


NUMBER = {"no": 0, "none": 0, "one": 1, "two": 2, "three": 3, "four": 4}


def count(text: str) -> int:
    return NUMBER[text.lower()] if text.lower() in NUMBER else int(text)


SENTENCES = [
    (r"(\d+) learning steps \((?:about )?([\d.]+) simulated minutes\)",
     lambda steps, minutes: math.isclose(float(minutes), simulated_s(int(steps)) / 60, abs_tol=0.05),
     "N learning steps (M simulated minutes): the warm-up and steps 0 to N at the default step"),
    (r"(\d+) learning steps, ([\d.]+) simulated minutes",
     lambda steps, minutes: math.isclose(float(minutes), simulated_s(int(steps)) / 60, abs_tol=0.05),
     "N learning steps, M simulated minutes"),
    (r"(\w+) pump cycles? measured from the phase change(?: on)?, (\w+) discarded",
     lambda measured, discarded: (count(measured), count(discarded)) == (LEARNER.cycles_per_step,
                                                                          LEARNER.discard_cycles),
     "a learning step's measured and discarded cycles"),
    (r"learning step (?:lasts|tries a new phase for) (\w+) pump cycles \((\d+) s\)",
     lambda cycles, seconds: count(cycles) == LEARNER.discard_cycles + LEARNER.cycles_per_step
     and math.isclose(float(seconds), STEP_S),
     "a learning step's pump cycles and seconds"),
    (r"the default ([\d.]+) s per (?:learning )?step",
     lambda seconds: math.isclose(float(seconds), STEP_S),
     "the default seconds per learning step"),
    (r"(\d+) discarded and (\d+) measured pump cycles",
     lambda discarded, measured: (int(discarded), int(measured)) == (LEARNER.discard_cycles,
                                                                     LEARNER.cycles_per_step),
     "discarded and measured cycles"),
]
"""Sentences that state a consequence of the defaults: (pattern, whether its groups agree with the code, what)."""


def sentence_mismatches(text: str) -> list[str]:
    wrong = []
    flat = re.sub(r"\s+", " ", text)
    for pattern, agrees, what in SENTENCES:
        for match in re.finditer(pattern, flat):
            if not agrees(*match.groups()):
                wrong.append(f"{match.group(0)!r}: not what the defaults give ({what})")
    return wrong


VIDEO = re.compile(r"an? ([\d.]+)-second video of its ([\d.]+) simulated minutes[^`]*?```bash\n([^`]*)```")


def video_mismatches(text: str) -> list[str]:
    """"a 12-second video of its 4.1 simulated minutes" and the command below it: its ``--steps`` at the defaults,
    and those seconds played ``--video-speed`` times faster."""
    wrong = []
    for match in VIDEO.finditer(text):
        seconds, minutes, command = float(match.group(1)), float(match.group(2)), match.group(3)
        steps = int(re.search(r"--steps (\d+)", command).group(1))
        speed = float(re.search(r"--video-speed ([\d.]+)", command).group(1))
        if not (math.isclose(minutes, simulated_s(steps) / 60, abs_tol=0.05)
                and math.isclose(seconds, simulated_s(steps) / speed, abs_tol=0.5)):
            wrong.append(f"{match.group(0).splitlines()[0]!r}: {steps} steps are {simulated_s(steps) / 60:.1f} "
                         f"simulated minutes, {simulated_s(steps) / speed:.1f} s of video at speed {speed:g}")
    return wrong


def notebook_text(path: Path) -> str:
    """The Markdown and code cells of a notebook as one text."""
    return "\n\n".join("".join(cell["source"]) for cell in json.loads(path.read_text("utf-8"))["cells"])


def mismatches(text: str) -> list[str]:
    return field_table_mismatches(text) + assignment_mismatches(text) + sentence_mismatches(text) + \
        video_mismatches(re.sub(r"[ \t]*\n(?!```|morphbench)", " ", text))


@pytest.mark.parametrize("page", PAGES + [ROOT / "docs" / "tutorial.ipynb"], ids=lambda p: p.name)
def test_every_default_a_page_states_is_the_code_s(page):
    text = notebook_text(page) if page.suffix == ".ipynb" else page.read_text("utf-8")
    assert not mismatches(text), f"{page.relative_to(ROOT)} states defaults the code does not have:\n" + \
        "\n".join(mismatches(text))


def test_the_pages_state_the_defaults_this_test_reads():
    """The statements are there to be checked: the learner table, the learning step's cycles in calibration.md and
    the README's run length (a page rewritten so that nothing matches would pass unchecked)."""
    learners = (ROOT / "docs" / "learners.md").read_text("utf-8")
    assert any("field" in h and "default" in h for h, _, _ in tables(learners))
    readme = re.sub(r"\s+", " ", (ROOT / "README.md").read_text("utf-8"))
    assert re.search(SENTENCES[0][0], readme)
    assert VIDEO.search(re.sub(r"[ \t]*\n(?!```|morphbench)", " ", (ROOT / "README.md").read_text("utf-8")))
    calibration = (ROOT / "docs" / "calibration.md").read_text("utf-8")
    assert ASSIGNED.search(calibration) and "`cycles_per_step` = " in calibration


def test_the_check_finds_a_wrong_default():
    step = LEARNER.cycles_per_step
    assert mismatches("| field | unit | default |\n|---|---|---|\n| `adapt_window` | steps | 11 |")
    assert not mismatches(f"| field | unit | default |\n|---|---|---|\n| `adapt_window` | steps | "
                          f"{LEARNER.adapt_window} |")
    assert mismatches(f"By default a step measures `cycles_per_step` = {step + 1} cycles.")
    assert not mismatches(f"By default a step measures `cycles_per_step` = {step} cycles.")
    assert mismatches("for 100 learning steps (10 simulated minutes) in a few seconds")
    assert not mismatches(f"for 100 learning steps ({simulated_s(100) / 60:.1f} simulated minutes)")
    assert mismatches("a learning step: 1 discarded and 2 measured pump cycles, the default")
    assert mismatches("a learning step tries a new phase for 3 pump cycles (6 s)")
    assert mismatches("with an 18-second video of its 6 simulated minutes:\n\n```bash\nmorphbench run grid-3x3 "
                      "--steps 60 --video grid-3x3.mp4 --video-speed 20\n```")
    assert not mismatches(f"with a {simulated_s(60) / 20:.0f}-second video of its {simulated_s(60) / 60:.1f} "
                          f"simulated minutes:\n\n```bash\nmorphbench run grid-3x3 --steps 60 --video-speed 20\n```")


def test_the_leaderboard_page_counts_the_runs_a_learner_needs():
    """docs/leaderboard.md's count of the runs one plug-in learner runs is the standard set's."""
    from morphbench.bench.leaderboard import learner_suite, standard_suite

    page = re.sub(r"\s+", " ", (ROOT / "docs" / "leaderboard.md").read_text("utf-8"))
    stated = re.search(r"into `results/leaderboard/` \(([\d,]+) runs", page)
    assert stated and int(stated.group(1).replace(",", "")) == len(learner_suite(standard_suite(), ["thermal"]).runs)
