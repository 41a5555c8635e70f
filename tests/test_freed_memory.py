"""Freed arrays go back to the system (``engine.memory.return_freed_arrays``, ``give_back_free_pages``): a long
session's resident memory follows what it holds (issue 16's soak), instead of keeping the holes its undo cache
leaves."""

from __future__ import annotations

import os
import platform
import subprocess
import sys
from pathlib import Path

import pytest

from fmr_editor.engine.kept_states import KeptStates
from fmr_editor.engine.memory import return_freed_arrays

REPO = Path(__file__).resolve().parents[1]

# In a fresh process: a 16 MB array freed (glibc's own rule would then raise its threshold to 16 MB), then 1 MB
# arrays with 100 KB blocks between them, as kept undo states leave theirs; the arrays freed, the blocks kept.
HOLES = """
import numpy as np
import fmr_editor.engine

fmr_editor.engine.setup_process()


def resident():
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) * 1024 for line in status if line.startswith("VmRSS:"))


big = np.ones(2**21)
del big
start = resident()
arrays, between = [], []
for _ in range(100):
    arrays.append(np.ones(2**17))
    between.append(bytearray(100_000))
held = resident()
del arrays
print(held - start, resident() - start)
"""


# Arrays below the threshold (a small file's, 120 KB) stay in glibc's heap: freed between kept blocks (16 KB, too
# big for the free pieces the imports left), their pages stay resident until ``give_back_free_pages``.
SMALL_HOLES = """
import numpy as np
from fmr_editor.engine.memory import give_back_free_pages


def resident():
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) * 1024 for line in status if line.startswith("VmRSS:"))


start = resident()
arrays, between = [], []
for _ in range(500):
    arrays.append(np.ones(15_000))
    between.append(np.ones(2_000))
del arrays
freed = resident()
give_back_free_pages()
print(freed - start, resident() - start)
"""


def _held_and_left(script: str = HOLES) -> tuple[int, int]:
    """The two numbers ``script`` prints, run in a fresh process with glibc's own defaults (no ``MALLOC_``)."""
    environment = {key: value for key, value in os.environ.items() if not key.startswith("MALLOC_")}
    environment["PYTHONPATH"] = os.pathsep.join([str(REPO), environment.get("PYTHONPATH", "")])
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, cwd=REPO,
                          env=environment, timeout=120)
    held, left = map(int, done.stdout.split())
    return held, left


GLIBC = sys.platform.startswith("linux") and platform.libc_ver()[0] == "glibc"


@pytest.mark.skipif(not GLIBC, reason="glibc's allocator")
def test_freed_arrays_leave_no_resident_holes():
    held, left = _held_and_left()
    assert held > 100 * 2**20  # the arrays' 100 MB and the blocks' 10 MB were resident while held
    assert left < 30 * 2**20, f"{left / 2**20:.0f} MB stayed resident: the freed arrays' 100 MB did"


@pytest.mark.skipif(not GLIBC, reason="glibc's allocator")
def test_the_environment_s_threshold_stands(monkeypatch):
    assert return_freed_arrays()
    monkeypatch.setenv("MALLOC_MMAP_THRESHOLD_", str(2**20))
    assert not return_freed_arrays()


@pytest.mark.skipif(not GLIBC, reason="glibc's allocator")
def test_free_pages_between_small_arrays_go_back():
    freed, left = _held_and_left(SMALL_HOLES)
    assert freed > 50 * 2**20  # the freed arrays' 60 MB stayed resident between the kept blocks
    assert left < 20 * 2**20, f"{left / 2**20:.0f} MB stayed resident after give_back_free_pages (kept: 8 MB)"


class _FakeState:
    """What ``KeptStates`` reads of a state: its size and its document."""

    def __init__(self, nbytes: int) -> None:
        self.nbytes, self.document = nbytes, object()


def test_the_undo_cache_gives_back_what_it_lets_go(monkeypatch):
    """``KeptStates`` calls ``give_back_free_pages`` when it lets states go, and only then."""
    calls = []
    monkeypatch.setattr("fmr_editor.engine.kept_states.give_back_free_pages", lambda: calls.append(1))
    kept = KeptStates(memory=100)
    for size in (60, 30, 50):
        kept.keep(_FakeState(size))
    assert len(kept) == 2 and calls == [1]  # the third state (60 + 30 + 50 > 100) let the first go


def test_setup_freezes_the_objects_alive_then_once_and_nothing_made_later():
    """``setup_process`` (the session's, as the editor's before any document) froze the objects alive then out
    of the collector's full passes; called again it freezes nothing made since: a cycle of a closed document's
    objects must stay collectable."""
    import gc

    from fmr_editor.engine import setup_process

    frozen = gc.get_freeze_count()
    assert frozen > 10_000
    cycles = [{} for _ in range(1000)]
    for item in cycles:
        item["self"] = item
    setup_process()
    assert gc.get_freeze_count() == frozen
    del cycles, item
    assert gc.collect() >= 1000
