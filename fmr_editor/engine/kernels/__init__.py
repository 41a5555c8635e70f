"""Kernels: the closed-form layer potentials of a segment and their compiled sums.

``potentials`` is the plain numpy reference (docs/design.md section 2),
``fastmath`` the vectorisable scalar maths every compiled loop shares,
``segment_sums`` the sums over segments at arbitrary points (direct, near
field, collocation) and ``grid`` the same on tensor grids of samples
(``blocks``: gathered segments and the loop over samples shared by every
grid kernel, in float64 or, through ``single``, float32; ``near_rows``: for
lattices of a sample or two a cell); ``local_grid`` evaluates the cells'
local expansions on a grid and ``subcells`` rasterises an FMR's segments,
cells of many samples in sub-cells; ``rows`` spreads the rows of cells the
grid kernels walk over their threads.
"""
