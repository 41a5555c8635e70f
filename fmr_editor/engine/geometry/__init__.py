"""Geometry: curves and the canvas border as straight segments with their boundary data.

``segments`` holds the ``Segments`` container, ``discretise`` turns a
document into segments (flatten, clip, border, cut at cells), ``overlaps``
resolves overlaps and ``curve_cache`` keeps each curve's segments
from one edit to the next, with the overlapping pairs (``overlap_index``);
``splice`` takes the pieces of the rows an edit left alone over from the last
result.  Nothing here knows about solving or expansions.
"""
