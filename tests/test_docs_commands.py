"""The README and docs/ as a reader meets them: every `morphbench` command line they show parses as printed (the
command's own parser takes it, options spelt out in full, files it names exist), the tutorial's too, and the README
rendered as HTML shows the pictures docs/make_media.py makes."""

from __future__ import annotations

import contextlib
import importlib.util
import io
import json
import re
import shlex
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from markdown_it import MarkdownIt
from PIL import Image, ImageSequence

from morphbench.cli import _parser, main
from morphbench.errors import ConfigError
from morphbench.shapes.loader import resolve_shape_path

from conftest import ROOT

PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), ROOT / "docs" / "tutorial.ipynb"]
SPAN = re.compile(r"`(morphbench [^`]+)`")
ENV = re.compile(r"^(?:\w+=\S*\s+)+")
OPTION = re.compile(r"--[a-z][a-z-]*")
MAX_BYTES = {".gif": 1_500_000, ".png": 200_000}
"""what a front-page picture may weigh: the README opens quickly."""


def command_lines(path: Path) -> list[tuple[str, str, bool]]:
    """(where, command, whole) for every ``morphbench ...`` command of ``path``: the lines of its code blocks (each
    part of a line joined by ``&&``, environment assignments before it dropped; whole command lines) and its inline
    code spans (commands named in prose). Of a notebook, its Markdown cells, one after the other."""
    text = path.read_text(encoding="utf-8")
    if path.suffix == ".ipynb":
        text = "\n".join("".join(c["source"]) for c in json.loads(text)["cells"] if c["cell_type"] == "markdown")
    found, fenced = [], False
    for number, line in enumerate(text.splitlines(), 1):
        where = f"{path.relative_to(ROOT)}:{number}"
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        if fenced:
            found += [(where, part, True) for part in (ENV.sub("", p.strip()) for p in line.split("&&"))
                      if part.startswith("morphbench ")]
        else:
            found += [(where, span, False) for span in SPAN.findall(line)]
    return found


DOCUMENTED = [c for page in PAGES for c in command_lines(page)]


def subcommands(parser) -> dict:
    """name -> parser of ``parser``'s sub-commands (argparse keeps them in its sub-parsers action)."""
    return next((a.choices for a in parser._actions if a.choices and hasattr(a, "add_parser")), {})


def options(parser) -> dict[str, object]:
    """every option string of ``parser`` and of its sub-commands, to its action."""
    found = {s: action for action in parser._actions for s in action.option_strings}
    for sub in subcommands(parser).values():
        found.update(options(sub))
    return found


def problems(command: str, whole: bool = True) -> list[str]:
    """What is wrong with a documented ``morphbench ...`` command: nothing if it parses as printed (``whole``: a
    command line, which must have every argument its command requires; else a command named in prose, such as
    `morphbench run`, which may leave them out).

    A synopsis (``[--steps N]``, ``thermal|flaky``, ``...``) is checked for its options only: each must be one the
    command has, and alternatives listed for an option with choices must be among them. A command as a reader types
    it must parse (argparse, without running it), spell its options out in full (no abbreviation argparse would
    accept) and name files and shapes that exist in the checkout."""
    tokens = shlex.split(command, comments=True)
    parser = _parser()
    name = tokens[1] if len(tokens) > 1 else ""
    sub = subcommands(parser).get(name)
    known = options(sub) if sub else {}
    known.update({s: a for a in parser._actions for s in a.option_strings})
    found = []
    for i, token in enumerate(tokens):
        for option in OPTION.findall(token.split("=")[0]) if token.lstrip("[").startswith("--") else ():
            if option not in known:
                found.append(f"no option {option} in morphbench {name}")
            elif i + 1 < len(tokens) and known[option].choices and "|" in tokens[i + 1]:
                listed = tokens[i + 1].strip("[]").split("|")
                found += [f"{option} has no choice {c!r}" for c in listed if c not in known[option].choices]
    if any(c in token for token in tokens for c in "[|") or any(t.endswith("...") for t in tokens):
        return found + ([] if sub else [f"no command {name!r}"])
    stderr = io.StringIO()
    with contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(io.StringIO()):
        try:
            args = parser.parse_args(tokens[1:])
        except SystemExit as exc:
            message = stderr.getvalue().strip() or f"exit {exc.code}"
            partial = not whole and "the following arguments are required" in message
            return found + [message] if exc.code and not partial else found
    for token in tokens[2:]:  # a file of the checkout's directories (not one a page writes first, nor FILE.toml)
        if (token.endswith(".toml") and (ROOT / token).parent.is_dir() and not Path(token).name[0].isupper()
                and not (ROOT / token).is_file()):
            found.append(f"no file {token}")
    shape = getattr(args, "config", None) or getattr(args, "shape", None)
    if name in ("run", "scan") and shape and not shape.isupper():
        try:
            with contextlib.chdir(ROOT):
                resolve_shape_path(shape)
        except ConfigError as exc:
            found.append(str(exc))
    return found


