"""Degenerate geometry in the boundary solve (issue 16): tiny, zero-length and coinciding segments.

Each case solves (the fast path against the plain dense solve) or is refused
with a ``ValueError``; none raises ``numpy.linalg.LinAlgError``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from shapes import scattered_document

from fmr_editor.engine import build
from fmr_editor.engine.fmm.lattice import Lattice
from fmr_editor.engine.geometry.discretise import boundary_segments, curve_segments
from fmr_editor.engine.geometry.segments import Segments
from fmr_editor.engine.solve import solver as fast_solve
from fmr_editor.engine.solve.dense import SingularSystemError, solve_dense
from fmr_editor.engine.solve.skeleton import SkeletonFactorization
from fmr_editor.io import load_document

HOSTILE = Path(__file__).parent / "data" / "hostile"
LATTICE = Lattice(4, 128.0)


@pytest.fixture(scope="module")
def base() -> Segments:
    doc = scattered_document(128, circles=4, seed=3)
    return boundary_segments(curve_segments(doc, max_length=2.0), doc, LATTICE.cell_size, 2.0)


def with_curve_segments(segments: Segments, p, q) -> Segments:
    """``segments`` and more curve segments from ``p`` to ``q``, each with a colour jump and a mean."""
    p, q = np.asarray(p, float), np.asarray(q, float)
    n = len(p)
    more = Segments(p, q, np.tile([1.0, 0.5, 0.0], (n, 1)), np.tile([0.5, 0.2, 0.1], (n, 1)), np.zeros(n, bool),
                    np.zeros((n, 3)))
    fields = ("p", "q", "jump", "mean", "on_border", "flux")
    return Segments(*(np.concatenate([getattr(segments, f), getattr(more, f)]) for f in fields))


def solved(segments: Segments, fast: bool, monkeypatch) -> np.ndarray:
    monkeypatch.setattr(fast_solve, "DENSE_CROSSOVER", 10 if fast else 10**6)
    return fast_solve.solve_boundary(segments, LATTICE).unknowns()


@pytest.mark.parametrize("length", [0.0, 1e-14], ids=["zero-length", "1e-14"])
@pytest.mark.parametrize("fast", [True, False], ids=["fast", "dense"])
def test_segments_as_short_as_a_point_take_no_part(base, length, fast, monkeypatch):
    p = [[40.0, 40.0], [40.0, 40.0], [70.0, 20.0]]
    segments = with_curve_segments(base, p, np.asarray(p) + [length, 0.0])
    unknowns = solved(segments, fast, monkeypatch)
    expected = solve_dense(base).unknowns()
    assert np.isfinite(unknowns).all()
    np.testing.assert_array_equal(unknowns[len(base):], 0.0)
    assert np.abs(unknowns[: len(base)] - expected).max() <= 1e-6 * np.abs(expected).max()


def test_tiny_segments_are_solved_like_the_dense_solve(base, monkeypatch):
    y = 40 + 1e-9 * np.arange(61)
    segments = with_curve_segments(base, np.c_[np.full(60, 40.0), y[:-1]], np.c_[np.full(60, 40.0), y[1:]])
    fast = solved(segments, True, monkeypatch)
    expected = solve_dense(segments).unknowns()
    assert np.isfinite(fast).all()
    assert np.abs(fast - expected).max() <= 1e-6 * np.abs(expected).max()


@pytest.fixture
def coinciding(base) -> Segments:
    """Twenty copies of one segment: identical rows and columns, a singular system."""
    return with_curve_segments(base, [[30.0, 30.0]] * 20, [[31.0, 30.5]] * 20)


def test_the_factorisation_of_a_singular_system_says_so_as_a_value_error(coinciding):
    with pytest.raises(SingularSystemError, match="singular") as raised:
        SkeletonFactorization(coinciding, 1e-6, leaf_size=16, top_size=40)
    assert isinstance(raised.value, ValueError) and not isinstance(raised.value, np.linalg.LinAlgError)


def test_coinciding_segments_are_shared_out_as_the_dense_solve_does(coinciding, monkeypatch):
    fast = solved(coinciding, True, monkeypatch)
    dense = solved(coinciding, False, monkeypatch)
    assert np.isfinite(fast).all()
    np.testing.assert_allclose(fast, dense, rtol=0, atol=1e-9 * np.abs(dense).max())
    np.testing.assert_allclose(fast[-20:], np.tile(fast[-1], (20, 1)), rtol=1e-9)  # the same density on every copy


def test_a_singular_system_too_large_to_solve_densely_is_refused(coinciding, monkeypatch):
    monkeypatch.setattr(fast_solve, "DENSE_FALLBACK", 100)
    with pytest.raises(ValueError, match="system is singular"):
        solved(coinciding, True, monkeypatch)


def test_tiny_curves_file_builds_as_the_dense_solve_does(monkeypatch):
    document = load_document(HOSTILE / "tiny-curves.xml")
    fast = build(document)
    assert len(fast.segments) > fast_solve.DENSE_CROSSOVER  # the compressed factorisation's case
    # Each tiny segment's density E is ill-determined on its own; its flux E h (what its field depends on) is not.
    weight = np.where(fast.segments.on_border, 1.0, fast.segments.lengths)[:, None]
    expected = solve_dense(fast.segments).unknowns() * weight
    got = fast.segments.unknowns() * weight
    assert np.isfinite(got).all()
    assert np.abs(got - expected).max() <= 1e-6 * np.abs(expected).max()
