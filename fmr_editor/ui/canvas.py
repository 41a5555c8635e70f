"""The canvas widget: a picture drawn by the shader renderer, with pan, zoom and pointer signals.

``Canvas`` owns a ``render.PictureRenderer`` in its OpenGL context; give it a
picture (a representation, or a layered ``engine.Composite``) with
``set_representation`` and, after an engine update, the new one with
``update_representation(picture, changed)`` (``update.changed`` of a
representation, or the changed cells by field of a composite).  Both only
record the request; the renderer uploads and draws in ``paintGL``.

Navigation: the wheel zooms about the cursor, Ctrl+plus / Ctrl+minus about
the centre, Ctrl+0 (or 5) fits the canvas and 1 shows it at its actual size
(``zoom_to``: one document pixel per screen pixel); the middle button, or the left one while
Space is held, pans.  A zoom evaluates every window pixel again (a few
hundred milliseconds at 1024x1024 under llvmpipe), so while zoom steps follow
each other the canvas shows the last sharp image scaled and evaluates once
they stop (``SETTLE_MS``).  Every other press, move, release and double click is
emitted in document pixels for the tools.
"""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import QPointF, Qt, QTimer, Signal
from PySide6.QtGui import QImage, QSurfaceFormat
from PySide6.QtOpenGLWidgets import QOpenGLWidget

from ..engine import Composite, Representation, Role
from ..render import PictureRenderer, ShaderError, View, merge_changes

Picture = Representation | Composite

#: Zoom factor of one wheel notch and of Ctrl+plus.
ZOOM_STEP = 1.25
#: Window pixels left around the canvas when fitting it.
FIT_MARGIN = 16
#: While zooming, frames scale the last sharp image; the image is evaluated this long after the last step (ms).
SETTLE_MS = 150


def surface_format() -> QSurfaceFormat:
    """The OpenGL format the canvas asks for: 4.1 core (the shader reads doubles and texture buffers)."""
    fmt = QSurfaceFormat()
    fmt.setVersion(4, 1)
    fmt.setProfile(QSurfaceFormat.OpenGLContextProfile.CoreProfile)
    return fmt


