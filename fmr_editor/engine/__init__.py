"""The FMR engine: a document in, its fast multipole representation and pixels out.

Synchronous and free of Qt and OpenGL.  The sub-packages build on each
other from the bottom up (an import-linter contract keeps that order)::

    geometry -> kernels -> fmm -> solve | points -> representation -> composite -> raster -> live | cloning -> stack

``docs/architecture.md`` draws the data flow.  What the rest of the program
uses is exported here; everything else is the engine's own.  Every fast path
has a plain reference beside it (``*_reference``), which the tests compare.
Importing it changes nothing in the process; ``setup_process`` sets the
engine's thread and memory policy, once, before work.
"""

from .cloning import clone_points
from .composite import NEGLIGIBLE_WEIGHT, SCALAR_WEIGHTS, Composite, FieldKey, LayerFields, Role
from .fmm.expansions import local_polynomials
from .fmm.lattice import Lattice
from .geometry.segments import Segments
from .kept_states import DEFAULT_MEMORY
from .live import LiveRepresentation, Progress, Update
from .memory import available_memory, check_image_memory
from .points.field import PointField
from .points.gauss import GaussPoints
from .process import setup_process
from .raster import evaluate_points, output_size, rasterise
from .raster_kernels import load_raster_kernels
from .representation import MAX_LEVELS, Representation, Settings, same_geometry, with_alpha
from .solve.clone import SeamlessClone, Similarity
from .stack import LiveStack, StackUpdate, build, composite_of

__all__ = [
    "DEFAULT_MEMORY", "MAX_LEVELS", "NEGLIGIBLE_WEIGHT", "SCALAR_WEIGHTS", "Composite", "FieldKey", "GaussPoints",
    "LayerFields", "Lattice", "LiveRepresentation", "LiveStack",
    "PointField", "Progress", "Representation", "Role", "SeamlessClone", "Segments", "Settings", "Similarity",
    "StackUpdate", "Update", "build",
    "available_memory", "check_image_memory", "clone_points", "composite_of", "evaluate_points", "load_raster_kernels",
    "local_polynomials", "output_size", "rasterise", "same_geometry", "setup_process", "with_alpha",
]
