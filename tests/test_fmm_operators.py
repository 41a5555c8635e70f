"""Each FMM operator against the direct sum at well-separated points (docs/design.md section 3)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from shapes import circle_points

from fmr_editor.engine import Settings, build
from fmr_editor.engine.fmm.expansions import (
    evaluate_local,
    evaluate_multipole,
    l2l_matrix,
    m2l_matrix,
    m2m_matrix,
    multipole_moments_reference,
)
from fmr_editor.engine.fmm.lattice import interaction_offsets, offset_parities
from fmr_editor.engine.kernels.potentials import direct_sum_reference
from fmr_editor.model import ColorStop, DiffusionCurve, Document

ORDER = 24


def sources_in_cell(rng, centre, size, count=40):
    """Short random segments inside the square cell around ``centre``."""
    p = centre + rng.uniform(-0.45, 0.45, (count, 2)) * size
    q = np.clip(p + rng.normal(0, 0.05 * size, (count, 2)), centre - size / 2, centre + size / 2)
    return p, q, rng.normal(size=(count, 3)), rng.normal(size=(count, 3))


def points_in_cell(rng, centre, size, count=50):
    return centre + rng.uniform(-0.5, 0.5, (count, 2)) * size


def as_complex(point):
    return complex(point[0], point[1])


def direct(targets, p, q, flux, jump):
    return direct_sum_reference(targets, p, q, flux, jump)


def multipole_of(p, q, flux, jump, centre, size, order=ORDER):
    return multipole_moments_reference(p, q, flux, jump, np.broadcast_to(centre, p.shape), size, order).sum(axis=0)


def relative_error(got, expected):
    return np.abs(got - expected).max() / np.abs(expected).max()


def test_p2m_matches_direct_sum_far_away():
    rng = np.random.default_rng(1)
    centre, size = np.array([10.0, 20.0]), 4.0
    p, q, flux, jump = sources_in_cell(rng, centre, size)
    moments = multipole_of(p, q, flux, jump, centre, size)
    angles = rng.uniform(0, 2 * np.pi, 60)
    targets = centre + 3 * size * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    got = evaluate_multipole(moments, as_complex(centre), size, targets @ [1, 1j])
    assert relative_error(got, direct(targets, p, q, flux, jump)) <= 1e-12


def test_m2m_shifts_children_to_their_parent():
    rng = np.random.default_rng(2)
    parent_centre, parent_size = np.array([50.0, 50.0]), 8.0
    total = np.zeros((3, ORDER + 1), complex)
    sources = []
    for px, py in itertools.product((0, 1), repeat=2):
        offset = complex((px - 0.5) / 2, (py - 0.5) / 2)
        child_centre = parent_centre + parent_size * np.array([offset.real, offset.imag])
        p, q, flux, jump = sources_in_cell(rng, child_centre, parent_size / 2)
        sources.append((p, q, flux, jump))
        total += multipole_of(p, q, flux, jump, child_centre, parent_size / 2) @ m2m_matrix(offset, ORDER)
    p, q, flux, jump = (np.concatenate(part) for part in zip(*sources))
    angles = rng.uniform(0, 2 * np.pi, 60)
    targets = parent_centre + 3 * parent_size * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    got = evaluate_multipole(total, as_complex(parent_centre), parent_size, targets @ [1, 1j])
    assert relative_error(got, direct(targets, p, q, flux, jump)) <= 1e-10


@pytest.mark.parametrize("offset", [(3, 2), (-3, -3), (2, -1)])
def test_m2l_matches_direct_sum_inside_the_target_cell(offset):
    rng = np.random.default_rng(3)
    size = 2.5
    target_centre = np.array([30.0, 40.0])
    source_centre = target_centre + size * np.array(offset)
    p, q, flux, jump = sources_in_cell(rng, source_centre, size)
    moments = multipole_of(p, q, flux, jump, source_centre, size)
    local = moments @ m2l_matrix(complex(*offset), ORDER, float(np.log(size)))
    targets = points_in_cell(rng, target_centre, size)
    got = evaluate_local(local, as_complex(target_centre), size, targets @ [1, 1j])
    # worst geometry of an interaction list, (2, -1): converges like about 0.6^order
    bound = 1e-5 if offset == (2, -1) else 1e-9
    assert relative_error(got, direct(targets, p, q, flux, jump)) <= bound


def test_m2l_error_falls_with_order():
    rng = np.random.default_rng(4)
    size, target_centre = 1.0, np.array([0.0, 0.0])
    source_centre = np.array([2.0, 0.0])
    p, q, flux, jump = sources_in_cell(rng, source_centre, size)
    targets = points_in_cell(rng, target_centre, size)
    expected = direct(targets, p, q, flux, jump)
    errors = []
    for order in (4, 8, 16, 24):
        local = multipole_of(p, q, flux, jump, source_centre, size, order) @ m2l_matrix(2.0, order, 0.0)
        errors.append(relative_error(evaluate_local(local, 0j, size, targets @ [1, 1j]), expected))
    assert all(later < earlier / 4 for earlier, later in zip(errors, errors[1:]))


def test_l2l_is_exact_for_the_shifted_polynomial():
    rng = np.random.default_rng(5)
    parent_centre, parent_size = np.array([5.0, 5.0]), 2.0
    local = rng.normal(size=(3, ORDER + 1)) + 1j * rng.normal(size=(3, ORDER + 1))
    local *= 0.5 ** np.arange(ORDER + 1)
    for px, py in itertools.product((0, 1), repeat=2):
        offset = complex((px - 0.5) / 2, (py - 0.5) / 2)
        child_centre = parent_centre + parent_size * np.array([offset.real, offset.imag])
        child = local @ l2l_matrix(offset, ORDER)
        targets = points_in_cell(rng, child_centre, parent_size / 2)
        got = evaluate_local(child, as_complex(child_centre), parent_size / 2, targets @ [1, 1j])
        expected = evaluate_local(local, as_complex(parent_centre), parent_size, targets @ [1, 1j])
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)


def test_interaction_lists_partition_the_far_field():
    """Every pair of fine cells meets exactly once: as neighbours, or at one level's interaction list."""
    levels = 5
    cells = list(itertools.product(range(2**levels), repeat=2))
    offsets = {(px, py): set(interaction_offsets(px, py)) for px in (0, 1) for py in (0, 1)}
    assert all(len(members) == 27 for members in offsets.values())
    for target in cells[::7]:
        for source in cells:
            meetings = int(max(abs(target[0] - source[0]), abs(target[1] - source[1])) <= 1)
            for level in range(2, levels + 1):
                shift = levels - level
                tx, ty = target[0] >> shift, target[1] >> shift
                sx, sy = source[0] >> shift, source[1] >> shift
                meetings += (sx - tx, sy - ty) in offsets[(tx % 2, ty % 2)]
            assert meetings == 1, (target, source)


