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


@pytest.fixture(scope="module")
def seeds(tmp_path_factory) -> dict[str, bytes]:
    """The files mutated: the sample XML and a ``.fmr`` of it with its representation."""
    document = load_document(RIBBON)
    saved = save_fmr(tmp_path_factory.mktemp("seeds") / "ribbon.fmr", document, build(document))
    return {".xml": RIBBON.read_bytes(), ".fmr": saved.read_bytes()}


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


def test_every_mutation_changes_the_file_and_is_reproducible(seeds):
    for suffix, data in seeds.items():
        for seed in range(40):
            kind, first = mutated(data, suffix, seed)
            assert mutated(data, suffix, seed) == (kind, first)
            assert first != data or kind in ("json_value", "member_array"), (suffix, seed, kind)
