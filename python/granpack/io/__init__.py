"""Particle file formats, one module per format family: its writer and its reader side by
side."""
