"""The engine's settings for the whole process, made by one explicit call.

``setup_process`` limits BLAS to one thread (``threads``: on two cores, numba's
kernels ran 20-50x slower right after a threaded BLAS call), gives large
arrays pages of their own and keeps some free heap for reuse
(``memory.return_freed_arrays``: freed arrays otherwise stayed resident, or
paid page faults again) and keeps the modules' objects out of the garbage
collector's full passes (``memory.freeze_loaded_objects``).  Importing the engine changes neither, so that a
script that only reads a file keeps its process as it was; the command line,
the editor, the benchmarks and the test suite call it before any work, and a
script that builds or edits documents should too.
"""

from __future__ import annotations

from .memory import freeze_loaded_objects, return_freed_arrays
from .threads import limit_blas


def setup_process() -> None:
    """Set the engine's thread and memory policy for this process (idempotent)."""
    limit_blas()
    return_freed_arrays()
    freeze_loaded_objects()
