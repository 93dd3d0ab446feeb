"""The data layer: bundled and user datasets, the row-level audit, Appendix A core physics, fit inputs.

Imports nothing of fitdf above :mod:`fitdf.errors`; everything else reads from here.
"""
