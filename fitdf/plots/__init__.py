"""Figures of fitdf; the only package that imports matplotlib.

:mod:`fitdf.plots.thesis_graphs` redraws the computed graphs of thesis Chapter IV
(Graphs 4.1-4.7) from fitdf's models; :mod:`fitdf.plots.fits` draws fitted results
(DF against amplitude, residuals, cross-impedance), :mod:`fitdf.plots.loci` their
critical loci and :mod:`fitdf.plots.posterior` a posterior's corner plot;
:mod:`fitdf.plots.summary` draws a report's opening figure from its results record and
:mod:`fitdf.plots.permeability` a series permeability compared at matched flux from its record.
"""

from fitdf.plots.fits import plot_cross_impedance, plot_fit, plot_residuals
from fitdf.plots.loci import plot_critical_loci
from fitdf.plots.permeability import plot_matched_flux
from fitdf.plots.posterior import plot_corner
from fitdf.plots.summary import plot_summary
from fitdf.plots.thesis_graphs import (
    THESIS_GRAPHS,
    graph_4_1,
    graph_4_2,
    graph_4_3,
    graph_4_4,
    graph_4_5,
    graph_4_6,
    graph_4_7,
    save_thesis_graphs,
)

__all__ = [
    "THESIS_GRAPHS",
    "graph_4_1",
    "graph_4_2",
    "graph_4_3",
    "graph_4_4",
    "graph_4_5",
    "graph_4_6",
    "graph_4_7",
    "save_thesis_graphs",
    "plot_fit",
    "plot_critical_loci",
    "plot_residuals",
    "plot_corner",
    "plot_cross_impedance",
    "plot_summary",
    "plot_matched_flux",
]
