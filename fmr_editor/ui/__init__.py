"""The only user of PySide6: the editor's widgets (the canvas so far; the main window and panels to come)."""
