"""The FMR engine: discretisation, boundary solve, FMM passes, rasterising.

Synchronous and free of Qt and OpenGL.  Every fast path has a plain
reference beside it (``layers`` for ``kernels``, the direct sum for the FMR).
"""

from .live import LiveRepresentation, Update, build
from .raster import evaluate_points, output_size, rasterise
from .representation import Representation, Settings

__all__ = [
    "LiveRepresentation", "Representation", "Settings", "Update", "build", "evaluate_points", "output_size", "rasterise",
]
