"""The FMR on real diffusion-curve files: against the direct sum and an independent render."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from fmr_editor import load
from fmr_editor.engine import Representation, build, rasterise
from fmr_editor.engine.solve import solver as fast_solve
from fmr_editor.engine.solve.dense import solve_dense

#: File and output size: half the canvas (a pixel every 2 document pixels, 4 to a lattice cell); the direct sum
#: over every segment at all of lady_bug's 512 x 512 pixels took 15 s of the suite's 10 minutes.
FILES = [("lady_bug.xml", 256), ("zephyr.xml", 256), ("poivron.xml", 256)]
ONE_LEVEL = 1.0 / 255.0


@lru_cache(maxsize=None)
def representation(path: Path) -> Representation:
    """One build per file for the whole module (the dense solve takes seconds)."""
    return build(load(path))


@pytest.fixture(scope="module", params=FILES, ids=[name for name, _ in FILES])
def solved(request, shared_data):
    name, size = request.param
    rep = representation(shared_data / "orzan_xml" / "berkbavas" / name)
    direct = rasterise(rep, size, size, samples=1, method="direct")
    return rep, size, direct


def test_fmr_matches_the_direct_sum_at_every_pixel(solved):
    rep, size, direct = solved
    fmr = rasterise(rep, size, size, samples=1)
    assert np.abs(fmr - direct).max() <= ONE_LEVEL


def test_fmr_error_falls_as_the_order_rises(solved):
    rep, size, direct = solved
    errors = [np.abs(rasterise(rep, size, size, samples=1, order=order) - direct).max() for order in (2, 4, 6, 8)]
    assert all(later < earlier / 3 for earlier, later in zip(errors, errors[1:])), errors


def test_lady_bug_matches_an_independent_ray_traced_render(shared_data):
    reference = np.asarray(Image.open(shared_data / "reference_renders" / "lb128.jpg").convert("RGB"), float) / 255
    rep = representation(shared_data / "orzan_xml" / "berkbavas" / "lady_bug.xml")
    image = np.clip(rasterise(rep, 512, 512, samples=3), 0.0, 1.0)
    assert reference.shape == image.shape
    assert np.abs(image - reference).mean() <= 0.025


def test_fast_solve_matches_the_dense_solve(shared_data):
    rep = representation(shared_data / "orzan_xml" / "berkbavas" / "poivron.xml")
    assert len(rep.segments) > fast_solve.DENSE_CROSSOVER  # built by the fast solve
    expected = solve_dense(rep.segments).unknowns()
    assert np.abs(rep.segments.unknowns() - expected).max() <= 1e-6 * np.abs(expected).max()
