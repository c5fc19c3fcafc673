"""docs/tutorial.ipynb runs top to bottom in a fresh kernel, as a reader runs it (nbclient), and shows what it says it
shows; it is stored without outputs, and the pages it links to exist."""

from __future__ import annotations

import os
import re
from collections import Counter

import nbformat
import pandas as pd
from nbclient import NotebookClient

from conftest import ROOT

NOTEBOOK = ROOT / "docs" / "tutorial.ipynb"
LINK = re.compile(r"\]\(([^)\s]+)\)")


def read() -> nbformat.NotebookNode:
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    nbformat.validate(notebook)
    return notebook


def test_it_is_stored_without_outputs():
    code = [cell for cell in read().cells if cell.cell_type == "code"]
    assert len(code) >= 8
    assert all(not cell.outputs and cell.execution_count is None for cell in code)


def test_its_links_exist():
    text = "\n".join(cell.source for cell in read().cells if cell.cell_type == "markdown")
    links = [m.group(1).split("#")[0] for m in LINK.finditer(text)]
    assert len(links) >= 5
    assert [link for link in links if not (NOTEBOOK.parent / link).exists()] == []


def test_it_runs_top_to_bottom(tmp_path):
    notebook = read()
    # the kernel imports the morphbench of this checkout, whatever is installed
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    client = NotebookClient(notebook, timeout=300, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}})
    client.execute(env=env)  # raises CellExecutionError at the first cell that fails

    outputs = [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.outputs]
    shown = Counter(mime for o in outputs for mime in o.get("data", {}))
    # the learning curve, the landscape and the drawn shape; the video
    assert shown["image/png"] == 3 and shown["image/gif"] == 1
    printed = "".join(o.get("text", "") for o in outputs if o.output_type == "stream")
    final = float(re.search(r"final Ubar ([+-][\d.]+) mm/cycle", printed).group(1))
    assert final > 2.0  # chain-3 found a gait in 30 steps (seed 2)
    assert "8 runs done, 0 failed" in printed

    out = tmp_path / "tutorial-output"
    runs = pd.read_parquet(out / "tiny" / "runs.parquet")
    assert len(runs) == 8 and (runs.status == "done").all()
    for name in ("pair.png", "chain-3.gif", "chain-3/summary.json"):
        assert (out / name).stat().st_size > 0