def test_cell_polynomials_hold_the_far_field_of_the_lattice():
    """The whole pipeline: a fine cell's polynomial equals the direct sum over segments outside its 3x3 block."""
    rng = np.random.default_rng(6)
    curves = []
    for _ in range(6):
        stops = tuple(ColorStop(s, tuple(rng.random(3))) for s in (0.0, 1.5, 3.0))
        curves.append(DiffusionCurve(circle_points(*rng.uniform(20, 108, 2), rng.uniform(5, 30)), left=stops,
                                     right=stops[::-1]))
    rep = build(Document(128, 128, curves), Settings(levels=4, order=16))
    poly = rep.polynomials()
    seg, lattice = rep.segments, rep.lattice
    seg_cells = lattice.cell_of(seg.midpoints)
    degrees = np.arange(poly.shape[-1])
    for row, column in [(0, 0), (5, 9), (15, 3), (8, 8)]:
        centre = (np.array([column, row]) + 0.5) * lattice.cell_size
        targets = points_in_cell(rng, centre, lattice.cell_size, 20)
        xi, eta = ((targets - centre) / lattice.cell_size).T
        got = np.einsum("cij,mi,mj->mc", poly[row, column], xi[:, None] ** degrees, eta[:, None] ** degrees)
        far = np.abs(seg_cells - [row, column]).max(axis=1) > 1
        expected = direct(targets, seg.p[far], seg.q[far], seg.flux[far], seg.jump[far])
        assert np.abs(got - expected).max() <= 1e-6


def test_compiled_cell_moments_equal_the_summed_reference():
    from fmr_editor.engine.fmm.lattice import Lattice, sort_into_cells
    from fmr_editor.engine.fmm.moments import cell_moments
    from fmr_editor.engine.geometry.segments import Segments

    rng = np.random.default_rng(7)
    lattice = Lattice(3, 40.0)
    p = rng.uniform(0, 40, (300, 2))
    q = np.clip(p + rng.normal(0, 0.8, (300, 2)), 0, 40)
    seg = Segments(p, q, rng.normal(size=(300, 3)), rng.normal(size=(300, 3)), np.zeros(300, bool),
                   rng.normal(size=(300, 3)))
    seg, start = sort_into_cells(seg, lattice)
    rows, columns = np.divmod(np.arange(64), 8)
    centres = lattice.cell_centres(np.stack([rows, columns], axis=1))
    got = cell_moments(start, centres, lattice.cell_size, seg.p, seg.q, seg.flux, seg.jump, ORDER)
    cells = lattice.cell_of(seg.midpoints)
    per_segment = multipole_moments_reference(seg.p, seg.q, seg.flux, seg.jump, lattice.cell_centres(cells),
                                              lattice.cell_size, ORDER)
    expected = np.zeros_like(got)
    np.add.at(expected, cells[:, 0] * 8 + cells[:, 1], per_segment)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)


def m2l_matrix_reference(offset: complex, order: int, log_size: float) -> np.ndarray:
    """Term by term: ``T[0, 0] = ln(-d) + ln r``, ``T[k, 0] = (-1)^k / d^k``, ``T[0, l] = -1 / (l d^l)``,
    ``T[k, l] = (-1)^k C(l + k - 1, k - 1) / d^(l + k)``."""
    t = np.zeros((order + 1, order + 1), complex)
    t[0, 0] = np.log(-offset) + log_size
    for k in range(1, order + 1):
        t[k, 0] = (-1.0) ** k / offset**k
        t[0, k] = -1.0 / (k * offset**k)
        for l in range(1, order + 1):
            t[k, l] = (-1.0) ** k * math.comb(l + k - 1, k - 1) / offset ** (l + k)
    return t


@pytest.mark.parametrize("log_size", [0.0, 2.3, -1.1])
def test_m2l_matrix_equals_its_terms_at_every_offset_of_the_passes(log_size):
    for dx, dy in offset_parities()[0]:
        offset = complex(int(dx), int(dy))
        expected = m2l_matrix_reference(offset, 24, log_size)
        np.testing.assert_allclose(m2l_matrix(offset, 24, log_size), expected, rtol=1e-13, atol=0)
