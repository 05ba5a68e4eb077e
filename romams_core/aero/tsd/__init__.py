"""Transonic small-disturbance (TSD) aerodynamics: coefficients, grids, numba kernels, time marching, solver."""

from romams_core.aero.tsd.solver import MeanFlow, TsdSolver

__all__ = ["MeanFlow", "TsdSolver"]
