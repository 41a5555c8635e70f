"""Recursive skeletonization against the dense matrix and the dense solve."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from shapes import scattered_document

from fmr_editor.engine.fmm.lattice import Lattice
from fmr_editor.engine.geometry.discretise import boundary_segments, curve_segments
from fmr_editor.engine.geometry.segments import Segments
from fmr_editor.engine.kernels.potentials import pair_integrals
from fmr_editor.engine.solve import dense as bem
from fmr_editor.engine.solve import skeleton
from fmr_editor.engine.solve.dense import SolveTooLargeError, assemble
from fmr_editor.engine.solve.entries import FAR, CollocationEntries
from fmr_editor.engine.solve.linalg import interpolative
from fmr_editor.engine.solve.skeleton import SkeletonFactorization


@pytest.fixture(scope="module")
def system():
    doc = scattered_document(256, circles=8, seed=7)
    segments = boundary_segments(curve_segments(doc, max_length=2.0), doc, Lattice(5, 256.0).cell_size, 2.0)
    matrix, rhs = assemble(segments)
    return segments, matrix, rhs, np.linalg.solve(matrix, rhs)


def test_entries_equal_the_dense_matrix(system):
    segments, matrix, _, _ = system
    rng = np.random.default_rng(0)
    rows = np.concatenate([rng.choice(len(segments), 40, replace=False), np.flatnonzero(segments.on_border)[:5]])
    columns = np.concatenate([rows[:10], rng.choice(len(segments), 30, replace=False)])
    np.testing.assert_allclose(CollocationEntries(segments).block(rows, columns), matrix[np.ix_(rows, columns)],
                               rtol=1e-12, atol=1e-14)


def test_far_entries_by_their_series_equal_the_closed_form():
    """Around the distance where the entries switch from the closed form to the series, and well beyond."""
    rng = np.random.default_rng(5)
    lengths = np.array([0.3, 1.0, 2.0, 50.0])
    angles = rng.uniform(0, 2 * np.pi, len(lengths))
    p = rng.uniform(100, 200, (len(lengths), 2))
    q = p + lengths[:, None] * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    n = len(p)
    segments = Segments(p, q, np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n, bool), np.zeros((n, 3)))
    for j, h in enumerate(lengths):
        radii = FAR * h * np.repeat([0.5, 0.99, 1.01, 1.5, 4.0, 30.0], 8)
        turns = rng.uniform(0, 2 * np.pi, len(radii))
        targets = 0.5 * (p[j] + q[j]) + radii[:, None] * np.stack([np.cos(turns), np.sin(turns)], axis=1)
        got = CollocationEntries(segments).at(targets, np.array([j]))[:, 0]
        expected = pair_integrals(targets, p[j:j + 1], q[j:j + 1])[0][:, 0]
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-14 * np.abs(expected).max())


@pytest.mark.parametrize("rows", [60, 400], ids=["square", "tall-sketched"])
def test_interpolative_decomposition_finds_the_rank_and_reproduces_the_columns(rows):
    rng = np.random.default_rng(1)
    matrix = rng.normal(size=(rows, 12)) @ rng.normal(size=(12, 50)) + 1e-13 * rng.normal(size=(rows, 50))
    gaussian = np.random.default_rng(2).standard_normal
    skeleton, redundant, T = interpolative(matrix.copy(), 1e-9, lambda rows, columns: gaussian((rows, columns)))
    assert len(skeleton) == 12 and sorted(np.concatenate([skeleton, redundant])) == list(range(50))
    error = np.abs(matrix[:, redundant] - matrix[:, skeleton] @ T).max()
    assert error <= 1e-9 * np.abs(matrix).max()


def test_solution_error_follows_the_compression_tolerance(system):
    segments, _, rhs, exact = system
    errors = []
    for tolerance in (1e-3, 1e-6, 1e-9):
        factor = SkeletonFactorization(segments, tolerance, leaf_size=24, top_size=100)
        assert len(factor.top) <= 0.7 * len(segments)  # it did compress
        errors.append(np.abs(factor.solve(rhs) - exact).max() / np.abs(exact).max())
    assert errors[2] <= 1e-6
    assert all(later < earlier / 100 for earlier, later in zip(errors, errors[1:])), errors


def test_without_compression_it_is_an_exact_lu(system):
    segments, _, rhs, exact = system
    factor = SkeletonFactorization(segments, 1e-8, top_size=len(segments))
    assert not factor.levels
    np.testing.assert_allclose(factor.solve(rhs), exact, rtol=0, atol=1e-10 * np.abs(exact).max())


def test_it_fails_early_when_the_factors_would_not_fit(system, monkeypatch):
    segments = system[0]
    monkeypatch.setattr(bem, "available_memory", lambda: 200_000)
    with pytest.raises(SolveTooLargeError, match="compressed factorisation needs more than"):
        SkeletonFactorization(segments, 1e-8, leaf_size=24, top_size=100)


def test_threads_give_the_serial_factorisation(system, monkeypatch):
    segments, _, rhs, _ = system
    monkeypatch.setattr(skeleton, "THREADED_BOX", 0)  # threads on every level, however small its boxes
    compress, threads = SkeletonFactorization._compress_box, set()

    def spy(*args):
        threads.add(threading.get_ident())
        return compress(*args)

    monkeypatch.setattr(SkeletonFactorization, "_compress_box", spy)
    serial = SkeletonFactorization(segments, 1e-6, leaf_size=24, top_size=100, workers=1)
    assert threads == {threading.get_ident()}
    threaded = SkeletonFactorization(segments, 1e-6, leaf_size=24, top_size=100, workers=2)
    assert len(threads) > 1  # boxes ran on the pool
    assert len(serial.levels) >= 2 and len(threaded.levels) == len(serial.levels)  # it did compress, alike
    np.testing.assert_array_equal(threaded.top, serial.top)
    assert threaded.stored_bytes == serial.stored_bytes
    x = serial.solve(rhs)
    np.testing.assert_allclose(threaded.solve(rhs), x, rtol=0, atol=1e-13 * np.abs(x).max())


@pytest.mark.parametrize("threaded_from", [0, 10**9], ids=["large", "small"])
def test_a_large_top_block_is_factorised_on_the_factorisation_threads_and_blas_is_limited_again_after(
        system, monkeypatch, threaded_from):
    """The top block is one large LU that no kernel runs beside (6,570 unknowns: 6.8 s on one BLAS thread, 4.0
    on two); below ``THREADED_LU`` it stays on one (the second thread's spinning after it would cost more), and
    everything else keeps the engine's one BLAS thread."""
    from fmr_editor.engine import threads
    from fmr_editor.engine.threads import BLAS_THREADS, FACTORISATION_THREADS, blas_threads

    monkeypatch.setattr(threads, "THREADED_LU", threaded_from)
    seen = []
    top_factors = skeleton._top_factors

    def spy(block, size):
        seen.append(blas_threads())
        return top_factors(block, size)

    monkeypatch.setattr(skeleton, "_top_factors", spy)
    SkeletonFactorization(system[0], 1e-6, leaf_size=24, top_size=100)
    assert seen and set(seen[0]) == {FACTORISATION_THREADS if threaded_from == 0 else BLAS_THREADS}
    assert set(blas_threads()) == {BLAS_THREADS}


def test_overlapping_factorisations_on_two_threads_leave_blas_as_it_was_only_when_both_are_done():
    """Two documents may be factorised at once, each on a job's thread (a job per tab): BLAS is raised from those
    threads (threadpoolctl alone ignores any but the main thread), the first one out does not lower it under the
    second, and the last one out does not leave it raised."""
    from fmr_editor.engine import threads as policy
    from fmr_editor.engine.threads import BLAS_THREADS, FACTORISATION_THREADS, blas_threads, factorisation_threads

    first_in, second_in, first_out = threading.Event(), threading.Event(), threading.Event()
    seen = {}

    def first() -> None:
        with factorisation_threads(policy.THREADED_LU):
            first_in.set()
            second_in.wait(10)
        first_out.set()

    def second() -> None:
        first_in.wait(10)
        with factorisation_threads(policy.THREADED_LU):
            second_in.set()
            first_out.wait(10)
            seen["after the first left"] = set(blas_threads())
        seen["after both left"] = set(blas_threads())

    threads = [threading.Thread(target=first), threading.Thread(target=second)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(20)
    assert seen == {"after the first left": {FACTORISATION_THREADS}, "after both left": {BLAS_THREADS}}
