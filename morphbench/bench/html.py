"""report.html: report.md as one self-contained page, with a video of one run per experiment.

``write_html(DIR)`` (called by ``build_report`` after it wrote report.md) renders ``DIR/report.md`` with markdown-it-py
(CommonMark and tables) and writes ``DIR/report.html``, which needs no other file and makes no request:
- figures are inlined as ``data:image/png;base64`` URIs, the CSS and the one script are in the page; a link or image
  to a file that is not in the directory, or to another site, is shown as text;
- at the top, the contents: every section of the report (each experiment, with its subsections and its video) and
  the two below, as links to their anchors;
- in each experiment's section, a short H.264 video of one of its runs (``morphbench.bench.videos``), inlined as a
  ``data:video/mp4;base64`` URI (the same file is in ``DIR/videos/``); a replay that fails says so in its place.
  ``build_report`` has them rendered in a process of their own (``start_videos``) while it writes report.md;
- at the end, the suite file the results came from (``DIR/suite.toml``, verbatim) and the versions: of the software
  at report time, and what the results directory itself records of the runs' environment.

The page's script writes each video's ``duration`` (s) into its ``data-duration`` attribute once its metadata has
loaded (``data-error`` if it cannot be played) and each image's decoded width into ``data-width``, so a headless
browser's DOM tells whether the figures show and the videos play.
"""

from __future__ import annotations

import base64
import html
import json
import mimetypes
import multiprocessing
import os
import re
import time
from concurrent.futures import Future, ProcessPoolExecutor
from pathlib import Path
from urllib.parse import unquote, urlsplit

from markdown_it import MarkdownIt

from morphbench.bench import provenance
from morphbench.failures import describe
from morphbench.files import write_text

SUITE_ANCHOR, VERSIONS_ANCHOR = "suite-file", "versions"


def start_videos(root: str | Path) -> Future:
    """The videos ``write_html`` shows, rendered (or reused) in a process of their own from now on: ``build_report``
    writes report.md meanwhile, which takes about as long, on the machine's other core."""
    pool = ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn"))
    future = pool.submit(_videos, Path(root), json.loads((Path(root) / "plan.json").read_text()))
    pool.shutdown(wait=False)  # the process ends once the videos are done
    return future


def write_html(root: str | Path, videos: bool | Future = True) -> Path:
    """Write ``root/report.html`` from ``root/report.md`` (see the module doc); with ``videos``, render (or reuse)
    one video per experiment first, or take those ``start_videos`` renders. Returns the page's path."""
    root = Path(root)
    plan = json.loads((root / "plan.json").read_text())
    failure = None
    try:
        clips = (videos.result() if isinstance(videos, Future) else _videos(root, plan)) if videos else None
    except Exception as exc:  # the videos are optional: the page goes on without them
        clips, failure = None, describe(exc)
    note = _video_note(clips, failure)
    md = MarkdownIt("commonmark", {"html": False}).enable("table")
    tokens = md.parse((root / "report.md").read_text(encoding="utf-8"))
    _inline_sources(tokens, root)
    headings = _anchor_headings(tokens)
    left = _insert_videos(tokens, {clip.experiment: clip for clip in clips or []}, root)
    body = md.renderer.render(tokens, md.options, {})
    if left:  # experiments the report has no section for: their videos in one of their own
        used = {anchor for _, _, anchor in headings} | {SUITE_ANCHOR, VERSIONS_ANCHOR}
        anchor = _unique("videos", used)
        headings.append((2, "Videos", anchor))
        body += f'<h2 id="{anchor}">Videos</h2>\n' + "".join(
            f"<h3 id=\"{_unique(_slug(c.experiment), used)}\">{html.escape(c.experiment)}</h3>\n"
            + _video_html(c, f"{anchor}-{_slug(c.experiment)}", root) for c in left)
    shown = {clip.experiment for clip in clips or []} - {clip.experiment for clip in left}
    title = next((text for level, text, _ in headings if level == 1), f"Suite {plan.get('suite', '')}")
    experiments = [e["name"] for e in plan["experiments"]]
    page = PAGE.format(title=html.escape(title), css=CSS, script=SCRIPT,
                       body=_with_contents(body, headings, experiments, shown, note),
                       suite=_suite_section(root, plan), versions=_versions_section(root))
    path = root / "report.html"
    write_text(path, page)
    return path


