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

The limit is set for the whole process by ``process.setup_process`` (BLAS
keeps one setting per process), on numpy's BLAS and on scipy's own copy, both
loaded by this module first (a library loaded later would start with a thread
per core); ``blas_threads`` says what is in force.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from concurrent.futures import Future
from contextlib import contextmanager, nullcontext
from functools import lru_cache

import numba
import numpy  # noqa: F401  (loads numpy's BLAS, so that the limit reaches it)
import scipy.linalg  # noqa: F401  (scipy ships its own BLAS: loaded now, it is limited too)
from threadpoolctl import ThreadpoolController, threadpool_info, threadpool_limits

#: BLAS threads the engine runs with.
BLAS_THREADS = 1
#: BLAS threads for one large dense factorisation, which no compiled kernel runs beside: a dense LU of
#: 1,451 unknowns (a clone's boundary) took 103 ms on one thread, 62-70 ms on two.
FACTORISATION_THREADS = 2
#: Unknowns from which a dense factorisation takes ``FACTORISATION_THREADS``.  OpenBLAS's second thread spins
#: for about 0.1 s after the LU returns (2^28 cycles by default), and the compiled kernels that follow on both
#: cores run at half speed or worse meanwhile: the LU must save more than that.  A lady_bug build (its top block
#: about 1,060 unknowns) took 469-629 ms (best-median of 10, alternating) with the LU on one thread and 575-655
#: on two, a paste of 1,451 boundary unknowns 255-337 against 278-320; from about 2,000 unknowns the second
#: thread saves more than 0.1 s.
THREADED_LU = 2000


def limit_blas(threads: int = BLAS_THREADS) -> None:
    """Make every loaded BLAS library use ``threads`` threads from now on (for the whole process)."""
    threadpool_limits(threads, user_api="blas")


def blas_threads() -> list[int]:
    """Threads of every loaded BLAS library, as now set."""
    return [entry["num_threads"] for entry in threadpool_info() if entry["user_api"] == "blas"]


@lru_cache(maxsize=None)
def _controller() -> ThreadpoolController:
    return ThreadpoolController()  # made once: scanning the loaded libraries costs 2 ms


def _set_threads(threads: list[int]) -> None:
    """Set each loaded BLAS library (in ``_blas_libraries`` order) to its number of ``threads``."""
    for library, count in zip(_blas_libraries(), threads):
        # threadpoolctl (>= 3.6) ignores a limit asked from any thread but the first to set one (the main
        # thread, by setup_process), while jobs factorise on threads of their own; _SharedLimit serialises
        # every change this module makes, which is what that rule guards against.
        getattr(library, "_real_set_num_threads", library.set_num_threads)(count)


def _blas_libraries() -> list:
    return _controller().select(user_api="blas").lib_controllers


class _SharedLimit:
    """BLAS raised to ``FACTORISATION_THREADS`` while at least one thread is in ``factorisation_threads``.

    Two jobs may factorise at once (documents opened in two tabs); restoring on each exit, as a plain
    ``threadpool_limits`` context does, would let the first one out lower BLAS under the second, or the last
    one out leave it raised for good.  So the first in raises it and the last out restores it.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._inside = 0
        self._before: list[int] = []

    @contextmanager
    def held(self):
        with self._lock:
            if self._inside == 0:
                self._before = [library.get_num_threads() for library in _blas_libraries()]
                _set_threads([FACTORISATION_THREADS] * len(self._before))
            self._inside += 1
        try:
            yield
        finally:
            with self._lock:
                self._inside -= 1
                if self._inside == 0:
                    _set_threads(self._before)


@lru_cache(maxsize=None)
def _shared_limit() -> _SharedLimit:
    return _SharedLimit()  # one per process, as BLAS's thread setting is


def factorisation_threads(unknowns: int):
    """A context in which BLAS runs on ``FACTORISATION_THREADS`` threads for a dense factorisation of ``unknowns``
    (back to what it was once no thread is inside one any more); below ``THREADED_LU`` it changes nothing."""
    return _shared_limit().held() if unknowns >= THREADED_LU else nullcontext()


def started(work: Callable[[], object], name: str = "fmr-engine-background") -> Future:
    """``work()`` running on a thread of its own; its result (or its exception) from the returned future.

    For a dense factorisation (BLAS, which lets the interpreter go) while the
    calling thread goes on with compiled kernels: the machine's second core
    is otherwise idle under a one-thread LU.  The thread is a daemon: a
    result nobody waits for does not hold the process open.
    """
    future: Future = Future()

    def run() -> None:
        try:
            future.set_result(work())
        except BaseException as error:  # handed to whoever waits for the result
            future.set_exception(error)

    threading.Thread(target=run, name=name, daemon=True).start()
    return future


@contextmanager
def one_thread(when: bool = True):
    """Within the block, numba's parallel loops run on one thread (if ``when``); as many as before afterwards."""
    if not when:
        yield
        return
    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(before)


def beside(work: Future):
    """Within the block, numba's parallel loops run on one thread while ``work`` (a ``started`` job) runs.

    A one-thread factorisation holds one core: kernels on both cores beside it slow it down as much as they
    gain, and what waits for it waits longer (a paste of 20,191 segments: 89-110 ms against 84-99).
    """
    return one_thread(not work.done())
