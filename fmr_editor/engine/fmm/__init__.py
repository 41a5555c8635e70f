"""The fast multipole machinery: expansions, the lattice of cells and the passes over it.

``expansions`` holds P2M, M2M, M2L and L2L (docs/design.md section 3) and
``moments`` the compiled P2M; ``lattice`` the cells, the upward and
downward passes; ``sparse_downward`` the downward pass of a change that
touches few cells, and of sources in a few cells to a few cells (a clone
layer's region).
"""
