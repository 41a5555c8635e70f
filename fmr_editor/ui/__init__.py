"""The only user of PySide6: the editor's window, canvas, panels and threads.

``app.main`` starts the editor; ``main_window.MainWindow`` holds the canvas
(``canvas``, with the tools' ``overlay`` on top), the panels (``options_panel``,
``stops_panel`` with its ``gradient_bar``, ``history_panel``) and the menus
(``menus``, ``file_commands``).  A ``workspace.Workspace`` is one open document:
its history, tools and ``engine_thread.EngineThread``; ``jobs.Job`` runs opening,
saving and exporting (``export``) off the window's thread.
"""