def test_the_pages_show_commands():
    assert len(DOCUMENTED) > 40
    commands = {c for _, c, whole in DOCUMENTED if whole}
    readme = ROOT.joinpath("README.md").read_text(encoding="utf-8")
    assert "morphbench run shapes/chain-2.toml --learner thermal --steps 100" in commands  # the first line's job
    assert sum(where.startswith("README.md") for where, _, whole in DOCUMENTED if whole) >= 6
    assert "python docs/make_media.py" in readme


@pytest.mark.parametrize("where, command, whole", DOCUMENTED, ids=[w for w, _, _ in DOCUMENTED])
def test_every_documented_command_parses(where, command, whole):
    assert problems(command, whole) == []


@pytest.mark.parametrize("command, expected", [
    ("morphbench run chain-3 --stpes 5", "unrecognized arguments: --stpes"),
    ("morphbench run chain-3 --lear flaky", "no option --lear"),  # an abbreviation argparse takes
    ("morphbench run chain-3 --sensor sonar", "invalid choice: 'sonar'"),
    ("morphbench run chain-3 --steps -1", "--steps"),
    ("morphbench rnu chain-3", "invalid choice: 'rnu'"),
    ("morphbench run chain-99 --steps 5", "chain-99"),
    ("morphbench bench benchmarks/nosuch.toml --out results/x", "no file benchmarks/nosuch.toml"),
    ("morphbench run FILE [--sensr optical|ideal]", "no option --sensr"),
    ("morphbench run FILE [--sensor optical|sonar]", "--sensor has no choice 'sonar'"),
    ("morphbench scan SHAPE [--steps N]", "no option --steps in morphbench scan"),
])
def test_a_wrong_command_is_caught(command, expected):
    found = problems(command)
    assert found and expected in " ".join(found)
    assert problems(command, whole=False)  # named in prose, as wrong


def test_a_command_line_must_be_whole():
    assert "the following arguments are required: --out" in " ".join(problems("morphbench bench SUITE"))
    assert problems("morphbench bench SUITE", whole=False) == []


@pytest.mark.parametrize("command", [
    "morphbench run chain-3 --steps 5 --sensor ideal",
    "morphbench run FILE|NAME [--sensor optical|camera|ideal] [--steps N]",
    "morphbench shapes show FILE --png OUT.png",
    "morphbench render RUN_DIR --out OUT.gif --video-steps 280:320",
])
def test_a_right_command_passes(command):
    assert problems(command) == []


class _Images(HTMLParser):
    def __init__(self):
        super().__init__()
        self.sources: list[str] = []

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.sources.append(dict(attrs)["src"])


def readme_html() -> str:
    return MarkdownIt("commonmark").enable("table").render(ROOT.joinpath("README.md").read_text(encoding="utf-8"))


def readme_images() -> list[str]:
    images = _Images()
    images.feed(readme_html())
    return images.sources


