"""A sparse Cholesky factorisation of symmetric matrices made of 3 x 3 blocks, one block row per body, in the order
of a geometric nested dissection (compiled with numba; the planar solver's Newton systems for large shapes).

A body couples only to the bodies it is linked to, so the matrix has the links' pattern. Eliminating the bodies in
their natural order fills the whole band between linked bodies (a square sheet's band is a row wide: a factor of N^1.5
entries, N^2 work); nested dissection (George 1973) orders each half of the assembly, split across its longer side,
before the bodies of the cut between them, recursively, so a planar assembly's factor holds O(N log N) blocks.

``structure`` computes once per shape everything that depends only on the links (the order, the elimination tree's
pattern of the factor, where each matrix block lands in it); ``factor`` and ``solve`` then run on numbers alone.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

LEAF = 8
"""bodies: a part this small is not split further (its few bodies fill in among themselves anyway)."""
FILL = 2.5
"""blocks of the factor per body and per log2 of the bodies, at most (square sheets: 1.6 at 1,024 bodies, 2.3 at
100,000): the memory estimate's."""
BLOCK_BYTES = 9 * 8 + 3 * 8
"""bytes a block of the factor takes: its numbers, its row and its place in its row's list."""


def memory(bodies: int) -> float:
    """bytes, an upper estimate of a planar assembly's factor (``FILL``)."""
    return FILL * bodies * np.log2(bodies + 1) * BLOCK_BYTES


class Structure(NamedTuple):
    """The pattern of the factor L of a matrix over n bodies (lower block triangle, in elimination order)."""

    position: np.ndarray
    """(n,) each body's place in the elimination order."""
    columns: np.ndarray
    """(n + 1,) where each block column of L starts in ``rows``: its diagonal block first, then the rows below it."""
    rows: np.ndarray
    """(blocks,) the block row (elimination order) of each stored block, increasing within a column."""
    row_starts: np.ndarray
    """(n + 1,) where each block row's off-diagonal blocks start in ``row_slots``."""
    row_slots: np.ndarray
    """(blocks - n,) per block row, the storage index of each of its off-diagonal blocks."""
    row_columns: np.ndarray
    """(blocks - n,) the block column of each of them."""
    link_slots: np.ndarray
    """(links,) where each link's front-rear block lands, transposed where the front is eliminated first."""


NONE = Structure(*(np.zeros(0, dtype=np.int64) for _ in Structure._fields))
"""no pattern (a world that does not solve by this factorisation)."""


def dissection_order(points: np.ndarray, neighbours: list[np.ndarray]) -> np.ndarray:
    """Bodies (indices of ``points``, (n, 2)) in a nested dissection order: each part split at the median of its
    longer side, the bodies of the lower half linked across the cut (the separator) after both halves."""
    order: list[int] = []
    stack: list[tuple[np.ndarray, bool]] = [(np.arange(len(points)), False)]
    side = np.zeros(len(points), dtype=np.int8)
    while stack:  # depth first, a part's separator emitted after both its halves (pushed first, popped last)
        part, emit = stack.pop()
        if emit or len(part) <= LEAF:
            order.extend(part.tolist())
            continue
        xy = points[part]
        axis = int(np.argmax(np.ptp(xy, axis=0)))
        cut = np.median(xy[:, axis])
        low = xy[:, axis] <= cut
        if low.all():
            low = xy[:, axis] < cut
        if not low.any():  # every body at one place along both axes: nothing to split by
            order.extend(part.tolist())
            continue
        side[part[low]], side[part[~low]] = 1, 2
        across = np.array([side[i] == 1 and bool((side[neighbours[i]] == 2).any()) for i in part])
        side[part] = 0
        stack.append((part[across], True))
        stack.append((part[~low], False))
        stack.append((part[low & ~across], False))
    return np.array(order, dtype=np.int64)


