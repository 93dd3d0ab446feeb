"""Figures of fitted describing functions: fits, critical loci, residuals, posteriors.

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

import corner
import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from fitdf.plots._figure import new_figure

__all__ = [
    "plot_fit",
    "plot_critical_loci",
    "plot_residuals",
    "plot_corner",
    "plot_cross_impedance",
]

MAG_LABEL = "|DF| (V/V)"
PHASE_LABEL = "phase lead (deg)"
AMP_LABEL = "input amplitude (V)"
_STYLES = ("-", "--", ":", "-.")


# ------------------------------------------------------------------ helpers
def _as_list(results):
    if results is None:
        raise ValueError("no results to plot")
    out = list(results) if isinstance(results, (list, tuple)) else [results]
    if not out:
        raise ValueError("no results to plot")
    return out


def _label(result, results):
    """Legend label: the model, plus the method when methods are mixed."""
    methods = {r.method for r in results}
    return result.model if len(methods) == 1 else f"{result.model} ({result.method})"


def _core_title(data):
    rows = data.rows
    core = (
        ", ".join(dict.fromkeys(rows["core"].astype(str))).capitalize()
        if "core" in rows
        else data.label
    )
    tables = "+".join(data.groups)
    return core, tables


def _rs_list(data, source_impedance):
    if source_impedance is not None:
        return [float(v) for v in np.atleast_1d(source_impedance)]
    return sorted(set(data.source_impedance.tolist()))


def _panels(data, frequencies, source_impedance):
    """(impedances, frequencies) to draw; frequencies default to every measured one."""
    rs = _rs_list(data, source_impedance)
    keep = np.isin(data.source_impedance, rs)
    freqs = (
        sorted(set(data.frequency[keep].tolist()))
        if frequencies is None
        else [float(f) for f in np.atleast_1d(frequencies)]
    )
    if not rs or not freqs:
        raise ValueError("nothing to plot: no source impedance or frequency selected")
    return rs, freqs


def _amplitude_grid(a_min, a_max, n):
    """Fine grid that is smooth on a linear axis and resolves the smallest amplitudes."""
    a_min = max(float(a_min), 1e-4)
    a_max = max(float(a_max), a_min * 1.01)
    return np.unique(
        np.concatenate([np.geomspace(a_min, a_max, n // 2), np.linspace(a_min, a_max, n - n // 2)])
    )


def _block(data, rs, f):
    m = (data.source_impedance == rs) & (data.frequency == f)
    return m, (data.group[m][0] if m.any() else (data.groups[0] if data.groups else None))


def _phase_ok(data, mask):
    """Rows with a meaningful measured phase (a zero output has none)."""
    ok = np.abs(data.measured[mask]) > 0
    if "phase_trusted" in data.rows:
        ok &= data.rows["phase_trusted"].to_numpy(bool)[mask]
    return ok


def _table_for(result, table):
    return table if table in result.problem.data.groups else None


def _draw_measured(ax_mag, ax_ph, data, mask, marker="o", label="measured"):
    A = data.amplitude[mask]
    D = data.measured[mask]
    ok = _phase_ok(data, mask)
    ax_mag.plot(A, np.abs(D), marker, color="k", ms=4, ls="none", label=label, zorder=5)
    ax_ph.plot(A[ok], np.angle(D[ok], deg=True), marker, color="k", ms=4, ls="none", zorder=5)


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


def _pair_axes(fig, nrows_pairs, ncols):
    axes = fig.subplots(2 * nrows_pairs, ncols, squeeze=False)
    for p in range(nrows_pairs):
        for j in range(ncols):
            axes[2 * p + 1, j].sharex(axes[2 * p, j])
            axes[2 * p, j].tick_params(labelbottom=False)
    return axes


def _label_pair(ax_mag, ax_ph, first_col, rs, many_rs, f):
    suffix = f"\n@ {rs:g} ohm" if many_rs else ""
    if first_col:
        ax_mag.set_ylabel(MAG_LABEL + suffix)
        ax_ph.set_ylabel(PHASE_LABEL + suffix)
    ax_ph.set_xlabel(AMP_LABEL)
    ax_mag.set_title(f"f = {f:g} c/s" + (f", {rs:g} ohm" if many_rs else ""), fontsize="medium")
    for ax in (ax_mag, ax_ph):
        ax.grid(True, lw=0.4, alpha=0.5)


def _blank(ax_mag, ax_ph, rs, f):
    for ax in (ax_mag, ax_ph):
        ax.set_axis_off()
    ax_mag.text(
        0.5,
        0.5,
        f"no data at {f:g} c/s, {rs:g} ohm",
        ha="center",
        va="center",
        transform=ax_mag.transAxes,
        color="0.5",
        fontsize="small",
    )


def _legend(fig, handles, ncol=None):
    fig.legend(
        handles=handles,
        loc="outside lower center",
        ncol=ncol or min(len(handles), 4),
        fontsize="small",
        frameon=False,
    )


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
                label=f"{band.model}: 68% / 95% posterior band of the curve",
            )
        )
    _legend(fig, handles, ncol=min(len(handles), 5))
    core, tables = _core_title(data)
    rs_text = " and ".join(f"{v:g}" for v in rs_list)
    fig.suptitle(
        title or f"{core} ({tables}), source impedance {rs_text} ohm: measured and fitted DF"
    )
    return fig


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
        Line2D([], [], color=f"C{j}", marker="o", ms=4, ls="none", label=f"{f:g} c/s measured")
        for j, f in enumerate(freqs)
    ]
    handles += [
        Line2D(
            [],
            [],
            color="0.2",
            ls=_STYLES[i % 4],
            label=f"{_label(r, results)} fit (arrow: A grows)",
        )
        for i, r in enumerate(curves)
    ]
    axes[-1].legend(handles=handles, fontsize="x-small", loc="best")
    core, tables = _core_title(data)
    text = title or f"Critical loci -1/DF, {core} ({tables})"
    if ax is None:
        fig.suptitle(text)
    else:
        ax.set_title(text, fontsize="medium")
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
            f"{_label(r, results)}\nRMS |DF| {m['rms_magnitude']:.3f}, phase {m['rms_phase_deg']:.1f} deg",
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
    _legend(fig, handles, ncol=min(len(handles), 8))
    core, tables = _core_title(results[0].problem.data)
    fig.suptitle(title or f"Residuals of the top {len(results)} models, {core} ({tables})")
    return fig


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
    corner.corner(
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


def plot_cross_impedance(
    train_results, test_data, calibration_gains=None, frequencies=None, n_grid=160, title=None
):
    """A fit at one source impedance and its prediction of the data at another.

    Top rows: the training data with the fitted curves; bottom rows: the other
    impedance's data with the curves *predicted* from the training fit (dashed), the
    core's parameters unchanged. As in :func:`fitdf.inference.ranking.cross_impedance`, only the
    target table's calibration gain may be refitted: give it per model in
    ``calibration_gains`` (model -> gain; missing or NaN keeps the training gain).

    Parameters
    ----------
    train_results : FitResult or list of them
        Fitted at the training impedance (first = best).
    test_data : FitData
        The rows to predict (e.g. ``fitdf.inference.api.resolve_data("B.3")``).

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
        Line2D(
            [], [], color=f"C{i}", label=f"{_label(r, results)}: fit (solid), prediction (dashed)"
        )
        for i, r in enumerate(results)
    ]
    _legend(fig, handles, ncol=min(len(handles), 3))
    core, _ = _core_title(train)
    fig.suptitle(
        title
        or f"{core}: fitted at {rs_train[0]:g} ohm ({'+'.join(train.groups)}, top), "
        f"predicting {rs_test[0]:g} ohm ({'+'.join(test.groups)}, bottom)"
    )
    return fig
