"""report.html: one self-contained page (figures, video, CSS inline; no request), its contents per experiment, the
suite file and versions, a video per experiment that a real browser plays (when one is installed), and a report
that survives a replay that fails. No test here times anything: what made the report quick is asserted as what
happened (the videos render in a process of their own while report.md is written; reused videos are not rendered
again)."""

from __future__ import annotations

import base64
import html
import json
import math
import os
import re
import shutil
import subprocess
from concurrent.futures import Future

import av
import numpy as np
import pandas as pd
import pytest
from PIL import Image

import morphbench.render
from morphbench.bench import build_report
from morphbench.bench import html as page_module
from morphbench.bench import report as report_module
from morphbench.bench.provenance import read_sessions, software_versions
from morphbench.bench.videos import Video, pick_runs, steps_to_show, video_problem
from morphbench.render.writers import H264Writer

from conftest import ROOT, run_cli

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


RENDERS = "renders.jsonl"
"""beside a results directory: a line per ``_videos`` call of a report's video process (its pid, the videos it
rendered)."""
VIDEOS = page_module._videos
"""what start_videos submits to its pool, unpatched."""


def _videos_recorded(root, plan):
    """``html._videos`` (what ``start_videos`` submits) as it runs in the video process, which writes down its pid and
    the videos it renders (``render_run`` calls) in ``root/../renders.jsonl``. A spawned process imports this module
    again: the test's monkeypatches are not there, this function is."""
    rendered = []
    real = morphbench.render.render_run

    def counted(run_dir, out, params):
        rendered.append(os.path.relpath(out, root))
        return real(run_dir, out, params)

    morphbench.render.render_run = counted
    try:
        return VIDEOS(root, plan)
    finally:
        morphbench.render.render_run = real
        with open(os.path.join(os.path.dirname(root), RENDERS), "a") as record:
            record.write(json.dumps({"pid": os.getpid(), "rendered": rendered}) + "\n")


def build_recorded(out, monkeypatch) -> dict:
    """``build_report(out, videos=True)``, and what happened: ``calls`` (start_videos and write_html, in order, with
    whether report.md was there and the videos write_html was given), ``here`` (videos rendered in this process) and
    ``process`` (the video process's line of renders.jsonl)."""
    calls, here = [], []
    record = out.parent / RENDERS
    record.unlink(missing_ok=True)

    def start_videos(root):
        written = (out / "report.md").exists()
        future = real_start(root)
        calls.append(("start_videos", written, future))
        return future

    def write_html(root, videos=True):
        calls.append(("write_html", (out / "report.md").exists(), videos))
        return real_write(root, videos=videos)

    real_start, real_write = report_module.start_videos, report_module.write_html
    monkeypatch.setattr(report_module, "start_videos", start_videos)
    monkeypatch.setattr(report_module, "write_html", write_html)
    monkeypatch.setattr(page_module, "_videos", _videos_recorded)  # what start_videos submits to its pool
    real_render = morphbench.render.render_run
    monkeypatch.setattr(morphbench.render, "render_run", lambda *args: here.append(args) or real_render(*args))
    build_report(out, videos=True)
    lines = record.read_text().splitlines() if record.exists() else []
    assert len(lines) == 1, lines  # one video process, which ran _videos once
    return {"calls": calls, "here": here, "process": json.loads(lines[0])}


@pytest.fixture(scope="module")
def page(reference, tmp_path_factory):
    """A copy of the tiny suite's results with its report built with videos: (results dir, report.html text, what
    happened: ``build_recorded``)."""
    out = tmp_path_factory.mktemp("html") / "results"
    shutil.copytree(reference[1], out, ignore=shutil.ignore_patterns("videos", "report.md", "report.html"))
    with pytest.MonkeyPatch.context() as monkeypatch:
        happened = build_recorded(out, monkeypatch)
    return out, (out / "report.html").read_text(encoding="utf-8"), happened


