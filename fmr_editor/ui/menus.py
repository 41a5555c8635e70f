"""The window's actions and menus, with the standard shortcuts.

``build_actions`` makes every ``QAction`` and connects it to a method of
the window by name; ``build_menus`` puts them in the menu bar.  Keys that
the active tool may take (Delete, BackSpace, Return, Escape, the arrows)
reach the tool before these shortcuts (see ``MainWindow.eventFilter``).
"""

from __future__ import annotations

from PySide6.QtGui import QAction, QActionGroup, QKeySequence

from ..tools import TOOLS

#: name: (text, shortcuts, window method (or ``"part.method"`` of one of its command objects), status tip)
ACTIONS = {
    "new": ("&New\u2026", ["Ctrl+N"], "new_document", "Start a new document (asks for the canvas size)"),
    "open": ("&Open\u2026", ["Ctrl+O"], "open_document", "Open a .fmr document, an Orzan .xml curve set or an SVG"),
    "import_svg": ("&Import SVG\u2026", ["Ctrl+I"], "import_svg",
                   "Open an SVG's paths and shapes as diffusion curves (stroke colour on both sides, fill inside)"),
    "save": ("&Save", ["Ctrl+S"], "save", "Save the document as .fmr"),
    "save_as": ("Save &As\u2026", ["Ctrl+Shift+S"], "save_as", "Save the document under another name"),
    "export": ("&Export PNG\u2026", ["Ctrl+E"], "export_png", "Render the image to a PNG file"),
    "export_svg": ("Export S&VG\u2026", ["Ctrl+Shift+E"], "export_svg",
                   "Render the image to an SVG file: the picture embedded, every curve kept as a hidden path"),
    "close": ("&Close", ["Ctrl+W"], "close_document", "Close the document (asks first about unsaved changes)"),
    "quit": ("&Quit", ["Ctrl+Q"], "close", "Close the editor"),
    "undo": ("Undo", ["Ctrl+Z"], "undo", "Undo the last step"),
    "redo": ("Redo", ["Ctrl+Shift+Z", "Ctrl+Y"], "redo", "Redo the step undone last"),
    "copy": ("&Copy", ["Ctrl+C"], "clip_commands.copy", "Copy the active layer inside the Lasso's selection"),
    "paste": ("&Paste", ["Ctrl+V"], "clip_commands.paste",
              "Paste the copied curves and points as they are, in a new layer (they diffuse on their own)"),
    "paste_seamless": ("Paste &Seamless", ["Ctrl+Shift+V"], "clip_commands.paste_seamless",
                       "Paste the copied region as a clone layer that blends into the layers below without a seam"),
    "delete": ("&Delete", ["Delete", "Backspace"], "delete_selection", "Delete the selection"),
    "select_all": ("Select &All", ["Ctrl+A"], "select_all", "Select every curve and point"),
    "deselect": ("D&eselect", ["Ctrl+Shift+A"], "deselect", "Clear the selection"),
    "preferences": ("Pre&ferences\u2026", ["Ctrl+,"], "edit_preferences",
                    "Brush settings to start with, autosave delay, undo memory"),
    "zoom_in": ("Zoom &In", ["Ctrl++", "Ctrl+="], "zoom_in", "Zoom in about the centre"),
    "zoom_out": ("Zoom &Out", ["Ctrl+-"], "zoom_out", "Zoom out about the centre"),
    "actual_size": ("&Actual Size", ["1"], "actual_size", "One document pixel per screen pixel (100%)"),
    "fit": ("&Fit Canvas", ["Ctrl+0", "5"], "fit", "Show the whole canvas"),
    "show_blur": ("Show &Blur", ["Ctrl+Shift+B"], "toggle_blur",
                  "Soften the picture by its curves' blur stops (off: show every edge sharp, and work faster)"),
    "next_document": ("Ne&xt Document", ["Ctrl+Tab", "Ctrl+PgDown"], "next_document", "Show the next open document"),
    "previous_document": ("Pre&vious Document", ["Ctrl+Shift+Tab", "Ctrl+PgUp"], "previous_document",
                          "Show the previous open document"),
    "swap_colors": ("&Swap Colours", ["X"], "swap_colors", "Swap the foreground and background colours"),
    "default_colors": ("&Default Colours", ["D"], "default_colors", "Black foreground, white background"),
    "new_layer": ("&New Layer", ["Ctrl+Shift+N"], "layer_commands.new_layer",
                  "Add an empty layer above the active one"),
    "duplicate_layer": ("&Duplicate Layer", ["Ctrl+J"], "layer_commands.duplicate_layer",
                        "Copy the active layer above it"),
    "delete_layer": ("De&lete Layer", [], "layer_commands.delete_layer", "Delete the active layer"),
    "merge_down": ("&Merge Down", [], "layer_commands.merge_down",
                   "Join the active layer's curves and points into the layer below (they then diffuse together)"),
    "flatten": ("&Flatten Image", [], "layer_commands.flatten",
                "Join the curves and points of every visible layer into one layer (hidden layers are dropped)"),
    "add_mask": ("Add &Mask", [], "layer_commands.add_mask",
                 "Give the active layer a mask that shows all of it (paint dark or draw dark shapes to hide)"),
    "add_hiding_mask": ("Add Mask: &Hide All", [], "layer_commands.add_hiding_mask",
                        "Give the active layer a mask that hides all of it (paint light or draw light shapes to show)"),
    "delete_mask": ("Delete Mas&k", [], "layer_commands.delete_mask", "Remove the active layer's mask"),
    "invert_mask": ("&Invert Mask", [], "layer_commands.invert_mask", "Show what the mask hid and hide what it showed"),
    "disable_mask": ("Disa&ble Mask", [], "layer_commands.toggle_mask",
                     "Draw the layer as if it had no mask (the mask is kept)"),
    "edit_mask": ("&Edit Mask", ["Ctrl+Shift+M"], "layer_commands.edit_mask",
                  "Tools act on the mask: the brush paints it (light adds, dark subtracts, Alt erases), "
                  "the pen draws its sharp edges"),
    "adjust_colors": ("&Colour Adjust\u2026", ["Ctrl+U"], "layer_commands.adjust_colors",
                      "Hue, saturation, brightness, contrast and invert of the active layer"),
    "shortcuts": ("&Keyboard Shortcuts", ["Ctrl+F1"], "show_shortcuts", "Every command's keys"),
    "user_guide": ("&User Guide", ["F1"], "user_guide", "Open the user guide (docs/user-guide.md)"),
    "about": ("&About", [], "about", "About the editor and its version"),
}

