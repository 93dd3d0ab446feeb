"""The posterior of an MCMC fit as a corner plot (the ``corner`` package).

The layout is fitdf's own, so that no text overlaps another whatever the number of
parameters: the figure grows with the parameters (:data:`PANEL_IN` inches a panel), each
histogram's title (the parameter, then its median and the distances to its 16th and 84th
percentiles) is written on two lines from the left edge of its panel, over the empty panels
to its right, and shrinks where it would leave the figure; a key below the panels names
every mark (:data:`KEY`).
"""

from __future__ import annotations

import textwrap

import numpy as np

from fitdf._arviz import without_refactor_notice
from fitdf.plots._figure import new_figure
from fitdf.plots._panels import law_label

__all__ = ["plot_corner", "KEY", "LEVELS", "PANEL_IN"]

#: Inches of each panel.
PANEL_IN = 1.5
#: Shares of the draws the 2-D contours enclose (corner's default: 0.5, 1, 1.5 and 2 sigma of
#: a 2-D Gaussian).
LEVELS = tuple(1.0 - np.exp(-0.5 * np.arange(0.5, 2.1, 0.5) ** 2))
#: What every mark of the figure means (drawn below its panels; the last sentence only where
#: the least-squares optimum is marked).
KEY = (
    "Diagonal: the histogram of each parameter's draws, dashed lines at its 16th, 50th and "
    "84th percentiles (its title: the median, + the distance to the 84th, - the distance to "
    "the 16th). Below the diagonal: the draws of each pair of parameters, contours enclosing "
    + ", ".join(f"{100 * lv:.0f}" for lv in LEVELS)
    + " % of them. Blue lines and squares: the least-squares optimum."
)
#: Inches above the panels (suptitle, first histogram's title) and below them (ticks,
#: labels, key), and left of them (ticks and labels).
_TOP_IN, _BOTTOM_IN, _LEFT_IN, _RIGHT_IN = 1.25, 1.35, 1.05, 0.2
_FONT = 8.0


def _corner():
    """The ``corner`` module, imported on the first corner plot: it imports ArviZ (1-3 s),
    which no other figure needs (``fitdf limit-cycle`` draws without it)."""
    with without_refactor_notice():
        import corner

    return corner


def _decade(x):
    """Power of ten (multiple of 3) to divide a parameter by for readable ticks, 0 if none."""
    m = float(np.nanmedian(np.abs(x))) if np.size(x) else 0.0
    if m == 0.0 or not np.isfinite(m) or 1e-2 <= m < 1e4:
        return 0
    return int(3 * np.floor(np.log10(m) / 3))


def _columns(posterior, flat, truths):
    """The plotted columns, their axis labels and the truths' marks (see :func:`plot_corner`)."""
    values = None
    if truths is not None:
        values = (
            truths.values if isinstance(getattr(truths, "values", None), dict) else dict(truths)
        )
    cols, labels, mark = [], [], []
    for i, s in enumerate(posterior.problem.specs):
        unit = s.unit if s.unit and s.unit != "1" else ""
        x = flat[:, i] if s.log else s.from_internal(flat[:, i])
        t = None if values is None else (np.log10(values[s.name]) if s.log else values[s.name])
        scale = 0 if s.log else _decade(x)
        if scale:  # tiny or huge values: show mantissas, the power of ten goes into the label
            x, t = x / 10.0**scale, None if t is None else t / 10.0**scale
            unit = f"1e{scale} {unit}".strip()
        cols.append(x)
        mark.append(t)
        labels.append(("log10 " if s.log else "") + s.name + (f" [{unit}]" if unit else ""))
    return np.column_stack(cols), labels, mark


def _title(label, x) -> str:
    """``label`` over ``median +up -down`` (the distances to the 16th and 84th percentiles)."""
    lo, mid, hi = np.percentile(x, [16, 50, 84])
    return f"{label}\n{mid:.3g} +{hi - mid:.2g} -{mid - lo:.2g}"


def _fit_titles(fig, titles) -> None:
    """Shrink each title that would leave the figure on the right until it fits."""
    renderer = fig.canvas.get_renderer()
    right = fig.bbox.x1
    for t in titles:
        while t.get_window_extent(renderer).x1 > right and t.get_fontsize() > 5:
            t.set_fontsize(t.get_fontsize() - 0.5)


def plot_corner(posterior, max_draws=4000, truths=None, title=None):
    """Corner plot of a PosteriorResult's parameters (the ``corner`` package).

    Log-scaled parameters (see :class:`~fitdf.params.ParamSpec`) are shown as
    ``log10``, the coordinate they were sampled in. ``truths`` (a FitResult, e.g. the
    least-squares optimum the walkers started from, or a dict name -> value) is marked
    with lines; ``None`` marks nothing.

    Returns
    -------
    matplotlib.figure.Figure
        ``P x P`` axes for ``P`` sampled parameters; the histograms' titles are the
        diagonal axes' left titles, the key the figure's last text.
    """
    if not hasattr(posterior, "flat_internal"):
        raise TypeError("plot_corner needs a PosteriorResult (fit with method='mcmc')")
    flat = posterior.flat_internal(max_draws=max_draws, seed=0)
    samples, labels, mark = _columns(posterior, flat, truths)
    P = samples.shape[1]
    width = _LEFT_IN + PANEL_IN * P + _RIGHT_IN
    height = _TOP_IN + PANEL_IN * P + _BOTTOM_IN
    fig = new_figure((width, height), layout=None)
    _corner().corner(
        samples,
        fig=fig,
        labels=labels,
        quantiles=[0.16, 0.5, 0.84],
        levels=LEVELS,
        show_titles=False,
        label_kwargs={"fontsize": _FONT},
        truths=None if truths is None else mark,
        max_n_ticks=3,
        plot_datapoints=False,
        fill_contours=True,
        smooth=1.0,
        labelpad=0.08,
    )
    fig.subplots_adjust(
        left=_LEFT_IN / width,
        right=1.0 - _RIGHT_IN / width,
        top=1.0 - _TOP_IN / height,
        bottom=_BOTTOM_IN / height,
        wspace=0.05,
        hspace=0.05,
    )
    for a in fig.axes:
        a.tick_params(labelsize=7)
    axes = np.asarray(fig.axes).reshape(P, P)
    titles = [
        axes[i, i].set_title(_title(labels[i], samples[:, i]), loc="left", fontsize=_FONT, pad=3)
        for i in range(P)
    ]
    _fit_titles(fig, titles)
    d = posterior.diagnostics
    conv = "converged" if d.get("converged") else "NOT converged"
    rhat = max(d.get("rhat", {"": np.nan}).values())
    text = title or "\n".join(
        [
            *textwrap.wrap(
                f"Posterior of {law_label(posterior.model)} on {posterior.label}: {conv}",
                int(width * 72 / (0.55 * 10.0)),  # 10 pt type
            ),
            f"(steps/tau {d.get('steps_over_tau', np.nan):.0f}, max R-hat {rhat:.3f})",
        ]
    )
    fig.suptitle(text, fontsize=10, y=1.0 - 0.12 / height, va="top")
    key = KEY if truths is not None else KEY.rsplit(" Blue", 1)[0]
    chars = int((width - _LEFT_IN) * 72 / (0.5 * 7.5))  # 7.5 pt type, half as wide on average
    fig.text(
        0.5 * _LEFT_IN / width,
        0.1 / height,
        "\n".join(textwrap.wrap(key, chars)),
        fontsize=7.5,
        ha="left",
        va="bottom",
    )
    return fig
