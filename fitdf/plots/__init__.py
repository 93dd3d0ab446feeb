"""Figures of fitdf; the only package that imports matplotlib.

:mod:`fitdf.plots.thesis` redraws the computed graphs of thesis Chapter IV
(Graphs 4.1-4.7) from fitdf's models.
"""
from .thesis import (THESIS_GRAPHS, graph_4_1, graph_4_2, graph_4_3, graph_4_4, graph_4_5,
                     graph_4_6, graph_4_7, save_thesis_graphs)

__all__ = ["THESIS_GRAPHS", "graph_4_1", "graph_4_2", "graph_4_3", "graph_4_4", "graph_4_5",
           "graph_4_6", "graph_4_7", "save_thesis_graphs"]
