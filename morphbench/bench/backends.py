"""Two results directories of one suite run on different physics (e.g. ``benchmarks/paper-quick.toml`` on PyBullet
and on the quasi-static model), condition by condition: what each backend gives and where they disagree.

``compare(a, b)`` reads both directories' ``metrics.parquet`` (written by ``morphbench report``) and pairs the
conditions that are equal in every condition column but ``physics``, the ``backend`` it resolved to and the ids that
hash them. Per pair and per compared metric (final Ubar, U_eq where the fit has a plateau, steps to 0.8 U_eq, mean
acceptance) it gives both values and the difference b - a.
Final Ubar has a standard error over seeds in each directory; the pair **disagrees** when the difference exceeds
``DISAGREE_SE`` combined standard errors, sqrt(std_a^2 / n_a + std_b^2 / n_b), so a difference that seed noise explains
is not called one. ``morphbench report DIR --compare A B`` keeps the table as ``DIR/backends.parquet``, and the
report of DIR shows it from then on (``section``). A table that is unreadable, lacks a column ``compare`` or a report
reads, holds an infinity or a row twice (a condition, a run) is a ConfigError naming the file, and so is a directory
compared with itself: nothing is compared or written.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pandas as pd

from morphbench.bench import metrics as M
from morphbench.errors import ConfigError
from morphbench.failures import describe
from morphbench.files import is_file

COMPARED = {"final_ubar": "final Ubar", "u_eq": "U_eq", "steps_to_threshold": f"steps to {M.THRESHOLD:g} U_eq",
            "acceptance_mean": "acceptance"}
"""metric column -> its name in the report."""
DISAGREE_SE = 2.0
"""combined standard errors of final Ubar beyond which two backends disagree on a condition."""
TABLE = "backends"
"""DIR/backends.parquet: the comparison a report shows."""
SHOWN = ("physics_a", "physics_b", "runs_a", "runs_b", "disagree",
         *(f"{column}_{side}" for column in COMPARED for side in ("a", "b", "diff")))
"""the columns of backends.parquet a report shows (``section``)."""
_READ = {"metrics": ("condition_id", ("condition_id", "physics", "runs", "failed", "missing", "final_ubar_std",
                                       *COMPARED)),
         "runs": ("run_id", ("run_id", "condition_id", "experiments"))}
"""per table of a results directory ``compare`` reads: the column that names a row (each value once) and the
columns it reads."""
_NOT_CONDITION = {"condition_id", "physics", "backend", "shape_id", "environment_id"}
_LABEL_COLUMNS = ("experiments", "shape", "learner", "step_size", "noise", "environment", "events", "steps")


def compare(a: str | Path, b: str | Path) -> pd.DataFrame:
    """One row per condition found in both results directories (see the module doc)."""
    if _same(a, b):
        raise ConfigError("--compare", str(b), f"a results directory other than {a} (the same directory compared "
                                               "with itself)")
    (ma, ra), (mb, _) = _read(a), _read(b)
    for table in (ma, mb):  # a U_eq without a plateau is an extrapolation, as in the report's own tables
        if "plateau" in table:
            table.loc[~table.plateau.astype(bool), "u_eq"] = math.nan
    keys = [c for c in M.condition_columns(ra) if c in mb.columns and c not in _NOT_CONDITION]
    ma = ma.assign(experiments=ma.condition_id.map(_experiments(ra)))
    pairs = ma.merge(mb, on=keys, suffixes=("_a", "_b"))
    table = pairs[[c for c in _LABEL_COLUMNS if c in pairs.columns]].copy()
    table["physics_a"], table["physics_b"] = pairs.physics_a, pairs.physics_b
    table["runs_a"], table["runs_b"] = pairs.runs_a - pairs.failed_a - pairs.missing_a, \
        pairs.runs_b - pairs.failed_b - pairs.missing_b
    for column in COMPARED:
        table[f"{column}_a"], table[f"{column}_b"] = pairs[f"{column}_a"], pairs[f"{column}_b"]
        table[f"{column}_diff"] = pairs[f"{column}_b"] - pairs[f"{column}_a"]
    se = np.sqrt(pairs.final_ubar_std_a ** 2 / table.runs_a.clip(lower=1)
                 + pairs.final_ubar_std_b ** 2 / table.runs_b.clip(lower=1))
    table["final_ubar_se"] = se
    table["disagree"] = table.final_ubar_diff.abs() > DISAGREE_SE * se
    return table.reset_index(drop=True)


def section(table: pd.DataFrame) -> list[str]:
    """report.md lines: the comparison's table, and in words where the backends disagree."""
    if table.empty:
        return ["## Backends side by side", "", "The two results directories share no condition.", ""]
    a, b = table.physics_a.iloc[0], table.physics_b.iloc[0]
    lines = ["## Backends side by side", "",
             f"The same suite on two physics backends, a = {a} and b = {b}, condition by condition: each metric as "
             f"a / b (difference b - a). A condition **disagrees** when the final Ubars differ by more than "
             f"{DISAGREE_SE:g} standard errors over seeds.", ""]
    label = [c for c in _LABEL_COLUMNS if c in table.columns and (c == "experiments" or table[c].nunique() > 1)]
    header = [*label, "runs", *COMPARED.values(), "disagree"]
    lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for _, row in table.iterrows():
        cells = [_text(row[c]) for c in label] + [f"{row.runs_a} / {row.runs_b}"]
        for column in COMPARED:
            digits = 1 if column == "steps_to_threshold" else 2
            cells.append(f"{_num(row[f'{column}_a'], digits)} / {_num(row[f'{column}_b'], digits)} "
                         f"({_num(row[f'{column}_diff'], digits, sign=True)})")
        cells.append("**yes**" if row.disagree else "no")
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    worse = table[table.disagree]
    if worse.empty:
        lines += [f"The backends agree on every one of the {len(table)} conditions within seed noise.", ""]
    else:
        where = "; ".join(f"{_text(row.get('experiments', ''))} {_text(row.get('learner', ''))}: "
                          f"{row.final_ubar_a:.2f} against "
                          f"{row.final_ubar_b:.2f} mm/cycle" for _, row in worse.iterrows())
        lines += [f"They disagree on {len(worse)} of {len(table)} conditions: {where}.", ""]
    return lines


