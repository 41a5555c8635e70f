"""An edit's fast path (``cells.propagated`` and the passes it runs) against the plain references."""

from __future__ import annotations

import numpy as np
import pytest

from fmr_editor.engine.cells import largest_part
from fmr_editor.engine.fmm import orders
from fmr_editor.engine.fmm.lattice import (
    Lattice,
    cell_order,
    changed_runs,
    changed_runs_reference,
    coarser_multipoles,
    cut_into_cells,
    downward_pass,
    sort_into_cells,
)
from fmr_editor.engine.fmm.passes import downward_onto, level_sources
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


def random_delta(rng, cells: np.ndarray, n: int) -> np.ndarray:
    """Random multipoles ``(len(cells), 3, WIDTH + 1)`` of the size real ones fall off with."""
    shape = (len(cells), 3, WIDTH + 1)
    return (rng.normal(size=shape) + 1j * rng.normal(size=shape)) * 0.3 ** np.arange(WIDTH + 1)


@pytest.mark.parametrize("chosen", [False, True])
@pytest.mark.parametrize("count", [1, 6, 60, 3000])  # one cell; a few (corners, borders); sparse; most (grids)
def test_a_change_goes_down_onto_the_local_expansions_as_the_plain_pass(count, chosen):
    rng = np.random.default_rng(count)
    lattice = Lattice(6, SIDE)
    n = lattice.cells_per_side
    pass_orders = orders.pass_orders(6, 8, WIDTH) if chosen else orders.uniform_orders(6, WIDTH)
    corners = np.array([0, n - 1, n * (n - 1), n * n - 1, n // 2, n * n // 2])  # the edges of the index maps
    cells = np.unique(np.concatenate([corners[:count], rng.choice(n * n, max(count - 6, 0), replace=False)]))
    moments = random_delta(rng, cells, n)
    terms = 9 if chosen else WIDTH + 1
    base = rng.normal(size=(n, n, 3, terms)) + 1j * rng.normal(size=(n, n, 3, terms))
    local, change = downward_onto(level_sources(moments, np.arange(len(cells)), cells, lattice, pass_orders),
                                  lattice, pass_orders, base)
    delta = np.zeros((n * n, 3, WIDTH + 1), complex)
    delta[cells] = moments
    expected = downward_pass(coarser_multipoles(delta.reshape(n, n, 3, -1), WIDTH), lattice, WIDTH,
                             pass_orders if chosen else None)[..., :terms]
    assert relative(local - base, expected) < 1e-12
    assert np.abs(change - largest_part(expected, axis=(2, 3))).max() < 1e-12 * np.abs(expected).max()