def test_the_page_is_self_contained(page):
    out, text, _ = page
    sources = re.findall(r'\ssrc="([^"]*)"', text)
    assert len(sources) >= 4  # the figures and the video
    assert all(s.startswith(("data:image/png;base64,", "data:video/mp4;base64,")) for s in sources)
    assert all(href.startswith("#") for href in re.findall(r'\shref="([^"]*)"', text))
    assert "<link" not in text and "url(" not in text and "@import" not in text and "<iframe" not in text
    assert re.search(r"<script[^>]*\ssrc=", text) is None
    # every figure of report.md, each the very file
    for name in re.findall(r"\]\(figures/([^)]+)\)", (out / "report.md").read_text()):
        data = base64.b64encode((out / "figures" / name).read_bytes()).decode()
        assert f'src="data:image/png;base64,{data}"' in text
    # every link of the contents lands on an anchor of the page
    ids = set(re.findall(r'\sid="([^"]+)"', text))
    assert set(re.findall(r'href="#([^"]+)"', text)) <= ids


def test_tables_and_contents_per_experiment(reference, page):
    out, text, _ = page
    plan = json.loads((out / "plan.json").read_text())
    nav = text[text.index('<nav id="contents">'):text.index("</nav>")]
    for experiment in plan["experiments"]:
        name = experiment["name"]
        assert f'<li class="experiment"><a href="#{name}">{name}</a><ul><li><a href="#{name}-video">video</a>' in nav
        assert f'<h2 id="{name}">{name}</h2>' in text
    assert '<a href="#suite-file">Suite file</a>' in nav and '<a href="#versions">Versions</a>' in nav
    assert "<table>" in text and "<th>final Ubar</th>" in text and "<td>thermal</td>" in text  # tables render
    markdown_tables = len(re.findall(r"^\|(?:---\|)+$", (out / "report.md").read_text(), re.M))
    assert markdown_tables >= 2 and text.count("<table>") == markdown_tables + 2  # and the versions' two tables


def test_the_suite_file_verbatim_and_the_versions(reference, page):
    out, text, _ = page
    suite = re.search(r'<h2 id="suite-file">.*?<pre><code>(.*?)</code></pre>', text, re.S)
    assert html.unescape(suite.group(1)) == (out / "suite.toml").read_text() == reference[0].read_text()
    versions = text[text.index('<h2 id="versions">'):]
    for name in ("morphbench", "Python", "numpy", "pybullet", "opencv-python", "pandas", "av", "markdown-it-py"):
        assert f"<td>{name}" in versions
    # what the bench recorded: one entry, the jobs it ran and the versions it ran with
    sessions = read_sessions(out)
    assert len(sessions) == 1 and sessions[0]["jobs"] == reference[2].done > 0
    assert sessions[0]["versions"]["numpy"] == software_versions()["numpy"]
    assert "environment.json" in versions and f"numpy {sessions[0]['versions']['numpy']}" in versions


def test_one_h264_video_per_experiment_in_the_page_and_in_videos(page):
    out, text, _ = page
    plan = json.loads((out / "plan.json").read_text())
    runs = pd.read_parquet(out / "runs.parquet")
    chosen = pick_runs(plan, lambda run_id: bool((runs.run_id == run_id).any()) and
                       runs.status[runs.run_id == run_id].item() == "done")
    assert pick_runs(plan, lambda run_id: False) == {e["name"]: None for e in plan["experiments"]}
    second = plan["experiments"][0]["run_ids"][1]
    assert pick_runs(plan, lambda run_id: run_id == second)[plan["experiments"][0]["name"]]["id"] == second
    first = plan["experiments"][0]
    assert chosen[first["name"]]["id"] == first["run_ids"][0]  # first seed of the first condition: all finished
    for experiment in plan["experiments"]:
        video = out / "videos" / f"{experiment['name']}.mp4"
        with av.open(str(video)) as container:
            stream = container.streams.video[0]
            assert stream.codec_context.name == "h264" and stream.codec_context.pix_fmt == "yuv420p"
            assert (stream.codec_context.width, stream.codec_context.height) == (480, 270)
            duration = float(stream.duration * stream.time_base)
        run_id = chosen[experiment["name"]]["id"]  # its rows: in the consolidated table (docs/results.md)
        steps = pd.read_parquet(out / "steps.parquet")
        steps = steps[steps.run_id == run_id].reset_index(drop=True)
        (first_step, last), simulated = steps_to_show(steps)
        assert 8 <= simulated <= 20 and duration == pytest.approx(simulated, abs=0.2)  # speed 1: real time
        assert f'src="data:video/mp4;base64,{base64.b64encode(video.read_bytes()).decode()}"' in text
        assert f"learning steps {first_step} to {last}" in text


