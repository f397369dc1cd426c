"""Rendering: the only package that imports Mitsuba, scikit-image meshing and image encoders."""
