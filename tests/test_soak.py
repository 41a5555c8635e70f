"""A short soak (``soak.py``): random edits, undos and redos stay equal to fresh builds, memory flat."""

from __future__ import annotations

from dataclasses import replace

from shapes import scattered_document
from soak import PIXEL, soak

from fmr_editor.model import BlurStop


def test_random_edits_undos_and_redos_stay_equal_to_fresh_builds():
    document = scattered_document(96, circles=4, seed=3)
    blurred = replace(document.curves[0], blur=(BlurStop(0.0, 1.5), BlurStop(1.0, 4.0)))  # the picture is drawn blurred
    checks = soak(document.with_curves((blurred,) + document.curves[1:]), steps=300, check_every=100, seed=11)
    assert [step for step, _, _ in checks] == [100, 200, 300]
    assert max(difference for _, difference, _ in checks) <= PIXEL, checks
    assert checks[-1][2] - checks[0][2] < 200 * 2**20  # resident growth after the first check
