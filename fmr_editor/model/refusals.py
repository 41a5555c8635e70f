"""``EditRefused``: what the document raises for an edit it cannot take.

An edit the user asks for may be impossible (merging a hidden layer, drawing on a clone layer, a region
that crosses itself); the model raises ``EditRefused`` with the reason in the user's words, and the editor
shows it and changes nothing.  ``limits.LimitError`` is one too (the engine checks the limits when it builds,
on its thread, where the window reports it as an image it could not update).  Any other exception is a bug:
the window reports it as one, with its traceback.
"""

from __future__ import annotations


class EditRefused(ValueError):
    """The document cannot take an edit as asked; the message says why, in the user's words.

    A ``ValueError``, so that scripts catching the wider error keep working.
    """
