"""Critical loci ``-1/DF`` of fitted describing functions in the Nyquist plane (Graphs 5.4-5.20).

Measured rows give points, fitted results curves over the measured amplitude range;
the conventions are those of :mod:`fitdf.plots.fits`.
"""

from __future__ import annotations

import numpy as np
from matplotlib.lines import Line2D

from fitdf.plots._figure import new_figure
from fitdf.plots._panels import (
    _STYLES,
    _amplitude_grid,
    _as_list,
    _block,
    _core_title,
    _label,
    _legend,
    _panels,
    _table_for,
)

__all__ = ["plot_critical_loci"]


def _loci_limits(points):
    """Axis limits covering the measured loci of the larger DFs (small DFs run off far)."""
    if not points:
        return None
    z = np.concatenate(points)
    z = z[np.isfinite(z) & (np.abs(z) <= 1.0 / 0.15)]
    if z.size == 0:
        return None
    x0, x1 = z.real.min(), z.real.max()
    y0, y1 = min(z.imag.min(), 0.0), z.imag.max()
    px, py = 0.08 * max(x1 - x0, 0.05), 0.08 * max(y1 - y0, 0.05)
    return (x0 - px, x1 + px), (y0 - py, y1 + py)


def plot_critical_loci(
    results, frequencies=None, top=1, source_impedance=None, ax=None, n_grid=240, title=None
):
    """Critical loci ``-1/DF`` in the Nyquist plane per frequency (thesis Graphs 5.4-5.20).

    Measured rows give points ``-1/DF`` (rows with zero output have none); the first
    ``top`` results give curves ``-1/DF(A)`` over the measured amplitude range, with an
    arrow in the direction of increasing amplitude. Colour = frequency, line style =
    model. The measured DF leads, so the loci lie in the second quadrant. The axes
    cover the measured points with ``|DF| >= 0.15``; smaller DFs lie further out.

    Parameters
    ----------
    results : FitResult or list of them
    frequencies : sequence of float, optional
    top : int
        How many of the results draw curves (default the first only).
    source_impedance : float or sequence, optional
        One axes per impedance (default all in the data).
    ax : matplotlib.axes.Axes, optional
        Draw into this axes (needs a single source impedance).

    Returns
    -------
    matplotlib.figure.Figure
    """
    results = _as_list(results)
    data = results[0].problem.data
    rs_list, freqs = _panels(data, frequencies, source_impedance)
    if ax is not None:
        if len(rs_list) != 1:
            raise ValueError("ax= needs a single source impedance; pass source_impedance=")
        fig, axes = ax.figure, [ax]
    else:
        fig = new_figure((6.2 * len(rs_list) + 0.6, 5.6))
        axes = list(fig.subplots(1, len(rs_list), squeeze=False)[0])
    curves = results[: max(int(top), 0)]
    for a, rs in zip(axes, rs_list):
        points = []
        for j, f in enumerate(freqs):
            mask, table = _block(data, rs, f)
            if not mask.any():
                continue
            D = data.measured[mask]
            z = -1.0 / D[np.abs(D) > 0]
            points.append(z)
            a.plot(z.real, z.imag, "o", color=f"C{j}", ms=4, zorder=5)
            A = _amplitude_grid(data.amplitude[mask].min(), data.amplitude[mask].max(), n_grid)
            for i, r in enumerate(curves):
                pred = r.predict(A, f, rs, table=_table_for(r, table))
                with np.errstate(divide="ignore", invalid="ignore"):
                    L = np.where(np.abs(pred) > 1e-9, -1.0 / pred, np.nan)
                a.plot(L.real, L.imag, color=f"C{j}", ls=_STYLES[i % 4], lw=1.3)
                good = np.flatnonzero(np.isfinite(L) & (np.abs(L) <= 1.0 / 0.15))
                if i == 0 and good.size > 4:
                    k = good[good.size // 2]
                    a.annotate(
                        "",
                        xy=(L.real[k + 1], L.imag[k + 1]),
                        xytext=(L.real[k], L.imag[k]),
                        arrowprops=dict(arrowstyle="-|>", color=f"C{j}", lw=1.0, mutation_scale=10),
                    )
        lim = _loci_limits(points)
        if lim:
            a.set_xlim(*lim[0])
            a.set_ylim(*lim[1])
        a.axhline(0.0, color="0.6", lw=0.6)
        a.axvline(0.0, color="0.6", lw=0.6)
        a.set_xlabel("Re(-1/DF)")
        a.set_ylabel("Im(-1/DF)")
        a.grid(True, lw=0.4, alpha=0.5)
        a.set_title(f"source impedance {rs:g} ohm", fontsize="medium")
    handles = [
        Line2D(
            [], [], color=f"C{j}", marker="o", ms=4, lw=1.3, label=f"{f:g} c/s: measured, fitted"
        )
        for j, f in enumerate(freqs)
    ]
    handles += [
        Line2D([], [], color="0.2", ls=_STYLES[i % 4], label=_label(r, results))
        for i, r in enumerate(curves)
    ]
    if curves:
        handles.append(
            Line2D([], [], color="0.2", marker=">", ms=5, lw=1.0, label="amplitude grows")
        )
    core, tables = _core_title(data)
    text = title or f"Critical loci -1/DF, {core} ({tables})"
    if ax is None:
        _legend(fig, handles, ncol=min(len(handles), 2 if curves else 4))
        fig.suptitle(text)
    else:
        ax.legend(handles=handles, fontsize="x-small", loc="best")
        ax.set_title(text, fontsize="medium")
    return fig
