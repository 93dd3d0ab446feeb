"""The posterior of an MCMC fit as a corner plot (the ``corner`` package)."""

from __future__ import annotations

import numpy as np

from fitdf._arviz import without_refactor_notice
from fitdf.plots._figure import new_figure

__all__ = ["plot_corner"]


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


def plot_corner(posterior, max_draws=4000, truths=None, title=None):
    """Corner plot of a PosteriorResult's parameters (the ``corner`` package).

    Log-scaled parameters (see :class:`~fitdf.params.ParamSpec`) are shown as
    ``log10``, the coordinate they were sampled in. ``truths`` (a FitResult, e.g. the
    least-squares optimum the walkers started from, or a dict name -> value) is marked
    with lines; ``None`` marks nothing.

    Returns
    -------
    matplotlib.figure.Figure
        ``P x P`` axes for ``P`` sampled parameters.
    """
    if not hasattr(posterior, "flat_internal"):
        raise TypeError("plot_corner needs a PosteriorResult (fit with method='mcmc')")
    problem = posterior.problem
    flat = posterior.flat_internal(max_draws=max_draws, seed=0)
    if truths is not None:
        values = (
            truths.values if isinstance(getattr(truths, "values", None), dict) else dict(truths)
        )
    cols, labels, mark = [], [], []
    for i, s in enumerate(problem.specs):
        unit = s.unit if s.unit and s.unit != "1" else ""
        x = flat[:, i] if s.log else s.from_internal(flat[:, i])
        t = None if truths is None else (np.log10(values[s.name]) if s.log else values[s.name])
        scale = 0 if s.log else _decade(x)
        if scale:  # tiny or huge values: show mantissas, the power of ten goes into the label
            x, t = x / 10.0**scale, None if t is None else t / 10.0**scale
            unit = f"1e{scale} {unit}".strip()
        cols.append(x)
        mark.append(t)
        labels.append(("log10 " if s.log else "") + s.name + (f" [{unit}]" if unit else ""))
    samples = np.column_stack(cols)
    P = samples.shape[1]
    size = max(6.0, 1.55 * P + 1.0)
    fig = new_figure((size, size), layout=None)
    _corner().corner(
        samples,
        fig=fig,
        labels=labels,
        quantiles=[0.16, 0.5, 0.84],
        show_titles=True,
        title_fmt=".3g",
        title_kwargs={"fontsize": 8},
        label_kwargs={"fontsize": 8},
        truths=None if truths is None else mark,
        max_n_ticks=3,
        plot_datapoints=False,
        fill_contours=True,
        smooth=1.0,
    )
    for a in fig.axes:
        a.tick_params(labelsize=7)
    fig.subplots_adjust(top=1.0 - 0.9 / size)  # room for the title above the first histogram's
    d = posterior.diagnostics
    conv = "converged" if d.get("converged") else "NOT converged"
    rhat = max(d.get("rhat", {"": np.nan}).values())
    text = title or (
        f"Posterior of {posterior.model} on {posterior.label}: {conv}\n"
        f"(steps/tau {d.get('steps_over_tau', np.nan):.0f}, max R-hat {rhat:.3f}"
        + ("; blue lines: least-squares optimum)" if truths is not None else ")")
    )
    fig.suptitle(text, fontsize="medium", y=1.0 - 0.12 / size)
    return fig