def make_media():
    """docs/make_media.py, the command the README documents, as a module."""
    spec = importlib.util.spec_from_file_location("make_media", ROOT / "docs" / "make_media.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_readme_shows_the_pictures_make_media_makes():
    sources = readme_images()
    media = make_media()
    assert sources == [f"docs/media/{media.GIF}", f"docs/media/{media.CURVE}"]
    for source in sources:
        path = ROOT / source
        assert path.stat().st_size < MAX_BYTES[path.suffix]
        with Image.open(path) as image:
            assert image.format == path.suffix[1:].upper()
            assert image.format == "PNG" or image.n_frames > 30  # an animation of a few seconds


def test_make_media_writes_those_pictures(tmp_path):
    media = make_media()
    written = media.make_media(tmp_path, steps=2)
    assert [p.name for p in written] == [media.GIF, media.CURVE]
    for path in written:
        with Image.open(path) as image, Image.open(media.MEDIA / path.name) as shipped:
            assert image.format == shipped.format and image.size == shipped.size
            if image.format == "GIF":
                assert 1 < image.n_frames < shipped.n_frames  # 3 learning steps of the 30 shown


BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


@pytest.mark.skipif(not any(shutil.which(b) for b in BROWSERS), reason="no headless Chromium on this machine")
def test_a_browser_shows_the_readmes_animation(tmp_path):
    """The README rendered as HTML, screenshotted by headless Chromium at one device pixel per CSS pixel: a frame of
    the animation (whichever it has reached) is on the screen, pixel for pixel."""
    page = tmp_path / "README.html"
    page.write_text(f'<!doctype html><html><head><meta charset="utf-8"><base href="{ROOT.as_uri()}/"></head>'
                    f'<body style="margin:8px">{readme_html()}</body></html>', encoding="utf-8")
    shot = tmp_path / "shot.png"
    browser = next(shutil.which(b) for b in BROWSERS if shutil.which(b))
    subprocess.run([browser, "--headless", "--disable-gpu", "--no-sandbox", "--hide-scrollbars",
                    "--force-device-scale-factor=1", "--allow-file-access-from-files", "--window-size=1200,2400",
                    f"--screenshot={shot}", page.as_uri()], check=True, capture_output=True, timeout=120)
    with Image.open(shot) as image:
        screen = np.asarray(image.convert("RGB"), dtype=np.int16)
    with Image.open(ROOT / readme_images()[0]) as gif:
        frames = [np.asarray(frame.convert("RGB"), dtype=np.int16) for frame in ImageSequence.Iterator(gif)]
    assert any(_find(screen, frame) for frame in frames), "the animation is not on the screenshot"


def _find(screen: np.ndarray, picture: np.ndarray, tolerance: int = 8) -> bool:
    """Whether ``picture`` appears in ``screen`` unscaled (each channel within ``tolerance``: colour management)."""
    height, width = picture.shape[:2]
    for y in range(screen.shape[0] - height + 1):
        starts = np.abs(screen[y, : screen.shape[1] - width + 1] - picture[0, 0]).max(axis=1) <= tolerance
        for x in np.flatnonzero(starts):
            if np.abs(screen[y:y + height, x:x + width] - picture).max() <= tolerance:
                return True
    return False


def test_find_locates_a_picture_on_a_screen():
    rng = np.random.default_rng(0)
    screen = rng.integers(0, 256, size=(120, 200, 3)).astype(np.int16)
    picture = screen[30:70, 50:130].copy()
    assert _find(screen, picture)
    picture[20, 40] += 100  # one pixel off: another picture
    assert not _find(screen, picture)


def test_the_documented_learner_runs(tmp_path, monkeypatch, capsys):
    """The README's fourth thing to try: docs/learners.md's Greedy saved as my_learners.py, run as printed there."""
    page = (ROOT / "docs" / "learners.md").read_text(encoding="utf-8")
    (tmp_path / "my_learners.py").write_text(re.search(r"```python\n(.*?)```", page, re.S).group(1))
    command = "morphbench run chain-3 --learner my_learners:Greedy"
    assert f"PYTHONPATH=. {command}" in page and f"PYTHONPATH=. {command}" in (ROOT / "README.md").read_text()
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))  # PYTHONPATH=.
    assert main([*shlex.split(command)[1:], "--steps", "3", "--quiet", "--out", "out"]) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["config"]["learner"] == "my_learners:Greedy"
    assert len(pd.read_parquet(tmp_path / "out" / "steps.parquet")) == 4  # step 0 and 3 learning steps