def read_table(root: str | Path) -> pd.DataFrame | None:
    """``root/backends.parquet``, checked (``table_problem``); None if there is none, ConfigError if it is damaged."""
    path = Path(root) / f"{TABLE}.parquet"
    return _table(path, table_problem) if is_file(path) else None


def table_problem(table: pd.DataFrame) -> str | None:
    """What a backends table lacks for a report (columns of SHOWN, numbers finite or NaN), or None."""
    return _problem(table, SHOWN, [c for c in SHOWN if not c.startswith("physics_")])


def _read(directory: str | Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """A results directory's metrics and runs tables, with the columns ``compare`` reads."""
    root = Path(directory)
    tables = []
    for name, (key, columns) in _READ.items():
        path = root / f"{name}.parquet"
        if not is_file(path):
            raise ConfigError(str(root), f"{name}.parquet", "a results directory with its report built (morphbench "
                              "bench, or morphbench report DIR)", "no such file")
        numeric = [c for c in columns if c not in ("run_id", "condition_id", "physics", "experiments")]
        tables.append(_table(path, lambda table, c=columns, n=numeric, k=key: _problem(table, c, n, k)))
    return tables[0], tables[1]


def _same(a: str | Path, b: str | Path) -> bool:
    """Whether ``a`` and ``b`` are one directory, however spelled (a symlink, a trailing slash, ..)."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):  # one is missing (its own message follows) or no path at all
        return False


def _table(path: Path, problem) -> pd.DataFrame:
    """A Parquet table whose ``problem(table)`` is None; else ConfigError naming the file."""
    try:
        table = pd.read_parquet(path)
    except Exception as exc:  # noqa: BLE001 - whatever Arrow raises on a damaged file
        raise ConfigError(str(path.parent), path.name, f"a Parquet table ({describe(exc, where=False)[:160]})"
                          ) from None
    reason = problem(table)
    if reason:
        raise ConfigError(str(path.parent), path.name, reason)
    return table


def _problem(table: pd.DataFrame, columns, numeric, key: str | None = None) -> str | None:
    """Why ``table`` lacks one of ``columns``, holds something but numbers (finite or NaN) in ``numeric`` or holds a
    value of ``key`` twice (a row repeated: it would be compared twice)."""
    missing = [c for c in columns if c not in table.columns]
    if missing:
        return f"the columns {', '.join(columns)}; no {missing[0]}"
    if key is not None and table[key].duplicated().any():
        twice = table[key][table[key].duplicated()].iloc[0]
        return f"one row per {key}, got {_text(twice)} {int((table[key] == twice).sum())} times"
    for column in numeric:
        if not pd.api.types.is_numeric_dtype(table[column]):  # bools are numbers here
            return f"numbers in column {column}, got {table[column].dtype}"
        if np.isinf(table[column].to_numpy(dtype=float, na_value=np.nan)).any():
            return f"no infinite value in column {column}"
    return None


def _experiments(runs: pd.DataFrame) -> dict[str, str]:
    return runs.groupby("condition_id").experiments.first().to_dict()


def _text(value) -> str:
    if isinstance(value, (float, np.floating)):
        return "-" if not math.isfinite(value) else f"{value:g}"
    return str(value).replace("|", "\\|").replace("\n", " ") if value is not None else "-"


def _num(value, digits: int, sign: bool = False) -> str:
    if value is None or not math.isfinite(float(value)):
        return "-"
    return f"{value:+.{digits}f}" if sign else f"{value:.{digits}f}"