class Canvas(QOpenGLWidget):
    """Shows a representation; pans, zooms and reports pointer events in document pixels.

    Signals carry ``(x, y, buttons, modifiers)``: document coordinates (floats,
    y down), ``Qt.MouseButton`` flags (for a release: the button released)
    and ``Qt.KeyboardModifier`` flags.

    Parameters
    ----------
    parent : QWidget, optional
    """

    pressed = Signal(float, float, object, object)
    moved = Signal(float, float, object, object)
    released = Signal(float, float, object, object)
    double_clicked = Signal(float, float, object, object)
    #: Emitted after the view (pan, zoom, size) changed.
    view_changed = Signal()

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self.setFormat(surface_format())
        self.setMouseTracking(True)
        self.setFocusPolicy(Qt.FocusPolicy.StrongFocus)
        self.renderer: PictureRenderer | None = None
        self.error: str | None = None  # why nothing can be drawn (no suitable OpenGL)
        self.frames_shown = 0  # paints that showed a picture not shown before
        self._rep: Picture | None = None
        self._full_upload = False
        self._changed: dict | None = None  # changed cells by field since the last paint
        self._mask_overlay: int | None = None
        self._view = View(width=max(self.width(), 1), height=max(self.height(), 1))
        self._fitted = True  # the view follows the widget's size until the user pans or zooms
        self._pan_from: QPointF | None = None
        self._space = False
        self._settle = QTimer(self)  # running while zoom steps follow each other
        self._settle.setSingleShot(True)
        self._settle.setInterval(SETTLE_MS)
        self._settle.timeout.connect(self.update)

    # -- content ------------------------------------------------------------------------------
    @property
    def representation(self) -> Picture | None:
        """The picture shown: a representation or a composite."""
        return self._rep

    def set_representation(self, rep: Picture | None, fit: bool = True) -> None:
        """Show ``rep`` (all of it is uploaded); ``fit`` fits its canvas in the window."""
        self._rep, self._full_upload, self._changed = rep, True, None
        if fit and rep is not None:
            self.fit()
        self.update()

    def update_representation(self, rep: Picture, changed: np.ndarray | dict) -> None:
        """Show ``rep``, which differs from the shown one only as ``changed`` says.

        ``changed``: the cells (``engine.Update.changed``) of a representation,
        or of a composite a dict of them by field (a field left out is unchanged).
        """
        if isinstance(changed, np.ndarray):
            changed = {(0, Role.IMAGE): changed}  # a representation is a picture of one layer of id 0
        if not self._full_upload:
            self._changed = merge_changes(self._changed or {}, changed)
        self._rep = rep
        self.update()

    @property
    def mask_overlay(self) -> int | None:
        """The id of the layer whose mask is tinted (``set_mask_overlay``)."""
        return self._mask_overlay

    def set_mask_overlay(self, layer_id: int | None) -> None:
        """Tint what the mask of layer ``layer_id`` hides (while it is edited); None: no tint."""
        self._mask_overlay = layer_id
        if self.renderer is not None and self.renderer.mask_overlay != layer_id:
            self.renderer.mask_overlay = layer_id
        self.update()

    # -- view ---------------------------------------------------------------------------------
    @property
    def view(self) -> View:
        """Pan and zoom in widget (logical) pixels."""
        return self._view

    @property
    def fitted(self) -> bool:
        """True while the view fits the canvas in the window and follows the window's size."""
        return self._fitted

    def set_view(self, view: View) -> None:
        self._fitted = False
        self._settle.stop()
        self._set_view(view)

    def _set_view(self, view: View) -> None:
        if view != self._view:
            self._view = view
            self.update()
            self.view_changed.emit()

    def fit(self) -> None:
        """Show the whole canvas, centred (Ctrl+0); the view then follows the widget's size."""
        self._fitted = True
        self._settle.stop()
        if self._rep is not None:
            self._set_view(View.fit(self._rep.width, self._rep.height, max(self.width(), 1), max(self.height(), 1),
                                    FIT_MARGIN))

    def zoom(self, factor: float, x: float | None = None, y: float | None = None) -> None:
        """Zoom by ``factor`` about widget point ``(x, y)`` (default: the centre)."""
        x = self.width() / 2 if x is None else x
        y = self.height() / 2 if y is None else y
        self.set_view(self._view.zoomed(factor, x, y))
        self._settle.start()

    def zoom_to(self, scale: float) -> None:
        """Show ``scale`` screen (device) pixels per document pixel, about the window's centre.

        The document's origin lands on a whole device pixel, so that at 1 each
        document pixel is exactly one screen pixel (its centre sampled).
        """
        ratio = self.devicePixelRatioF()
        scale = scale / ratio  # set, not reached by a factor: at 1 it must be 1 exactly
        x, y = self.width() / 2, self.height() / 2
        doc_x, doc_y = self._view.to_document(x, y)
        offset_x, offset_y = x - doc_x * scale, y - doc_y * scale
        self.set_view(View(scale, round(offset_x * ratio) / ratio, round(offset_y * ratio) / ratio,
                           self._view.width, self._view.height))
        self._settle.start()

    @property
    def zoom_factor(self) -> float:
        """Screen (device) pixels per document pixel: 1 at the actual size."""
        return self._view.scale * self.devicePixelRatioF()

    def zoom_in(self) -> None:
        self.zoom(ZOOM_STEP)

    def zoom_out(self) -> None:
        self.zoom(1 / ZOOM_STEP)

    def pan(self, dx: float, dy: float) -> None:
        """Move the view by ``(dx, dy)`` widget pixels."""
        self.set_view(self._view.panned(dx, dy))

    def to_document(self, x: float, y: float) -> tuple[float, float]:
        """Document position of widget point ``(x, y)``."""
        return self._view.to_document(x, y)

    def device_view(self) -> View:
        """The view in framebuffer (device) pixels, as the renderer draws it."""
        ratio = self.devicePixelRatioF()
        v = self._view
        return View(v.scale * ratio, v.offset_x * ratio, v.offset_y * ratio,
                    max(round(self.width() * ratio), 1), max(round(self.height() * ratio), 1))

    # -- OpenGL ---------------------------------------------------------------------------------
    def initializeGL(self) -> None:
        fmt = self.context().format()
        if (fmt.majorVersion(), fmt.minorVersion()) < (4, 1) \
                or fmt.profile() != QSurfaceFormat.OpenGLContextProfile.CoreProfile:
            self.error = f"the canvas needs OpenGL 4.1 core; got {fmt.majorVersion()}.{fmt.minorVersion()}"
            return
        self.renderer = PictureRenderer()
        self.renderer.mask_overlay = self._mask_overlay
        self._full_upload = self._rep is not None
        self.context().aboutToBeDestroyed.connect(self._release)

    def _release(self) -> None:
        if self.renderer is not None:
            self.makeCurrent()
            self.renderer.release()
            self.renderer = None
            self.doneCurrent()

    def resizeGL(self, width: int, height: int) -> None:
        if self._fitted and self._rep is not None:
            self.fit()
        else:
            self._set_view(self._view.resized(max(self.width(), 1), max(self.height(), 1)))

    def paintGL(self) -> None:
        renderer = self.renderer
        if renderer is None:
            return
        if self._view.width != max(self.width(), 1) or self._view.height != max(self.height(), 1):
            self._view = self._view.resized(max(self.width(), 1), max(self.height(), 1))
        try:
            if self._rep is None:
                renderer.forget()
            elif self._full_upload:
                renderer.upload(self._rep)
            elif self._changed is not None:
                renderer.update(self._rep, self._changed)
            self.frames_shown += self._rep is not None and (self._full_upload or self._changed is not None)
            self._full_upload, self._changed = False, None
            renderer.draw(self.device_view(), self.defaultFramebufferObject(), preview=self._settle.isActive())
        except ShaderError as error:  # the driver refused the shader: say so once, draw nothing more
            self.error = str(error)
            self.renderer = None
            renderer.release()

    def grab_image(self) -> np.ndarray:
        """What the canvas shows, ``(height, width, 3)`` uint8 in device pixels (``grabFramebuffer``), sharp."""
        self._settle.stop()
        image = self.grabFramebuffer().convertToFormat(QImage.Format.Format_RGB888)
        width, height = image.width(), image.height()
        data = np.frombuffer(image.constBits(), np.uint8, count=image.bytesPerLine() * height)
        return data.reshape(height, image.bytesPerLine())[:, : width * 3].reshape(height, width, 3).copy()

    # -- input ----------------------------------------------------------------------------------
    def _emit(self, signal, event, buttons) -> None:
        position = event.position()
        x, y = self.to_document(position.x(), position.y())
        signal.emit(x, y, buttons, event.modifiers())

    def mousePressEvent(self, event) -> None:
        button = event.button()
        if button == Qt.MouseButton.MiddleButton or (button == Qt.MouseButton.LeftButton and self._space):
            self._pan_from = event.position()
            self.setCursor(Qt.CursorShape.ClosedHandCursor)
            return
        self._emit(self.pressed, event, event.buttons())

    def mouseMoveEvent(self, event) -> None:
        if self._pan_from is not None:
            position = event.position()
            self.pan(position.x() - self._pan_from.x(), position.y() - self._pan_from.y())
            self._pan_from = position
            return
        self._emit(self.moved, event, event.buttons())

    def mouseReleaseEvent(self, event) -> None:
        if self._pan_from is not None:
            if not event.buttons() & (Qt.MouseButton.MiddleButton | Qt.MouseButton.LeftButton):
                self._pan_from = None
                self.unsetCursor()
            return
        self._emit(self.released, event, event.button())

    def mouseDoubleClickEvent(self, event) -> None:
        if event.button() == Qt.MouseButton.MiddleButton or self._space:
            return
        self._emit(self.double_clicked, event, event.buttons())

    def wheelEvent(self, event) -> None:
        steps = event.angleDelta().y() / 120
        if steps:
            position = event.position()
            self.zoom(ZOOM_STEP**steps, position.x(), position.y())
        event.accept()

    def keyPressEvent(self, event) -> None:
        key, ctrl = event.key(), bool(event.modifiers() & Qt.KeyboardModifier.ControlModifier)
        if key == Qt.Key.Key_Space and not event.isAutoRepeat():
            self._space = True
        elif ctrl and key in (Qt.Key.Key_Plus, Qt.Key.Key_Equal):
            self.zoom_in()
        elif ctrl and key == Qt.Key.Key_Minus:
            self.zoom_out()
        elif ctrl and key == Qt.Key.Key_0:
            self.fit()
        else:
            super().keyPressEvent(event)

    def keyReleaseEvent(self, event) -> None:
        if event.key() == Qt.Key.Key_Space and not event.isAutoRepeat():
            self._space = False
        else:
            super().keyReleaseEvent(event)
