"""The engine's thread policy: BLAS on one thread, numba's compiled kernels on every core.

OpenBLAS and numba's pool each start a thread per core, and both keep
spinning for a while after a call returns.  On a small machine they then
fight for the same cores: numba kernels called right after a BLAS product
ran 20-50x slower (measured on 2 cores).  The engine's matrix products are
small and many (translations, small boxes of the factorisation), so one BLAS
thread loses little, while the kernels that dominate (near fields, Horner
evaluation, sparse passes) keep both cores.  Measured on lady_bug: a build
0.92 -> 0.61 s, a stop-colour edit 61-75 -> 35 ms, a control-point move
0.73 -> 0.47 s.

The limit is set for the whole process when the engine is imported (BLAS
keeps one setting per process); ``blas_threads`` says what is in force.
"""

from __future__ import annotations

from threadpoolctl import threadpool_info, threadpool_limits

#: BLAS threads the engine runs with.
BLAS_THREADS = 1


def limit_blas(threads: int = BLAS_THREADS) -> None:
    """Make every loaded BLAS library use ``threads`` threads from now on (for the whole process)."""
    threadpool_limits(threads, user_api="blas")


def blas_threads() -> list[int]:
    """Threads of every loaded BLAS library, as now set."""
    return [entry["num_threads"] for entry in threadpool_info() if entry["user_api"] == "blas"]
