"""fmr-editor: diffusion-curve images on the fast multipole representation.

>>> from fmr_editor import load, render_image
>>> image = render_image(load("drawing.xml"), width=512)   # float32 (H, W, 3) in [0, 1]
"""

from __future__ import annotations

__all__ = ["load", "render_image"]
__version__ = "0.1.0"


def load(path):
    """Load a document from ``path`` (``.fmr``, or Orzan CurveSetXML ``.xml``).

    Raises
    ------
    fmr_editor.io.DocumentLoadError
        With one clear message when the file is unreadable or malformed.
    """
    from .io import load_document

    return load_document(path)


def render_image(document, width=None, height=None, samples=3, *, order=None, method="fmr", progress=None,
                 coverage=False, blur=True):
    """Render ``document`` (all its layers composed) to a float32 ``(height, width, 3)`` array in [0, 1]: the
    picture over black (``(height, width, 4)`` with its coverage after it, when ``coverage``).

    Parameters
    ----------
    document : fmr_editor.model.Document
    width, height : int, optional
        Output size; defaults to the canvas size, one alone keeps the aspect ratio.
    samples : int
        ``samples x samples`` supersampling per pixel (1: the pixel centre).
    order : int, optional
        Degree of the cell polynomials (default: the engine's).
    method : {"fmr", "direct"}
        ``"direct"`` sums over every segment instead (slow, for checking).
    progress : callable, optional
        Called as ``progress(stage, fraction)``.
    coverage : bool
        Add the picture's coverage (1 where it is opaque; ``io.png.save_png`` writes RGBA where it is not).
    blur : bool
        Soften each layer by its curves' blur stops (``engine.blur``), as the editor shows it with View > Show
        Blur (default); False renders every edge sharp.
    """
    import numpy as np

    from .engine import LiveStack, Settings, check_image_memory, output_size, rasterise

    check_image_memory(*output_size(document.width, document.height, width, height))
    settings = (Settings() if order is None
                else Settings(order=order, propagation_order=max(order, Settings().propagation_order)))
    stack = LiveStack(document, settings, progress, blur=blur)
    image = rasterise(stack.composite, width, height, samples=samples, method=method, progress=progress,
                      coverage=coverage)
    return np.clip(image, 0.0, 1.0).astype(np.float32)