def test_the_videos_render_in_a_process_of_their_own_while_report_md_is_written(page):
    """What keeps the report quick: build_report starts the videos (start_videos: a pool of one spawned process)
    before it writes report.md, and write_html takes them from that process; none is rendered in this one."""
    out, text, happened = page
    (start, md_before, future), (write, md_after, videos) = happened["calls"]
    assert (start, write) == ("start_videos", "write_html")
    assert not md_before and md_after  # started before report.md was written, taken after
    assert isinstance(future, Future) and videos is future and future.done()
    plan = json.loads((out / "plan.json").read_text())
    assert happened["process"]["pid"] != os.getpid()
    assert happened["process"]["rendered"] == [f"videos/{e['name']}.mp4" for e in plan["experiments"]]
    assert happened["here"] == []  # nothing rendered in the report's own process
    assert f"Videos: {len(plan['experiments'])} rendered in " in text


def test_videos_are_reused_and_can_be_left_out(page, capsys, monkeypatch):
    out, _, _ = page
    before = {p.name: p.stat().st_mtime_ns for p in (out / "videos").iterdir()}
    assert sorted(before) == ["pair.json", "pair.mp4"]
    happened = build_recorded(out, monkeypatch)
    assert happened["process"]["rendered"] == [] and happened["here"] == []  # no video rendered again
    assert happened["process"]["pid"] != os.getpid()
    assert {p.name: p.stat().st_mtime_ns for p in (out / "videos").iterdir()} == before  # nor written again
    assert "Videos: 1 reused." in (out / "report.html").read_text()

    code, stdout, _ = run_cli(capsys, "report", str(out), "--no-videos")
    assert code == 0 and "report.html" in stdout
    text = (out / "report.html").read_text()
    assert "<video" not in text and "Videos were not rendered (<code>--no-videos</code>)" in text
    assert 'href="#pair"' in text


def test_a_cached_video_that_does_not_decode_is_rendered_again(page, tmp_path):
    """Its record still says it shows the same run: reused, it would be embedded as it is."""
    out = tmp_path / "results"
    shutil.copytree(page[0], out)
    (out / "videos" / "pair.mp4").write_text("not a video\n")
    build_report(out, videos=True)
    video = (out / "videos" / "pair.mp4").read_bytes()
    assert video_problem(out / "videos" / "pair.mp4") is None
    text = (out / "report.html").read_text()
    assert "Videos: 1 rendered" in text and f'src="data:video/mp4;base64,{base64.b64encode(video).decode()}"' in text


def test_a_replay_that_fails_is_said_on_the_page(reference, tmp_path):
    out = tmp_path / "results"
    shutil.copytree(reference[1], out, ignore=shutil.ignore_patterns("videos", "report.html"))
    plan = json.loads((out / "plan.json").read_text())
    run_id = plan["experiments"][0]["run_ids"][0]
    result = out / "runs" / run_id / "result.json"
    data = json.loads(result.read_text())
    data["summary"]["config"]["shape"]["source"] = str(tmp_path / "gone.toml")  # the shape file is gone
    result.write_text(json.dumps(data))
    build_report(out, videos=True)
    text = (out / "report.html").read_text()
    assert "<video" not in text
    assert f"<strong>No video</strong>: Run <code>{run_id}</code>" in text and "gone.toml" in text
    assert "Videos: 1 missing." in text
    assert not (out / "videos" / "pair.mp4").exists()


def _browser() -> str | None:
    return next((path for path in map(shutil.which, BROWSERS) if path), None)


