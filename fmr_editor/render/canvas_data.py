"""A representation on the GPU: the texture buffers the canvas shader reads, uploaded in part.

``CanvasData`` keeps the cell coefficients, the per-cell segment lists and
the near points in buffer textures (``packing`` says how each is laid out),
with a copy of the coefficients as uploaded, so that an update uploads only
the rows of the cells that changed and knows by how much each changed.  It
also holds the change tables of a delta pass (``CanvasRenderer``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from OpenGL import GL

from ..engine import Representation
from . import bounds, packing
from .gl import BufferTexture

#: Cells whose coefficients an update packs at a time: its temporaries (a megabyte or two) come from the heap,
#: where freed blocks are used again, not from fresh pages (``engine.memory.OWN_PAGES``), which cost 2-3 ms a MB
#: on a virtual machine; roses' colour edit changes 65,536 cells, 19 MB of coefficients.
UPDATE_CHUNK = 8192
#: Texture units of the shader's buffers (the delta pass binds its own tables to the first three).
UNITS = {"u_coeffs": 0, "u_segment_start": 1, "u_segments": 2, "u_point_start": 3, "u_point_members": 4,
         "u_points": 5, "u_cell_list": 6}
_DELTA = {"u_coeffs": "delta_coeffs", "u_segment_start": "delta_segment_start", "u_segments": "delta_segments"}


@dataclass(frozen=True)
class ShaderLayout:
    """What the shader program and the buffers' shapes depend on."""

    cells: int
    cell_size: float
    order: int
    harmonic: bool
    width: int
    height: int
    scalar: bool = False
    alpha: bool = False

    @classmethod
    def of(cls, rep: Representation, scalar: bool = False, alpha: bool = False) -> ShaderLayout:
        return cls(rep.lattice.cells_per_side, rep.lattice.cell_size, rep.order, packing.uses_harmonic(rep),
                   rep.width, rep.height, scalar, alpha)

    @property
    def texels(self) -> int:
        return packing.texels(self.order, self.harmonic, self.scalar)

    @property
    def channels(self) -> int:
        """Of a colour field: 3, or 4 with an alpha field's (``packing``)."""
        return 4 if self.alpha else 3


