"""Unsteady aerodynamic solvers behind one protocol (see ``protocol.py``)."""
