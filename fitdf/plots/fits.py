"""Figures of fitted describing functions against amplitude: fits, residuals, cross-impedance.

The critical loci are drawn by :mod:`fitdf.plots.loci`, posteriors by
:mod:`fitdf.plots.posterior`; the panel helpers all share are in ``_panels``.

Every function takes fit results (:class:`~fitdf.inference.results.FitResult` or
:class:`~fitdf.inference.results.PosteriorResult`) and returns a
:class:`matplotlib.figure.Figure` built on the Agg canvas (no ``pyplot``: no global
state, nothing shown). Save with ``fig.savefig(path)``; in a notebook the figure
displays itself.

Conventions (thesis Chapter V): input volts on x, the measured DF is ``|DF|`` (output
over input volts) and a *phase lead* in degrees; measured rows are black dots, rows the
audit excluded (when given) grey crosses. Several results are drawn in the order given,
with colours ``C0, C1, ...``; the first one is "the best" (pass a ranking's order).

Joint fits (rows at several source impedances) are drawn in one figure: each source
impedance gets its own pair of rows (magnitude above, phase lead below), one column per
frequency; panels of a frequency not measured at that impedance are left blank.

Examples
--------
>>> import fitdf                                               # doctest: +SKIP
>>> fits = [fitdf.fit("B.1", m) for m in ("rayleigh", "constant_width")]   # doctest: +SKIP
>>> fig = plot_fit(fits)                                       # doctest: +SKIP
>>> fig.savefig("b1.png")                                      # doctest: +SKIP
"""

from __future__ import annotations

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from fitdf.plots._figure import new_figure
from fitdf.plots._panels import (
    _STYLES,
    AMP_LABEL,
    _amplitude_grid,
    _as_list,
    _blank,
    _block,
    _core_title,
    _draw_measured,
    _label,
    _label_pair,
    _legend,
    _pair_axes,
    _panels,
    _rs_list,
    _table_for,
)

__all__ = ["plot_fit", "plot_residuals", "plot_cross_impedance"]


def _draw_excluded(ax_mag, ax_ph, excluded, rs, f):
    if excluded is None or len(excluded) == 0:
        return
    e = excluded[
        (excluded["source_impedance_ohm"].astype(float) == rs) & (excluded["frequency_hz"] == f)
    ]
    e = e.dropna(subset=["input_v"])
    if e.empty:
        return
    kw = dict(color="0.45", ls="none", ms=6, mew=1.2, zorder=4)
    ax_mag.plot(e["input_v"], e["df_reported"], "x", **kw)
    ax_ph.plot(e["input_v"], e["phase_lead_deg"], "x", **kw)


def _draw_band(ax_mag, ax_ph, post, a_range, f, rs, table, color):
    A = _amplitude_grid(*a_range, 60)  # the band is smooth; 60 points x 150 draws keeps it fast
    band = post.predictive_band(
        A, np.full(A.shape, f), np.full(A.shape, rs), table=_table_for(post, table), max_draws=150
    )
    mag, ph = band["magnitude"], band["phase_deg"]
    for lo, hi, alpha in ((0, 4, 0.15), (1, 3, 0.3)):
        ax_mag.fill_between(A, mag[lo], mag[hi], color=color, alpha=alpha, lw=0)
        ax_ph.fill_between(A, ph[lo], ph[hi], color=color, alpha=alpha, lw=0)