class CanvasData:
    """The buffers of one representation at a time; GL calls need the caller's context current.

    Parameters
    ----------
    weights : numpy.ndarray, optional
        ``(3,)``: hold the scalar field ``weights . colour`` (``packing``'s scalar layouts).

    Attributes
    ----------
    rep : Representation or None
        What the buffers hold.
    alpha : Representation or None
        The alpha field they hold in a fourth channel (``packing``), or None.
    layout : ShaderLayout or None
    """

    def __init__(self, weights: np.ndarray | None = None) -> None:
        self.weights = weights
        self._buffers = {name: BufferTexture(GL.GL_R32I if name.endswith(("start", "members", "list"))
                                             else GL.GL_RGBA32F)
                         for name in [*UNITS, *_DELTA.values()]}
        self.rep: Representation | None = None
        self.alpha: Representation | None = None
        self.layout: ShaderLayout | None = None
        self._segment_table: packing.SegmentTable | None = None
        self._mirror = np.zeros((0, 0), np.float32)  # the coefficients as uploaded, a row per cell
        self._delta = np.zeros((0, 0), np.float32)  # each cell's latest change of them (as the delta pass reads)
        self._far: tuple[np.ndarray, np.ndarray] | None = None  # bounds.value_bounds of the rows, once asked for
        self._near: tuple[int, np.ndarray] | None = None  # bounds.near_bounds of the channels asked for

    def upload(self, rep: Representation, alpha: Representation | None = None) -> None:
        """Upload all of ``rep`` (and the ``alpha`` field of the same segments in a fourth channel)."""
        self.layout = ShaderLayout.of(rep, self.weights is not None, alpha is not None)
        n = self.layout.cells
        self.alpha = alpha
        self._mirror = packing.cell_coefficients(rep, weights=self.weights, alpha=alpha).reshape(n * n, -1)
        self._delta = np.zeros_like(self._mirror)
        self._buffers["u_coeffs"].set_data(self._mirror)
        self._buffers["delta_coeffs"].set_data(self._delta)
        self._upload_segments(rep)
        self._upload_points(rep)
        self.rep = rep
        self._far = self._near = None

    def update(self, rep: Representation, cells: np.ndarray, same_geometry: bool,
               alpha: Representation | None = None) -> tuple[np.ndarray, bool]:
        """Go over to ``rep`` (and ``alpha``; of the same layout), uploading the coefficients of ``cells`` (flat
        indices).

        Segment lists and near points are uploaded whole when they are other
        arrays than the uploaded ones (with ``same_geometry``, only E and C of
        the segments changed).  The change of the cells' coefficients is kept
        for a delta pass (``upload_change``).

        Returns
        -------
        moved : numpy.ndarray
            ``(len(cells),)`` bound on the change of their far field's pixels (``bounds.far_bound``).
        near_points_changed : bool
        """
        layout = self.layout
        moved = np.empty(len(cells))
        for first in range(0, len(cells), UPDATE_CHUNK):  # none: only segments or near points may have changed
            chunk = cells[first : first + UPDATE_CHUNK]
            fresh = packing.cell_coefficients(rep, chunk, weights=self.weights, alpha=alpha).reshape(len(chunk), -1)
            delta = self._delta[chunk] = fresh - self._mirror[chunk]
            moved[first : first + len(chunk)] = bounds.far_bound(delta, layout.order, layout.harmonic, layout.scalar,
                                                                 layout.channels)
            self._mirror[chunk] = fresh
            if self._far is not None:
                fresh_bounds = bounds.value_bounds(fresh, layout.order, layout.harmonic, layout.scalar,
                                                   layout.channels)
                for kept, rows in zip(self._far, fresh_bounds):
                    kept[chunk] = rows
        for start, stop in packing.cell_runs(cells):
            self._buffers["u_coeffs"].set_subdata(start * layout.texels, self._mirror[start:stop])
        old, old_alpha = self.rep, self.alpha
        self.alpha = alpha
        if (rep.near[0] is not old.near[0] or rep.near[1] is not old.near[1]
                or (alpha is not None and alpha.near[0] is not old_alpha.near[0])):
            self._upload_segments(rep, same_geometry=same_geometry)
            self._near = None
        near_points_changed = _near(rep) is not _near(old)
        if near_points_changed:
            self._upload_points(rep)
            self._near = None
        self.rep = rep
        return moved, near_points_changed

    def value_bounds(self, first: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Each cell's value at its centre and how far the shader's value at any of its pixels may get from it,
        ``(cells^2, channels)`` each (``(cells^2, 1)`` for a scalar field), flat cells, of the channels from
        ``first`` on (an alpha in the fourth: 3): ``bounds.value_bounds`` of the far field, what segments and
        near points may add to it (``bounds.near_bounds``) in the spread.  The far field's kept up to date by
        ``update`` once asked for; the near part made again after a change of the segments or near points."""
        layout = self.layout
        if self._far is None:
            self._far = bounds.value_bounds(self._mirror, layout.order, layout.harmonic, layout.scalar, layout.channels)
        if self._near is None or self._near[0] != first:
            self._near = first, bounds.near_bounds(self.rep, self.weights, self.alpha, first)
        return self._far[0][:, first:], self._far[1][:, first:] + self._near[1]

    def upload_change(self, cells: np.ndarray, table: packing.SegmentTable) -> None:
        """The change tables of a delta pass over ``cells``: their coefficients' latest change (rows by cell, as
        the coefficients) and the segments' change ``table``."""
        for start, stop in packing.cell_runs(cells):
            self._buffers["delta_coeffs"].set_subdata(start * self.layout.texels, self._delta[start:stop])
        self._buffers["delta_segments"].set_data(table.texels)
        self._buffers["delta_segment_start"].set_data(table.cell_start)

    def bind(self, cells: np.ndarray | None, delta: bool) -> None:
        """Bind every buffer to its unit (``UNITS``): the change tables for a ``delta`` pass; ``cells`` (or runs of
        cells) listed."""
        if cells is not None:
            self._buffers["u_cell_list"].set_data(cells.astype(np.int32))
        for name, unit in UNITS.items():
            self._buffers[_DELTA.get(name, name) if delta else name].bind(unit)

    def _upload_segments(self, rep: Representation, same_geometry: bool = False) -> None:
        """Upload the segment lists; with ``same_geometry``, only E and C changed since the last upload (the
        table is refilled and uploaded in place)."""
        if same_geometry and self._segment_table is not None:
            flux, jump = rep.near[0].flux, rep.near[0].jump
            if self.alpha is not None:
                flux, jump = (packing.with_alpha(flux, self.alpha.near[0].flux),
                              packing.with_alpha(jump, self.alpha.near[0].jump))
            packing.refill(self._segment_table, flux, jump)
            self._buffers["u_segments"].set_subdata(0, self._segment_table.texels)
            return
        table = self._segment_table = packing.segment_table(rep, weights=self.weights, alpha=self.alpha)
        self._buffers["u_segments"].set_data(table.texels)
        self._buffers["u_segment_start"].set_data(table.cell_start)

    def _upload_points(self, rep: Representation) -> None:
        table = packing.point_table(rep, self.weights)
        self._buffers["u_points"].set_data(table.texels)
        self._buffers["u_point_start"].set_data(table.start)
        self._buffers["u_point_members"].set_data(table.members)

    def release(self) -> None:
        """Free the buffers (with the context current)."""
        for buffer in self._buffers.values():
            buffer.delete()
        self.rep = None


def _near(rep: Representation):
    return None if rep.points is None else rep.points.near
