"""Document model: immutable items and the document.  No Qt, no OpenGL."""

from .curve import BlurStop, ColorStop, DiffusionCurve, interpolate_stops
from .document import Document

__all__ = ["BlurStop", "ColorStop", "DiffusionCurve", "Document", "interpolate_stops"]
