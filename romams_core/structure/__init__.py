"""Structural models of the wing: plate and beam finite elements, modal analysis, mode mapping."""
