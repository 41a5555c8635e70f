"""The one error every document reader raises."""

from __future__ import annotations


class DocumentLoadError(Exception):
    """A document could not be loaded.

    The message names the file and says what is wrong, ready to show to a
    user, e.g. ``"lady_bug.xml: curve 3 has 5 control points; a chain of
    cubic Beziers needs 3k+1"``.

    Parameters
    ----------
    source : str
        The file name (or another label for where the data came from).
    problem : str
        What is wrong, without the file name.
    """

    def __init__(self, source: str, problem: str) -> None:
        super().__init__(source, problem)
        self.source = source
        self.problem = problem

    def __str__(self) -> str:
        return f"{self.source}: {self.problem}"
