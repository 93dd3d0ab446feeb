"""Series permeability and Q against flux amplitude, rows and laws, one colour per frequency.

:func:`plot_matched_flux` reads the record of
:func:`fitdf.inference.matched_flux.matched_flux` (``MatchedFlux.to_dict()``, as the report
keeps it): the rows as points with their printed-precision ranges, the static law as solid
lines, its refit with rate-dependent losses (when present) dashed, and the flux levels at
which the frequencies are compared as grey verticals. Only the flux range of the comparison
is drawn (up to 1.25 times its highest level): above it the readings approach the gain, where the
inversion through Fig 5.10 loses its precision.
"""

from __future__ import annotations

import numpy as np
from matplotlib.lines import Line2D

from fitdf.plots._figure import new_figure

__all__ = ["plot_matched_flux"]


def _arr(record: dict, key: str) -> np.ndarray:
    return np.array([np.nan if v is None else v for v in record[key]], float)


def plot_matched_flux(rec: dict):
    """``mu'`` (left) and ``Q`` (right) against flux amplitude (mV s), log-log."""
    fig, axes = new_figure((10.0, 4.2), 1, 2)
    ax_mu, ax_q = axes[0]
    rows = rec["rows"]
    freq, flux = _arr(rows, "frequency_hz"), 1e3 * _arr(rows, "flux_vs")
    levels = sorted({r["level_vs"] for r in rec["levels"]})
    top = 1.25e3 * max(levels)
    low = 0.5e3 * min(levels)
    for i, f in enumerate(np.unique(freq)):
        color = f"C{i}"
        m = (freq == f) & (flux <= top)
        mu, lo, hi = (_arr(rows, k)[m] for k in ("mu", "mu_lo", "mu_hi"))
        err = np.abs(np.vstack([mu - lo, hi - mu]))
        ax_mu.errorbar(flux[m], mu, yerr=err, fmt="o", ms=4, color=color, capsize=2, zorder=4)
        ax_q.plot(flux[m], _arr(rows, "q")[m], "o", ms=4, color=color, zorder=4)
        for law, style in (("static", "-"), ("dynamic", "--")):
            curve = rec["curves"].get(law)
            if not curve:
                continue
            cf, cx = _arr(curve, "frequency_hz"), 1e3 * _arr(curve, "flux_vs")
            k = (cf == f) & (cx <= top) & (cx >= low)
            order = np.argsort(cx[k])
            ax_mu.plot(cx[k][order], _arr(curve, "mu")[k][order], style, color=color, lw=1.2)
            ax_q.plot(cx[k][order], _arr(curve, "q")[k][order], style, color=color, lw=1.2)
    for ax in (ax_mu, ax_q):
        for level in levels:
            ax.axvline(1e3 * level, color="0.75", lw=0.8, zorder=0)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(low, top)
        ax.set_xlabel("flux amplitude |DF| V / (gain w)  (mV s)")
        ax.grid(True, which="both", alpha=0.25)
    ax_mu.set_ylabel("series permeability mu'")
    ax_q.set_ylabel("quality factor Q = mu'/mu''")
    handles = [
        Line2D([], [], color=f"C{i}", marker="o", ls="none", label=f"{f:g} c/s")
        for i, f in enumerate(np.unique(freq))
    ]
    handles += [
        Line2D([], [], color="k", ls="-", label=f"static law ({rec['fits']['static']['model']})")
    ]
    if "dynamic" in rec["curves"]:
        handles.append(Line2D([], [], color="k", ls="--", label="refit, rate-dependent losses"))
    handles.append(Line2D([], [], color="0.75", label="levels compared"))
    ax_q.legend(handles=handles, fontsize=8, loc="best")
    ax_mu.set_title("rows (printed-precision range) and laws", fontsize=10)
    ax_q.set_title("loss: Q of the rows and the laws", fontsize=10)
    return fig
