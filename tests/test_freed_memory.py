"""Freed arrays go back to the system (``engine.memory.return_freed_arrays``, ``give_back_spare_pages``): a long
session's resident memory follows what it holds (issue 16's soak), instead of keeping the holes its undo cache
leaves, while blocks freed within and between jobs are used again without page faults."""

from __future__ import annotations

import os
import platform
import subprocess
import sys
from pathlib import Path

import pytest

from fmr_editor.engine.memory import return_freed_arrays

REPO = Path(__file__).resolve().parents[1]

# In a fresh process: a 16 MB array freed (glibc's own rule would then raise its threshold to 16 MB), then 1 MB
# arrays with 100 KB blocks between them, as kept undo states leave theirs; the arrays freed, the blocks kept, and
# the end of an engine job (``give_back_spare_pages``).  Then 20 MB arrays (pages of their own) made and freed.
HOLES = """
import numpy as np
import fmr_editor.engine
from fmr_editor.engine.memory import give_back_spare_pages, resident_bytes

fmr_editor.engine.setup_process()
give_back_spare_pages()  # the first job's end: measured from here
big = np.ones(2**21)
del big
start = resident_bytes()
arrays, between = [], []
for _ in range(100):
    arrays.append(np.ones(2**17))
    between.append(bytearray(100_000))
held = resident_bytes()
del arrays
freed = resident_bytes()
given = give_back_spare_pages()
after_job = resident_bytes()
large = [np.ones(20 * 2**17) for _ in range(4)]
del large
print(held - start, freed - start, int(given), after_job - start, resident_bytes() - start)
"""


# Arrays held across the end of a job (the resident memory grew: the first rule gives back, and the arrays are
# the new lowest), then freed, as the undo cache lets states go: the resident memory does not grow, the heap's
# bytes in use fall, and the end of the next job gives their pages back.
LET_GO = """
import numpy as np
import fmr_editor.engine
from fmr_editor.engine.memory import give_back_spare_pages, heap_in_use, resident_bytes

fmr_editor.engine.setup_process()
give_back_spare_pages()
start = resident_bytes()
states = [np.ones(2**17) for _ in range(100)]
kept = [bytearray(100_000) for _ in range(100)]
give_back_spare_pages()
held, in_use = resident_bytes(), heap_in_use()
del states
freed = resident_bytes()
given = give_back_spare_pages()
print(held - start, in_use - heap_in_use(), freed - start, int(given), resident_bytes() - start)
"""


# Freed blocks below the threshold are used again: 30 arrays of 1 MB made, written and freed, then 30 more; the
# end of a job between them gives nothing back (30 MB is within ``SPARE_HEAP``).  Minor page faults of each round.
REUSED = """
import resource
import numpy as np
import fmr_editor.engine
from fmr_editor.engine.memory import give_back_spare_pages

fmr_editor.engine.setup_process()
give_back_spare_pages()


def faults_of_a_round():
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    arrays = [np.ones(2**17) for _ in range(30)]
    del arrays
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before


first = faults_of_a_round()
given = give_back_spare_pages()
print(first, int(given), faults_of_a_round())
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


def _printed(script: str) -> list[int]:
    """The numbers ``script`` prints, run in a fresh process with glibc's own defaults (no ``MALLOC_``)."""
    environment = {key: value for key, value in os.environ.items() if not key.startswith("MALLOC_")}
    environment["PYTHONPATH"] = os.pathsep.join([str(REPO), environment.get("PYTHONPATH", "")])
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, cwd=REPO,
                          env=environment, timeout=120)
    return [int(number) for number in done.stdout.split()]


GLIBC = sys.platform.startswith("linux") and platform.libc_ver()[0] == "glibc"


@pytest.mark.skipif(not GLIBC, reason="glibc's allocator")
def test_freed_arrays_leave_no_resident_holes_after_a_job():
    held, freed, given, after_job, after_large = _printed(HOLES)
    assert held > 100 * 2**20  # the arrays' 100 MB and the blocks' 10 MB were resident while held
    assert freed > 90 * 2**20  # freed between kept blocks: resident, for reuse, until the job's end
    assert given and after_job < 30 * 2**20, f"{after_job / 2**20:.0f} MB stayed resident after the job"
    assert after_large < after_job + 10 * 2**20  # 80 MB in arrays of pages of their own: gone when freed


@pytest.mark.skipif(not GLIBC, reason="glibc's allocator")
def test_arrays_freed_after_a_job_go_back_at_the_next_job_s_end():
    held, fell, freed, given, after_job = _printed(LET_GO)
    assert held > 100 * 2**20 and fell > 95 * 2**20  # held across a job's end, then freed from the heap
    assert freed > 90 * 2**20  # resident between the kept blocks until the next job's end
    assert given and after_job < 30 * 2**20, f"{after_job / 2**20:.0f} MB stayed resident after the next job"


@pytest.mark.skipif(not GLIBC, reason="glibc's allocator")
def test_freed_blocks_within_the_spare_heap_are_used_again_without_page_faults():
    first, given, second = _printed(REUSED)
    assert first > 30 * 256 * 0.9  # the first round touched fresh pages: one fault per 4 kB of its 30 MB
    assert not given  # 30 MB of growth is within SPARE_HEAP: kept
    assert second < 30 * 256 * 0.1, f"{second} page faults making arrays of freed blocks again ({first} the first time)"


@pytest.mark.skipif(not GLIBC, reason="glibc's allocator")
def test_the_environment_s_threshold_stands(monkeypatch):
    assert return_freed_arrays()
    monkeypatch.setenv("MALLOC_MMAP_THRESHOLD_", str(2**20))
    assert not return_freed_arrays()


@pytest.mark.skipif(not GLIBC, reason="glibc's allocator")
def test_free_pages_between_small_arrays_go_back():
    freed, left = _printed(SMALL_HOLES)
    assert freed > 50 * 2**20  # the freed arrays' 60 MB stayed resident between the kept blocks
    assert left < 20 * 2**20, f"{left / 2**20:.0f} MB stayed resident after give_back_free_pages (kept: 8 MB)"


def test_every_job_of_the_engine_ends_by_giving_back_what_the_heap_spares(monkeypatch):
    """``LiveStack``'s jobs (open, update, the blur shown, refine) each end with ``give_back_spare_pages``."""
    from shapes import scattered_document

    from fmr_editor.engine import LiveStack
    from fmr_editor.model import edits

    calls = []
    monkeypatch.setattr("fmr_editor.engine.stack.give_back_spare_pages", lambda: calls.append(1))
    document = scattered_document(64, circles=2, seed=1)
    stack = LiveStack(document)
    moved = edits.translate(document, (1.0, 0.0), curves=[document.curves[0].id])
    stack.update(moved, exact=False)
    stack.refine()
    stack.set_blur(True)
    assert len(calls) == 4


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