def structure(points: np.ndarray, front: np.ndarray, rear: np.ndarray) -> Structure:
    """The factor's pattern for bodies at ``points`` ((n, 2), m) linked front to rear (every link, cut or not: a cut
    leaves its blocks 0)."""
    n = len(points)
    pairs = np.concatenate([np.stack([front, rear], 1), np.stack([rear, front], 1)])
    neighbours = np.split(pairs[np.argsort(pairs[:, 0], kind="stable"), 1],
                          np.cumsum(np.bincount(pairs[:, 0], minlength=n))[:-1])
    order = dissection_order(points, neighbours)
    position = np.empty(n, dtype=np.int64)
    position[order] = np.arange(n)
    starts = np.concatenate([[0], np.cumsum([len(neighbours[b]) for b in order])]).astype(np.int64)
    flat = np.concatenate([position[neighbours[b]] for b in order]) if n else np.zeros(0, dtype=np.int64)
    columns, rows, row_starts, row_slots, row_columns = _symbolic(starts, flat.astype(np.int64))
    link_slots = _link_slots(position[front], position[rear], columns, rows)
    return Structure(position, columns, rows, row_starts, row_slots, row_columns, link_slots)


@numba.njit(cache=True, nogil=True)
def _symbolic(starts, adjacent):
    """The pattern of L from the matrix's (``adjacent[starts[j]:starts[j + 1]]``: the bodies linked to the body at
    place j): row i of L holds the columns met walking up the elimination tree from each k < i linked to i."""
    n = len(starts) - 1
    parent = np.full(n, -1, dtype=np.int64)
    ancestor = np.full(n, -1, dtype=np.int64)
    for i in range(n):  # the elimination tree (Liu's algorithm, with path compression)
        for p in range(starts[i], starts[i + 1]):
            k = adjacent[p]
            while k != -1 and k < i:
                up = ancestor[k]
                ancestor[k] = i
                if up == -1:
                    parent[k] = i
                k = up
    mark = np.full(n, -1, dtype=np.int64)
    counts = np.ones(n, dtype=np.int64)  # per column, its diagonal block and the rows below
    row_starts = np.zeros(n + 1, dtype=np.int64)
    for sweep in range(2):  # count, then fill (rows come in increasing order, so each column is sorted)
        if sweep == 1:
            columns = np.zeros(n + 1, dtype=np.int64)
            columns[1:] = np.cumsum(counts)
            rows = np.empty(columns[n], dtype=np.int64)
            fill = columns[:n] + 1
            rows[columns[:n]] = np.arange(n)
            row_slots = np.empty(row_starts[n], dtype=np.int64)
            row_columns = np.empty(row_starts[n], dtype=np.int64)
            mark[:] = -1
        for i in range(n):
            mark[i] = i
            for p in range(starts[i], starts[i + 1]):
                k = adjacent[p]
                while k != -1 and k < i and mark[k] != i:
                    mark[k] = i
                    if sweep == 0:
                        counts[k] += 1
                        row_starts[i + 1] += 1
                    else:
                        rows[fill[k]] = i
                        row_columns[row_starts[i]] = k
                        row_slots[row_starts[i]] = fill[k]
                        fill[k] += 1
                        row_starts[i] += 1
                    k = parent[k]
        if sweep == 0:
            row_starts = np.cumsum(row_starts)
    row_starts[1:] = row_starts[:n].copy()  # the fill moved each start to the next row's
    row_starts[0] = 0
    return columns, rows, row_starts, row_slots, row_columns


@numba.njit(cache=True, nogil=True)
def _link_slots(front, rear, columns, rows):
    """Per link (its bodies' places), the storage index of its block in L's pattern."""
    slots = np.empty(len(front), dtype=np.int64)
    for link in range(len(front)):
        row, column = max(front[link], rear[link]), min(front[link], rear[link])
        slot = columns[column] + 1
        while rows[slot] != row:
            slot += 1
        slots[link] = slot
    return slots


