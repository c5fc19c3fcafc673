"""An off-screen picture of a shape at rest (matplotlib, no pyplot): a top view and a side view in one PNG."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from morphbench.files import atomic_write
from morphbench.shapes.colours import BELLOWS_RGBA, DUMMY_RGBA, PASSIVE_RGBA, UNIT_RGBA
from morphbench.shapes.model import Shape


def draw(shape: Shape, path: str | Path, dpi: int = 120) -> Path:
    """An off-screen picture (PNG) of the shape at rest: a top view (x forward to the right, y up the page) and a
    side view (x to the right, z up), units numbered, dummies marked D, actuated and passive links in their colours,
    the heading as an arrow, with a legend."""
    from matplotlib.figure import Figure  # no pyplot: no global backend, nothing left open
    from matplotlib.lines import Line2D
    from matplotlib.patches import FancyBboxPatch, Patch

    path = Path(path)
    centres = np.array([b.position for b in shape.bodies], dtype=float)
    sizes = np.array([b.size for b in shape.bodies], dtype=float)
    lo, hi = (centres - sizes / 2).min(axis=0), (centres + sizes / 2).max(axis=0)
    lo[2] = min(lo[2], 0.0)
    span = np.maximum(hi - lo, 1e-3)
    pad = 0.1 * span + 0.015  # m around the bodies, per axis
    extent = span + 2 * pad
    width = 9.0
    heights = [max(1.2, width * extent[1] / extent[0]), max(1.0, width * extent[2] / extent[0])]
    scale = min(1.0, 10.0 / sum(heights))
    fig = Figure(figsize=(width * scale, sum(heights) * scale + 1.6))
    top, side = fig.subplots(2, 1, gridspec_kw={"height_ratios": heights})
    labels, n = [], 0
    for body in shape.bodies:
        n += not body.dummy
        labels.append("D" if body.dummy else str(n))
    views = ((top, (0, 1), 2, "top view (x forward, y left)"), (side, (0, 2), 1, "side view (x forward, z up)"))
    for ax, (u, v), depth, title in views:
        # Bodies from the farthest to the nearest (lowest first from above, leftmost first from the side), then links
        # over them, then one label per place (bodies one behind the other share it: "1/5", nearest last).
        near = centres[:, depth] if depth == 2 else -centres[:, depth]
        order = np.argsort(near, kind="stable")
        places: dict[tuple[float, float], list[int]] = {}
        for i in order:
            body = shape.bodies[i]
            (cx, cy), (w, h) = centres[i, [u, v]], sizes[i, [u, v]]
            rounding = 0.0 if body.mesh in ("", "box") else 0.45 * min(w, h)
            colour = DUMMY_RGBA if body.dummy else UNIT_RGBA
            ax.add_patch(FancyBboxPatch((cx - w / 2 + rounding, cy - h / 2 + rounding), w - 2 * rounding,
                                        h - 2 * rounding, boxstyle=f"round,pad={rounding}", facecolor=colour[:3],
                                        alpha=0.85, edgecolor="black", linewidth=0.6, zorder=1))
            places.setdefault((round(cx, 9), round(cy, 9)), []).append(i)
        for link in shape.links:
            a, b = centres[link.rear, [u, v]], centres[link.front, [u, v]]
            actuated = link.unit is not None
            ax.plot([a[0], b[0]], [a[1], b[1]], color=(BELLOWS_RGBA if actuated else PASSIVE_RGBA)[:3],
                    linewidth=3.0 if actuated else 1.6, linestyle="-" if actuated else "--", zorder=2,
                    solid_capstyle="round")
        for (cx, cy), bodies in places.items():
            nearest = shape.bodies[bodies[-1]]
            ax.text(cx, cy, "/".join(labels[i] for i in bodies), ha="center", va="center", fontsize=7,
                    color="white", weight="bold", zorder=3,
                    bbox={"boxstyle": "round,pad=0.15", "facecolor": (DUMMY_RGBA if nearest.dummy else UNIT_RGBA)[:3],
                          "edgecolor": "none"})
        ax.set_xlim(lo[u] - pad[u], hi[u] + pad[u])
        ax.set_ylim((-0.004 if v == 2 else lo[v] - pad[v]), hi[v] + pad[v])
        ax.set_aspect("equal")
        ax.set_title(title, fontsize=9)
        ax.set_xlabel(f"{'xyz'[u]} (m)", fontsize=8)
        ax.set_ylabel(f"{'xyz'[v]} (m)", fontsize=8)
        ax.tick_params(labelsize=7)
    side.axhline(0.0, color="saddlebrown", linewidth=1.5, zorder=0)
    heading = np.asarray(shape.heading, dtype=float)
    if np.linalg.norm(heading[:2]) > 1e-9:
        arrow = heading[:2] / np.linalg.norm(heading[:2]) * 0.8 * min(pad[0], pad[1])
        start = np.array([hi[0] + 0.5 * pad[0], hi[1] + 0.5 * pad[1]]) - arrow / 2
        top.annotate("", xy=start + arrow, xytext=start, arrowprops={"arrowstyle": "->", "color": "black"})
        top.text(*(start + arrow / 2), "heading", fontsize=7, ha="center", va="bottom")
    handles = [Patch(color=UNIT_RGBA[:3], label="unit (unit number)"), Patch(color=DUMMY_RGBA[:3], label="dummy (D)"),
               Line2D([], [], color=BELLOWS_RGBA[:3], linewidth=3.0, label="bellows (actuated link)"),
               Line2D([], [], color=PASSIVE_RGBA[:3], linewidth=1.6, linestyle="--", label="passive link")]
    fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=8, frameon=False)
    summary = f"{shape.name}: {shape.n_units} units, {len(shape.bodies)} bodies, {len(shape.links)} links"
    fig.suptitle(summary + (f"\n{shape.description}" if shape.description else ""), fontsize=9)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    return atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=dpi, format="png"))
