"""Matplotlib figures (PNG/SVG) of modes, bases, training and flutter results."""
