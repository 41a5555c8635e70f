"""Solving the boundary-element system for the unknown densities (docs/design.md section 2).

``dense`` assembles and solves it directly, ``solver`` by GMRES with FMM
products preconditioned by the compressed factorisation of ``skeleton``
(which draws on ``linalg`` and ``entries``); ``updated`` solves a nearby
geometry through a kept factorisation and ``system_solvers`` chooses
between the two.
"""