def markdown_page(text: str, title: str, root: str | Path | None = None) -> str:
    """A Markdown text (CommonMark and tables, no raw HTML) as one page in the report's style (the leaderboard); with
    ``root``, its images of files in ``root`` inline as data URIs (as report.html's), anything else as text."""
    md = MarkdownIt("commonmark", {"html": False}).enable("table")
    tokens = md.parse(text)
    if root is not None:
        _inline_sources(tokens, Path(root))
    body = md.renderer.render(tokens, md.options, {})
    return PAGE.format(title=html.escape(title), css=CSS, script="", body=body, suite="", versions="")


# --- markdown tokens ------------------------------------------------------------------------------------------------


def _inline_sources(tokens, root: Path) -> None:
    """Images of files in ``root`` become data URIs; links and images to anything else become plain text."""
    for token in tokens:
        if token.type != "inline" or not token.children:
            continue
        children = []
        skip_close = 0
        for child in token.children:
            if child.type == "image":
                uri = _data_uri(root, child.attrGet("src") or "")
                if uri is None:
                    child.type, child.tag = "text", ""
                    child.content = f"[figure {child.attrGet('src')} is not in the results directory]"
                    child.attrs, child.children = {}, None
                else:
                    child.attrSet("src", uri)
            elif child.type == "link_open":
                href = child.attrGet("href") or ""
                if not href.startswith("#"):
                    skip_close += 1  # the link's text stays, the link goes
                    continue
            elif child.type == "link_close" and skip_close:
                skip_close -= 1
                continue
            children.append(child)
        token.children = children


def _data_uri(root: Path, src: str) -> str | None:
    """``src`` (relative to ``root``) as a data URI, or None if it is not a file inside ``root``."""
    parts = urlsplit(src)
    if parts.scheme or parts.netloc or not parts.path or os.path.isabs(parts.path):
        return None
    path = (root / unquote(parts.path)).resolve()
    if not path.is_file() or not path.is_relative_to(root.resolve()):
        return None
    kind = mimetypes.guess_type(path.name)[0] or "application/octet-stream"
    return f"data:{kind};base64,{base64.b64encode(path.read_bytes()).decode('ascii')}"


def _anchor_headings(tokens) -> list[tuple[int, str, str]]:
    """Give every heading a unique id; returns (level, text, id) in order."""
    headings, used = [], {SUITE_ANCHOR, VERSIONS_ANCHOR}
    for k, token in enumerate(tokens):
        if token.type == "heading_open":
            text = tokens[k + 1].content if k + 1 < len(tokens) else ""
            anchor = _unique(_slug(text), used)
            token.attrSet("id", anchor)
            headings.append((int(token.tag[1]), _plain(text), anchor))
    return headings


def _slug(text: str) -> str:
    slug = re.sub(r"[^a-z0-9_.-]+", "-", _plain(text).lower()).strip("-")
    return slug or "section"


def _plain(text: str) -> str:
    """Heading text without Markdown's inline marks."""
    return re.sub(r"[`*_]", "", text).strip()


def _unique(anchor: str, used: set[str]) -> str:
    candidate, n = anchor, 2
    while candidate in used:
        candidate, n = f"{anchor}-{n}", n + 1
    used.add(candidate)
    return candidate


def _insert_videos(tokens, clips: dict, root: Path) -> list:
    """Each experiment's video at the end of its section (before the next heading of its level or above); returns
    the clips of experiments without a section."""
    from markdown_it.token import Token

    clips = dict(clips)
    opens = [k for k, t in enumerate(tokens) if t.type == "heading_open"]
    level = {k: int(tokens[k].tag[1]) for k in opens}
    inserts = []
    for k in opens:
        name = _plain(tokens[k + 1].content)
        if level[k] != 2 or name not in clips:
            continue
        end = next((j for j in opens if j > k and level[j] <= level[k]), len(tokens))
        block = Token("html_block", "", 0)
        block.content = _video_html(clips.pop(name), tokens[k].attrGet("id"), root)
        inserts.append((end, block))
    for end, block in sorted(inserts, key=lambda item: -item[0]):
        tokens.insert(end, block)
    return list(clips.values())


