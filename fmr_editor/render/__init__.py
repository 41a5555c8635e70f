"""The only user of OpenGL: the canvas's shader renderer and its small GL wrappers.

``CanvasRenderer`` evaluates a representation per window pixel in
``shaders/canvas.frag`` (any zoom stays sharp) and re-evaluates only what
changed; ``PictureRenderer`` keeps one per layer image and mask and composes
them (``shaders/compose.frag``); ``View`` is the pan and zoom.  Nothing here imports Qt: the caller
owns the OpenGL context and makes it current.
"""

from .canvas_renderer import CanvasRenderer
from .gl import ShaderError
from .picture_renderer import PictureRenderer, merge_changes
from .view import View

__all__ = ["CanvasRenderer", "PictureRenderer", "ShaderError", "View", "merge_changes"]
