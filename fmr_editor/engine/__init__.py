"""The FMR engine: a document in, its fast multipole representation and pixels out.

Synchronous and free of Qt and OpenGL.  The sub-packages build on each
other from the bottom up (an import-linter contract keeps that order)::

    geometry -> kernels -> fmm -> solve | points -> representation -> composite -> raster -> live | cloning -> stack

``docs/architecture.md`` draws the data flow.  What the rest of the program
uses is exported here; everything else is the engine's own.  Every fast path
has a plain reference beside it (``*_reference``), which the tests compare.
"""

from .memory import return_freed_arrays
from .threads import limit_blas

limit_blas()  # before any work: see threads.py for why one BLAS thread is faster here
return_freed_arrays()  # before any work: see memory.py for why freed arrays stayed resident

from .composite import Composite, LayerFields  # noqa: E402
from .fmm.expansions import local_polynomials  # noqa: E402
from .fmm.lattice import Lattice  # noqa: E402
from .geometry.segments import Segments  # noqa: E402
from .live import LiveRepresentation, Progress, Update  # noqa: E402
from .memory import available_memory, check_image_memory  # noqa: E402
from .points.field import PointField  # noqa: E402
from .points.gauss import GaussPoints  # noqa: E402
from .raster import evaluate_points, output_size, rasterise  # noqa: E402
from .representation import MAX_LEVELS, Representation, Settings  # noqa: E402
from .cloning import clone_points  # noqa: E402
from .solve.clone import SeamlessClone, Similarity  # noqa: E402
from .stack import LiveStack, StackUpdate, build, composite_of  # noqa: E402

__all__ = [
    "MAX_LEVELS", "Composite", "GaussPoints", "LayerFields", "Lattice", "LiveRepresentation", "LiveStack",
    "PointField", "Progress", "Representation", "SeamlessClone", "Segments", "Settings", "Similarity", "StackUpdate",
    "Update", "build",
    "available_memory", "check_image_memory", "clone_points", "composite_of", "evaluate_points", "local_polynomials",
    "output_size", "rasterise",
]
