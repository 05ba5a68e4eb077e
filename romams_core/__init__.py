"""romams_core: the numerics of ROM-AMS (numpy/scipy only; no web, database or queue imports).

SI units everywhere; angles in radians inside the core.
"""

__version__ = "0.1.0"