@numba.njit(cache=True, nogil=True)
def factor(blocks, columns, rows, row_starts, row_slots, row_columns, where):
    """Factor in place the matrix held in ``blocks`` (one 3 x 3 block per slot of the pattern, the lower triangle
    in elimination order): True, or False if it is not definite to rounding. ``where`` is an (n,) int workspace."""
    n = len(columns) - 1
    for j in range(n):  # left-looking: column j less the columns k < j whose row j is not 0
        for q in range(columns[j], columns[j + 1]):
            where[rows[q]] = q
        for e in range(row_starts[j], row_starts[j + 1]):
            p, k = row_slots[e], row_columns[e]
            # L_ij -= L_ik L_jk^T for the rows i >= j of column k, L_jk held in scalars (the loop's hot spot)
            b00, b01, b02 = blocks[p, 0, 0], blocks[p, 0, 1], blocks[p, 0, 2]
            b10, b11, b12 = blocks[p, 1, 0], blocks[p, 1, 1], blocks[p, 1, 2]
            b20, b21, b22 = blocks[p, 2, 0], blocks[p, 2, 1], blocks[p, 2, 2]
            for q in range(p, columns[k + 1]):
                t = where[rows[q]]
                for a in range(3):
                    x0, x1, x2 = blocks[q, a, 0], blocks[q, a, 1], blocks[q, a, 2]
                    blocks[t, a, 0] -= x0 * b00 + x1 * b01 + x2 * b02
                    blocks[t, a, 1] -= x0 * b10 + x1 * b11 + x2 * b12
                    blocks[t, a, 2] -= x0 * b20 + x1 * b21 + x2 * b22
        d = blocks[columns[j]]
        l00 = d[0, 0]
        if not l00 > 0.0:
            return False
        l00 = np.sqrt(l00)
        l10, l20 = d[1, 0] / l00, d[2, 0] / l00
        l11 = d[1, 1] - l10 * l10
        if not l11 > 0.0:
            return False
        l11 = np.sqrt(l11)
        l21 = (d[2, 1] - l20 * l10) / l11
        l22 = d[2, 2] - l20 * l20 - l21 * l21
        if not l22 > 0.0:
            return False
        l22 = np.sqrt(l22)
        d[0, 0], d[0, 1], d[0, 2] = l00, 0.0, 0.0
        d[1, 0], d[1, 1], d[1, 2] = l10, l11, 0.0
        d[2, 0], d[2, 1], d[2, 2] = l20, l21, l22
        for q in range(columns[j] + 1, columns[j + 1]):  # L_ij = A_ij L_jj^-T
            b = blocks[q]
            for a in range(3):
                b[a, 0] = b[a, 0] / l00
                b[a, 1] = (b[a, 1] - l10 * b[a, 0]) / l11
                b[a, 2] = (b[a, 2] - l20 * b[a, 0] - l21 * b[a, 1]) / l22
    return True


@numba.njit(cache=True, nogil=True)
def solve(blocks, columns, rows, x):
    """x <- (L L^T)^-1 x in place, L factored by ``factor``; x is (n, 3), one row per place in elimination order."""
    n = len(columns) - 1
    for j in range(n):
        d = blocks[columns[j]]
        x[j, 0] = x[j, 0] / d[0, 0]
        x[j, 1] = (x[j, 1] - d[1, 0] * x[j, 0]) / d[1, 1]
        x[j, 2] = (x[j, 2] - d[2, 0] * x[j, 0] - d[2, 1] * x[j, 1]) / d[2, 2]
        for q in range(columns[j] + 1, columns[j + 1]):
            i, b = rows[q], blocks[q]
            for a in range(3):
                x[i, a] -= b[a, 0] * x[j, 0] + b[a, 1] * x[j, 1] + b[a, 2] * x[j, 2]
    for j in range(n - 1, -1, -1):
        for q in range(columns[j] + 1, columns[j + 1]):
            i, b = rows[q], blocks[q]
            for a in range(3):
                x[j, a] -= b[0, a] * x[i, 0] + b[1, a] * x[i, 1] + b[2, a] * x[i, 2]
        d = blocks[columns[j]]
        x[j, 2] = x[j, 2] / d[2, 2]
        x[j, 1] = (x[j, 1] - d[2, 1] * x[j, 2]) / d[1, 1]
        x[j, 0] = (x[j, 0] - d[1, 0] * x[j, 1] - d[2, 0] * x[j, 2]) / d[0, 0]