def _video_html(clip, section: str, root: Path) -> str:
    anchor = f"{section}-video"
    what = (f"Run <code>{html.escape(clip.run_id)}</code> ({html.escape(clip.label)}, seed {clip.seed})"
            if clip.run_id else "")
    if clip.path is None:
        reason = html.escape(clip.error or "unknown")
        failed = f": {what} could not be replayed" if what else ""
        return f'<div class="video missing" id="{anchor}"><p><strong>No video</strong>{failed}: {reason}</p></div>\n'
    data = base64.b64encode(Path(clip.path).read_bytes()).decode("ascii")
    first, last = clip.steps
    shown = f"learning steps {first} to {last} ({clip.simulated_s:.0f} s of simulated time, step 0 with the warm-up)"
    codec = "" if clip.codec == "h264" else (f" Encoded as {html.escape(clip.codec)} (PyAV is missing): most "
                                             "browsers cannot play it; <code>pip install av</code> gives H.264.")
    relative = html.escape(Path(clip.path).relative_to(root).as_posix())
    return (f'<figure class="video" id="{anchor}">\n<video controls muted playsinline preload="metadata" '
            f'src="data:video/mp4;base64,{data}"></video>\n<figcaption><strong>Video.</strong> {what}: {shown}, '
            f"replayed off-screen from its stored configuration; also in <code>{relative}</code>.{codec}"
            "</figcaption>\n</figure>\n")


# --- the page around the report -------------------------------------------------------------------------------------


def _with_contents(body: str, headings, experiments: list[str], with_video: set[str], note: str) -> str:
    """The body with the contents list (and ``note``) after its title (or at its top); ``with_video``: the
    experiments whose section ends with a video."""
    names = set(experiments)
    items = [(level, text, anchor) for level, text, anchor in headings if level >= 2]
    entries = [(level, text, anchor, "experiment" if level == 2 and text in names else "")
               for level, text, anchor in items]
    for k in reversed(range(len(items))):  # each experiment's video after its last subsection, as in the page
        level, text, anchor = items[k]
        if level == 2 and text in with_video:
            end = next((j for j in range(k + 1, len(items)) if items[j][0] <= 2), len(items))
            entries.insert(end, (3, "video", f"{anchor}-video", ""))
    entries += [(2, "Suite file", SUITE_ANCHOR, ""), (2, "Versions", VERSIONS_ANCHOR, "")]
    nav = f'<nav id="contents"><h2>Contents</h2>\n<ul>{_tree(entries)}</ul>\n{note}</nav>\n'
    end = body.find("</h1>")
    return body[:end + 5] + "\n" + nav + body[end + 5:] if end >= 0 else nav + body


def _tree(entries) -> str:
    """Nested list items of (level, text, anchor, class) entries in document order."""
    out, i = [], 0
    while i < len(entries):
        level, text, anchor, css = entries[i]
        j = i + 1
        while j < len(entries) and entries[j][0] > level:
            j += 1
        children = _tree(entries[i + 1:j])
        mark = f' class="{css}"' if css else ""
        out.append(f'<li{mark}><a href="#{anchor}">{html.escape(text)}</a>'
                   + (f"<ul>{children}</ul>" if children else "") + "</li>")
        i = j
    return "".join(out)


def _video_note(clips, failure: str | None = None) -> str:
    if failure is not None:
        return f'<p class="note">No videos: rendering them failed ({html.escape(failure)}).</p>'
    if clips is None:
        return "<p class=\"note\">Videos were not rendered (<code>--no-videos</code>).</p>"
    made = [c for c in clips if c.path is not None and not c.reused]
    reused = [c for c in clips if c.reused]
    failed = [c for c in clips if c.path is None]
    seconds = sum(c.wall_time_s for c in made)
    parts = [f"{len(made)} rendered in {seconds:.1f} s" if made else "", f"{len(reused)} reused" if reused else "",
             f"{len(failed)} missing" if failed else ""]
    text = ", ".join(p for p in parts if p) or "none"
    return f'<p class="note">Videos: {text}.</p>'


def _suite_section(root: Path, plan: dict) -> str:
    path = root / "suite.toml"
    source = html.escape(str(plan.get("source", "")))
    if path.is_file():
        text = html.escape(path.read_text(encoding="utf-8", errors="replace"))
        return (f'<h2 id="{SUITE_ANCHOR}">Suite file</h2>\n<p>The suite the results came from: '
                f"<code>suite.toml</code> of the results directory, copied from <code>{source}</code> when the bench "
                f"ran.</p>\n<pre><code>{text}</code></pre>\n")
    return (f'<h2 id="{SUITE_ANCHOR}">Suite file</h2>\n<p>The results directory holds no suite.toml (the suite was '
            f"read from <code>{source}</code>).</p>\n")