#: Actions that only make sense with a document open.
LAYER_ACTIONS = ("new_layer", "duplicate_layer", "delete_layer", "merge_down", "flatten", "add_mask",
                 "add_hiding_mask", "delete_mask", "invert_mask", "disable_mask", "edit_mask", "adjust_colors")

MENUS = (
    ("&File", ("new", "open", "import_svg", "recent", None, "save", "save_as", "export", "export_svg", None, "close",
               "quit")),
    ("&Edit", ("undo", "redo", None, "copy", "paste", "paste_seamless", None, "delete", None, "select_all",
               "deselect", None, "preferences")),
    ("&View", ("zoom_in", "zoom_out", "actual_size", "fit", None, "show_blur", None, "next_document",
               "previous_document", None, "panels")),
    ("&Layer", ("new_layer", "duplicate_layer", "delete_layer", None, "merge_down", "flatten", None, "add_mask",
                "add_hiding_mask", "delete_mask", "invert_mask", "disable_mask", "edit_mask", None, "adjust_colors")),
    ("&Tools", ("tools", None, "swap_colors", "default_colors")),
    ("&Help", ("user_guide", "shortcuts", None, "about")),
)


def _method(window, path: str):
    """``window``'s method ``path``, or a method of one of its parts (``"layer_commands.new_layer"``)."""
    target = window
    for name in path.split("."):
        target = getattr(target, name)
    return target


def build_actions(window) -> dict[str, QAction]:
    """Every action of ``window``, by name; the tools' as ``"tool:NAME"`` (checkable, exclusive)."""
    actions = {}
    for name, (text, shortcuts, method, tip) in ACTIONS.items():
        action = QAction(text, window)
        action.setShortcuts([QKeySequence(s) for s in shortcuts])
        action.setStatusTip(tip)
        action.triggered.connect(lambda _=False, method=method: _method(window, method)())
        actions[name] = action
    actions["edit_mask"].setCheckable(True)
    actions["show_blur"].setCheckable(True)
    group = QActionGroup(window)
    group.setExclusive(True)
    for cls in TOOLS:
        action = QAction(cls.title, window)
        action.setCheckable(True)
        action.setShortcut(QKeySequence(cls.shortcut))
        action.setToolTip(f"<b>{cls.title}</b> ({cls.shortcut})<br>{cls.summary}")
        action.setStatusTip(f"{cls.title} ({cls.shortcut}): {cls.summary}")
        action.triggered.connect(lambda _=False, name=cls.name: window.set_tool(name))
        group.addAction(action)
        actions[f"tool:{cls.name}"] = action
    return actions


def build_menus(window, actions: dict[str, QAction], recent_menu, panel_actions) -> None:
    """Fill ``window``'s menu bar; ``recent_menu`` goes in File, ``panel_actions`` in View."""
    bar = window.menuBar()
    for title, names in MENUS:
        menu = bar.addMenu(title)
        for name in names:
            if name is None:
                menu.addSeparator()
            elif name == "recent":
                menu.addMenu(recent_menu)
            elif name == "panels":
                for action in panel_actions:
                    menu.addAction(action)
            elif name == "tools":
                for cls in TOOLS:
                    menu.addAction(actions[f"tool:{cls.name}"])
            else:
                menu.addAction(actions[name])
