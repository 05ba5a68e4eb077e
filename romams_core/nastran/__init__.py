"""Nastran input through pyNastran: planforms from CAERO1/AERO(S) cards, modes from OP2 eigenvector tables.

pyNastran is optional: importing this package does not import it; the readers raise ImportError saying how
to install it.
"""

from romams_core.nastran.caero import DeckPlanform, planform_from_model, wing_from_bdf
from romams_core.nastran.deck import import_pynastran, main_deck, read_bdf, scrub
from romams_core.nastran.op2 import UNIT_SYSTEMS, NastranOptions, load_modes_nastran

__all__ = ["UNIT_SYSTEMS", "DeckPlanform", "NastranOptions", "import_pynastran", "load_modes_nastran", "main_deck",
           "planform_from_model", "read_bdf", "scrub", "wing_from_bdf"]