def _versions_section(root: Path) -> str:
    rows = "".join(f"<tr><td>{html.escape(n)}</td><td>{html.escape(v)}</td></tr>"
                   for n, v in provenance.software_versions().items())
    return (f'<h2 id="{VERSIONS_ANCHOR}">Versions</h2>\n<p>At report time ({time.strftime("%Y-%m-%d %H:%M")}, '
            f"{html.escape(provenance.machine())}):</p>\n<table><thead><tr><th>software</th><th>version</th></tr>"
            f"</thead><tbody>{rows}</tbody></table>\n{_recorded_environment(root)}")


def _recorded_environment(root: Path) -> str:
    """What the results directory records of the environment its runs ran in (environment.json)."""
    sessions = provenance.read_sessions(root)
    if not sessions:
        return ("<p>The results directory records no versions of the runs' environment (it has no "
                "<code>environment.json</code>: its runs were stored before benches recorded one): they may have "
                "run with other versions than these.</p>\n")
    parts = ["<p>What the runs ran with, as each bench that ran jobs into the directory recorded it "
             "(<code>environment.json</code>: the versions of the process that ran the bench; a Dask cluster's "
             "workers could have others):</p>\n<table><thead><tr><th>bench started</th><th>finished</th>"
             "<th>jobs run</th><th>failed</th><th>executor</th><th>machine</th><th>versions</th></tr></thead><tbody>"]
    for session in sessions:
        versions = session.get("versions")
        listed = ", ".join(f"{k} {v}" for k, v in versions.items()) if isinstance(versions, dict) else versions
        cells = [session.get(key, "") for key in ("started", "finished", "jobs", "failed", "executor", "machine")]
        parts.append("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in [*cells, listed or ""]) + "</tr>")
    return "".join(parts) + "</tbody></table>\n"


CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto; max-width: 1200px;
       padding: 0 1em; color: #222; line-height: 1.45; }
h1, h2, h3 { line-height: 1.2; }
h2 { border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 2em; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.85em; display: block; overflow-x: auto; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.5em; text-align: left; white-space: nowrap; }
th { background: #f0f0f0; }
tr:nth-child(even) td { background: #fafafa; }
img { max-width: 100%; height: auto; }
code { background: #f4f4f4; padding: 0 0.2em; border-radius: 3px; }
pre { background: #f4f4f4; padding: 0.8em; overflow-x: auto; font-size: 0.85em; }
pre code { background: none; padding: 0; }
nav#contents { background: #f8f8f8; border: 1px solid #ddd; padding: 0.5em 1.5em; margin: 1em 0; }
nav#contents h2 { border: none; margin: 0.3em 0; font-size: 1.1em; }
nav#contents ul { margin: 0.2em 0; }
nav#contents li.experiment > a { font-weight: 600; }
figure.video { margin: 1em 0; }
figure.video video { max-width: 100%; width: 480px; background: #000; }
figcaption { font-size: 0.85em; color: #555; max-width: 60em; }
div.video.missing { border-left: 4px solid #c33; padding: 0.2em 1em; background: #fff4f4; }
p.note { font-size: 0.85em; color: #555; }
"""

SCRIPT = """
document.querySelectorAll("video").forEach(function (video) {
  function record() { video.setAttribute("data-duration", String(video.duration)); }
  video.addEventListener("loadedmetadata", record);
  video.addEventListener("error", function () {
    video.setAttribute("data-error", String(video.error ? video.error.code : "unknown"));
  });
  if (video.readyState >= 1) { record(); }
});
document.querySelectorAll("img").forEach(function (img) {
  function record() { img.setAttribute("data-width", String(img.naturalWidth)); }
  if (img.complete) { record(); } else { img.addEventListener("load", record); img.addEventListener("error", record); }
});
"""

PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title}</title>
<style>{css}</style>
</head>
<body>
{body}
{suite}
{versions}
<script>{script}</script>
</body>
</html>
"""


def _videos(root: Path, plan: dict):
    from morphbench.bench.videos import render_videos

    return render_videos(root, plan)
