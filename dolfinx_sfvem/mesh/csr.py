"""Flat (CSR) arrays of variable-length rows, the layout of polygon vertex lists: entries per row,
the cyclic next and previous entry, and the key of an undirected edge between two points.

A CSR array is ``offsets`` (n_rows + 1,) int64 with ``offsets[0] == 0`` and the flat entries;
row k is ``entries[offsets[k]:offsets[k + 1]]``.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt


def segment_owner(offsets: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Segment index of every entry of a CSR array with these offsets, (offsets[-1],)."""
    return np.repeat(np.arange(offsets.size - 1, dtype=np.int64), np.diff(offsets))


def concatenated_ranges(starts: npt.NDArray[np.int64], lengths: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Concatenation of ``arange(s, s + n)`` over the pairs of ``starts`` and ``lengths`` (k,):
    (lengths.sum(),) int64. With CSR offsets: the entries of a set of polygons."""
    total = int(lengths.sum())
    shift = np.repeat(starts - np.concatenate([[0], np.cumsum(lengths)[:-1]]), lengths)
    return (shift + np.arange(total)).astype(np.int64)


def next_entries(offsets: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Position (offsets[-1],) int64 of the next vertex of the same polygon, counter-clockwise,
    for every entry of a CSR vertex array with these offsets (the last vertex is followed by the first)."""
    nxt = np.arange(1, offsets[-1] + 1, dtype=np.int64)
    nxt[offsets[1:] - 1] = offsets[:-1]
    return nxt


def previous_entries(offsets: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Position (offsets[-1],) int64 of the previous vertex of the same polygon (clockwise) for
    every entry of a CSR vertex array with these offsets: the inverse of :func:`next_entries`."""
    previous = np.arange(-1, offsets[-1] - 1, dtype=np.int64)
    previous[offsets[:-1]] = offsets[1:] - 1
    return previous


def edge_key(a: npt.ArrayLike, b: npt.ArrayLike, n_points: int) -> npt.NDArray[np.int64]:
    """Key of the undirected edges between points ``a`` and ``b`` (same shape) of a mesh with
    ``n_points`` points: ``min(a, b) * n_points + max(a, b)``, the same for both directions,
    ordered as the pairs (lower, higher end point)."""
    return np.minimum(a, b) * n_points + np.maximum(a, b)
