"""Sort-based helpers on integer id arrays for the sharp-feature step (`isoscope.core.sharp.features`).

np.unique and np.isin hash; on the million-entry keys here a sort is several times faster, and
equal keys are equal, so the sort need not be stable.
"""
from __future__ import annotations

import numpy as np


def _unique(values):
    """np.unique(values) of a 1-D integer array by a sort (np.unique's hash table is several times slower
    on the million-entry keys here; equal keys are equal, so the sort need not be stable, and numpy's
    default sort is ~4x faster than its stable one on such keys)."""
    ordered = np.sort(values)
    return ordered[np.concatenate([[True], ordered[1:] != ordered[:-1]])] if len(ordered) else ordered


def _row_counts(*columns):
    """For each row of the columns, how many rows equal it."""
    order = np.lexsort(columns[::-1])
    stacked = np.stack(columns, axis=1)[order]
    starts = np.flatnonzero(np.concatenate([[True], (stacked[1:] != stacked[:-1]).any(axis=1)]))
    sizes = np.diff(np.append(starts, len(order)))
    counts = np.empty(len(order), np.int64)
    counts[order] = np.repeat(sizes, sizes)
    return counts


def _first_rows(*columns):
    """The index of one row per distinct row of the columns."""
    order = np.lexsort(columns[::-1])
    stacked = np.stack(columns, axis=1)[order]
    return order[np.concatenate([[True], (stacked[1:] != stacked[:-1]).any(axis=1)])[:len(order)]]


def _padded(groups, members, n_groups, width=None):
    """(G, width) unique members of each group, ascending, padded with -1."""
    base = members.max() + 1
    group, member = np.divmod(_unique(groups * base + members), base)
    counts = np.bincount(group, minlength=n_groups)
    width = width or counts.max()
    slot = np.arange(len(group)) - np.repeat(np.cumsum(counts) - counts, counts)
    out = np.full(n_groups * width, -1, np.int64)
    out[group * width + slot] = member
    return out.reshape(n_groups, width)


def _lowest_reached(p, q, n):
    """Connected groups of the pairs (p, q) among ids 0 .. n-1: each id's label is the lowest id it reaches."""
    label = np.arange(n)
    while True:
        low = np.minimum(label[p], label[q])
        new = label.copy()
        np.minimum.at(new, p, low)
        np.minimum.at(new, q, low)
        new = new[new]
        if np.array_equal(new, label):
            return label
        label = new