# ------------------------------------------------------------------ public figures
def plot_fit(
    results,
    frequencies=None,
    band=None,
    source_impedance=None,
    excluded=None,
    n_grid=160,
    title=None,
):
    """Measured DF magnitude and phase lead against input amplitude, with fitted curves.

    Parameters
    ----------
    results : FitResult, PosteriorResult or list of them
        Fitted to the same rows (a ranking); the first is "the best". Curves are
        ``result.predict`` on a fine amplitude grid per frequency and source impedance.
    frequencies : sequence of float, optional
        Frequencies (c/s) to draw, one panel column each; default every measured one.
    band : PosteriorResult, False or None
        Posterior predictive band (68 % and 95 %, shaded) to draw. ``None`` uses the
        first result when it is a PosteriorResult; ``False`` draws none.
    source_impedance : float or sequence, optional
        Impedances (ohm) to draw; default all in the data (a pair of rows each).
    excluded : pandas.DataFrame, optional
        Rows left out of the fit (``input_v``, ``frequency_hz``, ``source_impedance_ohm``,
        ``df_reported``, ``phase_lead_deg``), drawn as grey crosses.
    n_grid : int
        Amplitude grid points per curve.
    title : str, optional
        Figure title; default names the core, tables and source impedance(s).

    Returns
    -------
    matplotlib.figure.Figure
        ``2 x n_impedances`` rows by ``n_frequencies`` columns of axes.
    """
    results = _as_list(results)
    data = results[0].problem.data
    if band is None:
        band = results[0] if hasattr(results[0], "predictive_band") else None
    band_idx = next((i for i, r in enumerate(results) if band and r.model == band.model), 0)
    rs_list, freqs = _panels(data, frequencies, source_impedance)
    many = len(rs_list) > 1
    fig = new_figure((max(3.1 * len(freqs), 6.5), 2.3 * 2 * len(rs_list) + 1.4))
    axes = _pair_axes(fig, len(rs_list), len(freqs))
    for p, rs in enumerate(rs_list):
        for j, f in enumerate(freqs):
            ax_mag, ax_ph = axes[2 * p, j], axes[2 * p + 1, j]
            mask, table = _block(data, rs, f)
            if not mask.any():
                _blank(ax_mag, ax_ph, rs, f)
                continue
            A = _amplitude_grid(data.amplitude[mask].min(), data.amplitude[mask].max(), n_grid)
            if band:
                _draw_band(ax_mag, ax_ph, band, (A[0], A[-1]), f, rs, table, f"C{band_idx}")
            for i, r in enumerate(results):
                pred = r.predict(A, f, rs, table=_table_for(r, table))
                ax_mag.plot(A, np.abs(pred), color=f"C{i}", lw=1.4, ls=_STYLES[(i // 10) % 4])
                ax_ph.plot(
                    A, np.angle(pred, deg=True), color=f"C{i}", lw=1.4, ls=_STYLES[(i // 10) % 4]
                )
            _draw_excluded(ax_mag, ax_ph, excluded, rs, f)
            _draw_measured(ax_mag, ax_ph, data, mask)
            _label_pair(ax_mag, ax_ph, j == 0, rs, many, f)
    handles = [
        Line2D([], [], color="k", marker="o", ls="none", ms=4, label="measured (fitted rows)")
    ]
    if excluded is not None and len(excluded):
        handles.append(
            Line2D([], [], color="0.45", marker="x", ls="none", ms=6, label="excluded by the audit")
        )
    handles += [
        Line2D([], [], color=f"C{i}", ls=_STYLES[(i // 10) % 4], label=_label(r, results))
        for i, r in enumerate(results)
    ]
    if band:
        handles.append(
            Patch(
                color=f"C{band_idx}",
                alpha=0.35,
                label=f"{band.model}: 68% (darker) / 95% posterior band of the curve",
            )
        )
    _legend(fig, handles)
    core, tables = _core_title(data)
    rs_text = " and ".join(f"{v:g}" for v in rs_list)
    fig.suptitle(
        title or f"{core} ({tables}), source impedance {rs_text} ohm: measured and fitted DF"
    )
    return fig


def plot_residuals(results, top=3, title=None):
    """Magnitude and phase-lead residuals (fit minus measured) against amplitude.

    One column per model (the first ``top`` results), magnitude residuals on top and
    phase-lead residuals below, shared y axes so the models compare at a glance.
    Colour = frequency; circles = the first source impedance, squares = the second.

    Returns
    -------
    matplotlib.figure.Figure
        ``2 x min(top, len(results))`` axes.
    """
    results = _as_list(results)[: max(int(top), 1)]
    fig = new_figure((max(3.6 * len(results), 6.5), 5.6))
    axes = fig.subplots(2, len(results), squeeze=False, sharey="row", sharex="col")
    freqs = sorted(
        set(np.concatenate([r.residuals["frequency_hz"].to_numpy(float) for r in results]).tolist())
    )
    impedances = sorted(
        set(
            np.concatenate(
                [r.residuals["source_impedance_ohm"].to_numpy(float) for r in results]
            ).tolist()
        )
    )
    markers = dict(zip(impedances, "os^D"))
    for j, r in enumerate(results):
        res = r.residuals
        top_ax, bottom = axes[0, j], axes[1, j]
        for (rs, f), g in res.groupby(["source_impedance_ohm", "frequency_hz"]):
            color = f"C{freqs.index(f)}"
            top_ax.plot(
                g["input_v"],
                g["magnitude_residual"],
                markers[rs],
                color=color,
                ms=4,
                ls="-",
                lw=0.6,
            )
            ok = g["phase_residual_deg"].notna()
            bottom.plot(
                g["input_v"][ok],
                g["phase_residual_deg"][ok],
                markers[rs],
                color=color,
                ms=4,
                ls="-",
                lw=0.6,
            )
        m = r.metrics
        top_ax.set_title(
            f"{_label(r, results, width=44)}\n"
            f"RMS |DF| {m['rms_magnitude']:.3f}, phase {m['rms_phase_deg']:.1f} deg",
            fontsize="medium",
        )
        for a in (top_ax, bottom):
            a.axhline(0.0, color="0.5", lw=0.8)
            a.grid(True, lw=0.4, alpha=0.5)
        bottom.set_xlabel(AMP_LABEL)
    axes[0, 0].set_ylabel("|DF| residual (fit - measured)")
    axes[1, 0].set_ylabel("phase-lead residual (deg)")
    handles = [
        Line2D([], [], color=f"C{i}", marker="o", ls="none", ms=4, label=f"{f:g} c/s")
        for i, f in enumerate(freqs)
    ]
    if len(impedances) > 1:
        handles += [
            Line2D([], [], color="0.3", marker=markers[rs], ls="none", ms=4, label=f"{rs:g} ohm")
            for rs in impedances
        ]
    handles += [
        Line2D([], [], color="0.3", marker="o", ms=4, lw=0.6, label="rows of one frequency"),
        Line2D([], [], color="0.5", lw=0.8, label="zero"),
    ]
    _legend(fig, handles, ncol=min(len(handles), 8))
    core, tables = _core_title(results[0].problem.data)
    fig.suptitle(title or f"Residuals of the top {len(results)} models, {core} ({tables})")
    return fig


def plot_cross_impedance(
    train_results, test_data, calibration_gains=None, frequencies=None, n_grid=160, title=None
):
    """A fit at one source impedance and its prediction of the data at another.

    Top rows: the training data with the fitted curves; bottom rows: the other
    impedance's data with the curves *predicted* from the training fit (dashed), the
    core's parameters unchanged. As in :func:`fitdf.inference.cross_impedance.cross_impedance`, only the
    target table's calibration gain may be refitted: give it per model in
    ``calibration_gains`` (model -> gain; missing or NaN keeps the training gain).

    Parameters
    ----------
    train_results : FitResult or list of them
        Fitted at the training impedance (first = best).
    test_data : FitData
        The rows to predict (e.g. ``fitdf.data.resolve.resolve_data("B.3")``).

    Returns
    -------
    matplotlib.figure.Figure
        ``4`` rows (training magnitude/phase, predicted magnitude/phase) by frequency.
    """
    results = _as_list(train_results)
    train = results[0].problem.data
    test = test_data
    gains = dict(calibration_gains or {})
    rs_train, rs_test = _rs_list(train, None), _rs_list(test, None)
    freqs = (
        sorted(set(train.frequency.tolist()) | set(test.frequency.tolist()))
        if frequencies is None
        else [float(f) for f in np.atleast_1d(frequencies)]
    )
    fig = new_figure((max(3.1 * len(freqs), 6.5), 2.3 * 4 + 1.4))
    axes = _pair_axes(fig, 2, len(freqs))
    for p, (data, rs, predicted) in enumerate(
        ((train, rs_train[0], False), (test, rs_test[0], True))
    ):
        for j, f in enumerate(freqs):
            ax_mag, ax_ph = axes[2 * p, j], axes[2 * p + 1, j]
            mask, table = _block(data, rs, f)
            if not mask.any():
                _blank(ax_mag, ax_ph, rs, f)
                continue
            A = _amplitude_grid(data.amplitude[mask].min(), data.amplitude[mask].max(), n_grid)
            for i, r in enumerate(results):
                pred = r.predict(A, f, rs, table=_table_for(r, table) if not predicted else None)
                if predicted:
                    g = gains.get(r.model, np.nan)
                    if "gain" in r.values and np.isfinite(g):
                        pred = pred * (g / r.values["gain"])
                ls = "--" if predicted else "-"
                ax_mag.plot(A, np.abs(pred), color=f"C{i}", ls=ls, lw=1.4)
                ax_ph.plot(A, np.angle(pred, deg=True), color=f"C{i}", ls=ls, lw=1.4)
            _draw_measured(ax_mag, ax_ph, data, mask)
            _label_pair(ax_mag, ax_ph, j == 0, rs, True, f)
    handles = [Line2D([], [], color="k", marker="o", ls="none", ms=4, label="measured")]
    handles += [
        Line2D([], [], color="0.3", label=f"fitted at {rs_train[0]:g} ohm (top rows)"),
        Line2D(
            [],
            [],
            color="0.3",
            ls="--",
            label=f"predicted at {rs_test[0]:g} ohm"
            + (", only the table's gain refitted" if gains else "")
            + " (bottom rows)",
        ),
    ]
    handles += [
        Line2D([], [], color=f"C{i}", label=_label(r, results)) for i, r in enumerate(results)
    ]
    _legend(fig, handles)
    core, _ = _core_title(train)
    fig.suptitle(
        title
        or f"{core}: fitted at {rs_train[0]:g} ohm ({'+'.join(train.groups)}, top), "
        f"predicting {rs_test[0]:g} ohm ({'+'.join(test.groups)}, bottom)"
    )
    return fig
