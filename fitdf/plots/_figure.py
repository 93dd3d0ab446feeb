"""The one way fitdf makes a figure: a matplotlib ``Figure`` on the Agg canvas.

No pyplot: figures are plain objects (nothing global, safe in worker processes), the
caller saves or shows them. One resolution for every figure, so a report's images match.
"""

from __future__ import annotations

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

__all__ = ["DPI", "new_figure"]

#: Screen resolution of every figure (``savefig`` may override it).
DPI = 100


def new_figure(figsize, nrows=0, ncols=1, layout="constrained", **subplot_kw):
    """A figure of ``figsize`` inches; with ``nrows > 0`` also its ``(nrows, ncols)`` axes.

    Returns the figure alone when ``nrows == 0``, else ``(figure, axes)`` with ``axes``
    always a 2-D array (``squeeze=False``).
    """
    fig = Figure(figsize=figsize, dpi=DPI, layout=layout)
    FigureCanvasAgg(fig)
    if nrows == 0:
        return fig
    return fig, fig.subplots(nrows, ncols, squeeze=False, **subplot_kw)
