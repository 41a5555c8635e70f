"""Diffusion points: Gaussians expanded into the cells' polynomials (docs/design.md section 4).

``gauss`` holds the settings, truncation and Hermite functions,
``tensor`` (with ``tensor_kernels``) builds the cell polynomials,
``increments`` adds or removes a few points in place, ``near`` sums the
narrow points exactly, and ``field`` ties them together for the
representation (``PointField``) and for live edits (``LivePoints``).
"""
