"""Document model: immutable items and the document.  No Qt, no OpenGL."""

from .curve import BlurStop, ColorStop, DiffusionCurve, interpolate_stops
from .document import Document
from .layer import Layer, Mask
from .point import DiffusionPoint
from .refusals import EditRefused

__all__ = [
    "BlurStop", "ColorStop", "DiffusionCurve", "DiffusionPoint", "Document", "EditRefused", "Layer", "Mask",
    "interpolate_stops",
]
