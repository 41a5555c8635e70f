"""An edit's fast path (``cells.propagated`` and the passes it runs) against the plain references."""

from __future__ import annotations

import numpy as np

from fmr_editor.engine.fmm.lattice import (
    Lattice,
    cell_order,
    changed_runs,
    changed_runs_reference,
    cut_into_cells,
    sort_into_cells,
)
from fmr_editor.engine.geometry.segments import Segments

SIDE = 256.0
WIDTH = 16
FIELDS = ("p", "q", "jump", "mean", "on_border", "flux", "origin")


def random_segments(rng, count: int, spread: float = 0.2) -> Segments:
    """Short segments around the canvas centre with random E, C and colours (not cut at cells)."""
    centre = rng.normal(SIDE / 2, spread * SIDE, (count, 2)).clip(1.0, SIDE - 1.0)
    q = (centre + rng.normal(0.0, 2.0, (count, 2))).clip(0.5, SIDE - 0.5)
    origin = np.stack([rng.integers(-1, 5, count).astype(float), rng.uniform(0.0, 3.0, count)], axis=1)
    origin[origin[:, 0] < 0, 1] = np.nan
    return Segments(p=centre, q=q, jump=rng.normal(size=(count, 3)), mean=rng.normal(size=(count, 3)),
                    on_border=rng.random(count) < 0.1, flux=rng.normal(size=(count, 3)), origin=origin)


def cut(segments: Segments, lattice: Lattice) -> Segments:
    """``segments`` cut at the cells, in an order other than the cells' (as a document's boundary comes)."""
    pieces, _ = cut_into_cells(segments, lattice)
    return pieces.take(np.random.default_rng(len(pieces)).permutation(len(pieces)))


def relative(got: np.ndarray, expected: np.ndarray) -> float:
    return float(np.abs(got - expected).max() / np.abs(expected).max())


def test_sorting_into_cells_equals_the_stable_take():
    rng = np.random.default_rng(2)
    lattice = Lattice(5, SIDE)
    segments = random_segments(rng, 3000, spread=0.6)
    outside = rng.uniform(-20.0, SIDE + 20.0, (200, 2))  # clamped to the border cells
    on_edges = rng.integers(0, 32, (200, 2)) * lattice.cell_size
    extra = random_segments(rng, 400)
    segments = Segments(**{name: np.concatenate([getattr(segments, name), getattr(extra, name)]) for name in FIELDS})
    segments = Segments(**{**{name: getattr(segments, name) for name in FIELDS},
                           "p": np.concatenate([segments.p[:-400], outside, on_edges]),
                           "q": np.concatenate([segments.q[:-400], outside, on_edges])})
    order, expected_start = cell_order(segments, lattice)
    expected = segments.take(order)
    got, cell_start = sort_into_cells(segments, lattice)
    assert np.array_equal(cell_start, expected_start)
    for name in FIELDS:
        assert np.array_equal(getattr(got, name), getattr(expected, name), equal_nan=True), name


def test_changed_runs_equal_the_reference():
    rng = np.random.default_rng(3)
    lattice = Lattice(5, SIDE)
    before = cut(random_segments(rng, 1500), lattice)
    flux, p = before.flux.copy(), before.p.copy()
    flux[rng.choice(len(flux), 30, replace=False), rng.integers(0, 3, 30)] += 1e-9  # E of a few
    p[rng.choice(len(p), 10, replace=False)] += 1e-12  # geometry of a few, in place
    keep = np.ones(len(p), bool)
    keep[rng.choice(len(p), 15, replace=False)] = False  # some removed
    after = Segments(**{**{name: getattr(before, name) for name in FIELDS}, "flux": flux, "p": p}).take(keep)
    moved = random_segments(rng, 20)  # some added elsewhere
    after = Segments(**{name: np.concatenate([getattr(after, name), getattr(moved, name)]) for name in FIELDS})
    old, old_start = sort_into_cells(before, lattice)
    new, new_start = sort_into_cells(after, lattice)
    expected = changed_runs_reference(old, old_start, new, new_start)
    assert 40 < len(expected) < 32 * 32 / 2
    assert np.array_equal(changed_runs(old, old_start, new, new_start), expected)
    assert len(changed_runs(old, old_start, old, old_start)) == 0
