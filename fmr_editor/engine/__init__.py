"""The FMR engine: discretisation, boundary solve, FMM passes, rasterising.

Synchronous and free of Qt and OpenGL.  Every fast path has a plain
reference beside it (``layers`` for ``kernels``, the direct sum for the FMR).
"""

from .threads import limit_blas

limit_blas()  # before any work: see threads.py for why one BLAS thread is faster here

from .live import LiveRepresentation, Update, build  # noqa: E402
from .raster import evaluate_points, output_size, rasterise  # noqa: E402
from .representation import Representation, Settings  # noqa: E402

__all__ = [
    "LiveRepresentation", "Representation", "Settings", "Update", "build", "evaluate_points", "output_size", "rasterise",
]