@pytest.mark.skipif(_browser() is None, reason="no chromium or chrome on PATH")
def test_a_headless_browser_shows_the_figures_and_plays_the_videos(page, tmp_path):
    out, _, _ = page
    build_report(out, videos=True)  # the page with its videos (an earlier test may have left it without)
    command = [_browser(), "--headless", "--no-sandbox", "--disable-gpu", "--mute-audio", "--no-first-run",
               f"--user-data-dir={tmp_path / 'profile'}", "--virtual-time-budget=20000", "--dump-dom",
               (out / "report.html").as_uri()]
    dom = subprocess.run(command, capture_output=True, text=True, timeout=120).stdout
    assert "</html>" in dom and '<nav id="contents">' in dom  # the page loaded and its script ran
    videos = re.findall(r"<video\b[^>]*>", dom)
    images = re.findall(r"<img\b[^>]*>", dom)
    assert len(videos) == 1 and len(images) >= 3
    for tag in videos + images:
        assert re.search(r'\ssrc="data:(image/png|video/mp4);base64,', tag), tag[:200]
    for tag in images:
        width = re.search(r'data-width="(\d+)"', tag)
        assert width and int(width.group(1)) > 0, tag[:200]  # decoded: not a broken image
    for tag in videos:
        assert "data-error" not in tag
        duration = re.search(r'data-duration="([^"]+)"', tag)
        assert duration, "the browser loaded no video metadata"
        assert math.isfinite(float(duration.group(1))) and float(duration.group(1)) > 0


def test_the_page_of_any_report_md(tmp_path, monkeypatch):
    """Markdown the report may come to hold: a section per experiment or none, links to files and sites, a figure
    that is not there; videos whose experiment has no section get one of their own, a failed rendering a note."""
    (tmp_path / "figures").mkdir()
    shutil.copy(ROOT / "docs" / "results.md", tmp_path / "notes.md")
    png = tmp_path / "figures" / "a.png"
    Image.new("RGB", (8, 6), "red").save(png)
    clip = tmp_path / "videos" / "beta.mp4"
    clip.parent.mkdir()
    writer = H264Writer(clip, (16, 16), 10, clip, "test")
    for _ in range(5):
        writer.write(np.zeros((16, 16, 3), "uint8"))
    writer.close()
    plan = {"suite": "s", "experiments": [{"name": "alpha"}, {"name": "beta"}, {"name": "gamma"}], "runs": [],
            "scans": [], "source": "s.toml"}
    (tmp_path / "plan.json").write_text(json.dumps(plan))
    (tmp_path / "report.md").write_text(
        "# Suite s\n\nSee [the notes](notes.md), [a site](https://example.org) and [below](#alpha).\n\n"
        "## alpha\n\n| a | b |\n|---|---|\n| 1 | <b>2</b> |\n\n![fig](figures/a.png)\n\n### Detail\n\ntext\n\n"
        "![gone](figures/gone.png) ![far](https://example.org/x.png) ![up](../secret.png)\n\n## Other\n")
    clips = [Video("alpha", run_id="r1", seed=0, label="chain-2, thermal", error="ConfigError: no shape"),
             Video("beta", run_id="r2", seed=1, label="chain-3", path=clip, steps=(0, 1), simulated_s=14.0,
                   codec="h264")]
    monkeypatch.setattr(page_module, "_videos", lambda root, plan: clips)
    text = page_module.write_html(tmp_path).read_text()
    assert all(s.startswith("data:") for s in re.findall(r'\ssrc="([^"]*)"', text))
    assert all(h.startswith("#") for h in re.findall(r'\shref="([^"]*)"', text))
    assert "the notes" in text and "a site" in text and '<a href="#alpha">below</a>' in text
    assert "<td>&lt;b&gt;2&lt;/b&gt;</td>" in text  # raw HTML of report.md is text, not markup
    assert text.count("is not in the results directory") == 3
    nav = text[text.index('<nav id="contents">'):text.index("</nav>")]
    assert ('<li class="experiment"><a href="#alpha">alpha</a><ul><li><a href="#detail">Detail</a></li>'
            '<li><a href="#alpha-video">video</a></li></ul></li>') in nav
    assert '<a href="#videos">Videos</a>' in nav  # beta has no section of its own in report.md
    alpha = text[text.index('<h2 id="alpha">'):text.index('<h2 id="other">')]
    assert alpha.index('id="detail"') < alpha.index("<strong>No video</strong>: Run <code>r1</code>")
    assert "ConfigError: no shape" in alpha
    beta = text[text.index('<h2 id="videos">'):]
    assert f'src="data:video/mp4;base64,{base64.b64encode(clip.read_bytes()).decode()}"' in beta
    assert "The results directory holds no suite.toml" in text

    monkeypatch.setattr(page_module, "_videos", lambda root, plan: 1 / 0)
    text = page_module.write_html(tmp_path).read_text()
    assert "No videos: rendering them failed (ZeroDivisionError" in text and "<video" not in text
