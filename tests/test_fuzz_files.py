"""Our own fuzzing: mutated sample files (``mutations.py``) open and render finite colours, or give the
documented error; nothing else (a traceback, a NaN pixel) passes.  ``bench/fuzz_campaign.py`` runs the
same mutations by the ten thousand in worker processes with memory and time limits.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mutations import mutated, outcome

from fmr_editor.engine import build
from fmr_editor.io import load_document, save_fmr

RIBBON = Path(__file__).resolve().parents[1] / "resources" / "samples" / "ribbon.xml"
EXAMPLES = 60
#: An SVG of what import reads: a filled path with a hole, an arc, a transformed shape, line art.
DRAWING = (b'<svg xmlns="http://www.w3.org/2000/svg" width="96" height="64" viewBox="0 0 192 128">'
           b'<path fill-rule="evenodd" fill="#c04020" d="M 10 10 L 90 10 L 90 90 L 10 90 Z M 30 30 L 70 30 '
           b'L 70 70 L 30 70 Z"/><g transform="rotate(-20 140 60)"><ellipse cx="140" cy="60" rx="40" ry="20" '
           b'fill="#30a070" stroke="#102030"/></g><path d="M 5 120 Q 90 60 185 120 A 30 20 0 0 1 150 100" '
           b'stroke="#f0f0ff" fill="none"/></svg>')


@pytest.fixture(scope="module")
def seeds(tmp_path_factory) -> dict[str, bytes]:
    """The files mutated: the sample XML and a ``.fmr`` of it with its representation."""
    document = load_document(RIBBON)
    saved = save_fmr(tmp_path_factory.mktemp("seeds") / "ribbon.fmr", document, build(document))
    return {".xml": RIBBON.read_bytes(), ".fmr": saved.read_bytes(), ".svg": DRAWING}


def check(seeds: dict[str, bytes], suffix: str, seed: int, folder: Path) -> None:
    kind, data = mutated(seeds[suffix], suffix, seed)
    path = folder / f"{kind}-{seed}{suffix}"
    path.write_bytes(data)
    try:
        assert outcome(path) in ("accepted", "refused")
    finally:
        path.unlink()


@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**32 - 1))
def test_mutated_orzan_files_open_finite_or_give_the_load_error(seeds, tmp_path, seed):
    check(seeds, ".xml", seed, tmp_path)


@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**32 - 1))
def test_mutated_fmr_files_open_finite_or_give_the_load_error(seeds, tmp_path, seed):
    check(seeds, ".fmr", seed, tmp_path)


@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**32 - 1))
def test_mutated_svg_files_open_finite_or_give_the_load_error(seeds, tmp_path, seed):
    check(seeds, ".svg", seed, tmp_path)


def test_every_mutation_changes_the_file_and_is_reproducible(seeds):
    for suffix, data in seeds.items():
        for seed in range(40):
            kind, first = mutated(data, suffix, seed)
            assert mutated(data, suffix, seed) == (kind, first)
            assert first != data or kind in ("json_value", "member_array"), (suffix, seed, kind)
