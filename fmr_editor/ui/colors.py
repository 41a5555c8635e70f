"""Colour dialogs: a blocking pick, and a live one whose changes merge into one undo step."""

from __future__ import annotations

from collections.abc import Callable, Hashable

from PySide6.QtGui import QColor
from PySide6.QtWidgets import QColorDialog

from ..model.history import History
from .gradient_bar import qcolor

Color = tuple[float, float, float]


def rgb(color: QColor) -> Color:
    """A QColor as an sRGB float triple."""
    return (color.redF(), color.greenF(), color.blueF())


def pick_color(parent, current: Color, title: str = "Choose Colour") -> Color | None:
    """Ask for a colour (``QColorDialog.getColor``); None when the user cancels."""
    chosen = QColorDialog.getColor(qcolor(current), parent, title, QColorDialog.ColorDialogOption.DontUseNativeDialog)
    return rgb(chosen) if chosen.isValid() else None


def new_merge_key(name: str) -> Hashable:
    """A merge key no earlier step has (``History.apply``), for one dialog's changes."""
    return (name, object())


def live_color_dialog(parent, history: History, current: Color, apply: Callable[[Color, float, Hashable], object],
                      title: str = "Choose Colour", alpha: float | None = None) -> QColorDialog:
    """Open a colour dialog (window-modal, not blocking) whose every change is shown at once.

    Each change calls ``apply(colour, alpha, merge_key)`` with the same merge
    key, so the whole dialog is one undo step; Cancel undoes that step.  With
    ``alpha`` (the current one) the dialog shows an alpha channel too; else the
    alpha passed is 1.

    Returns
    -------
    QColorDialog
        Already open; it deletes itself when closed.
    """
    initial = qcolor(current)
    if alpha is not None:
        initial.setAlphaF(alpha)
    dialog = QColorDialog(initial, parent)
    dialog.setWindowTitle(title)
    dialog.setOption(QColorDialog.ColorDialogOption.DontUseNativeDialog)
    dialog.setOption(QColorDialog.ColorDialogOption.ShowAlphaChannel, alpha is not None)
    key = new_merge_key(title)
    start = history.index, history.document

    def changed(color: QColor) -> None:
        if color.isValid():
            apply(rgb(color), color.alphaF() if alpha is not None else 1.0, key)

    def rejected() -> None:
        if history.index == start[0] + 1 and history.document is not start[1]:
            history.undo()  # the dialog's one merged step

    dialog.currentColorChanged.connect(changed)
    dialog.colorSelected.connect(changed)
    dialog.rejected.connect(rejected)
    dialog.finished.connect(dialog.deleteLater)
    dialog.open()
    return dialog
