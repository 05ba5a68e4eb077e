"""romams: the service layer around romams_core (settings, persistence, CLI, plots)."""

__version__ = "0.1.0"
