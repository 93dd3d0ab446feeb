"""Figures for limit-cycle prediction (thesis V.6, Graphs 5.21 and 5.22).

* :func:`plot_nyquist` -- the Nyquist plane: the plant locus ``K G0(j omega)`` for a few
  gains and the critical loci ``-1/N(A, omega)`` for a few frequencies, with the
  harmonic-balance intersections marked (filled: stable by Loeb's criterion; open:
  unstable), framed on where the loci meet, beside a panel of the whole loci. For a
  measured core the loci lie in the second quadrant (phase lead, Fig 5.10).
* :func:`plot_thesis_comparison` -- predicted vs measured amplitude and frequency
  against the system gain for Tables 5.1 and 5.2, unscaled and with the analog computer's
  time and gain scales fitted to the other blocks (:mod:`fitdf.limit_cycle_tables.scales`), the
  simulated loop beside harmonic balance, the measured die-out brackets and the predicted
  critical gains.
* :func:`plot_time_response` -- a simulated loop (:mod:`fitdf.loop.simulate`).

Like :mod:`fitdf.plots.thesis_graphs`, figures are built on the Agg canvas without
``pyplot``: no global backend switch and no figure registry that could leak (and warn,
an error under ``filterwarnings = error``). Every function returns the Figure.
"""

from __future__ import annotations

import numpy as np
from matplotlib.patches import Rectangle
from matplotlib.ticker import FormatStrFormatter, LogLocator

from fitdf.plots._figure import new_figure

__all__ = ["plot_nyquist", "plot_thesis_comparison", "plot_time_response"]

FIGSIZE = (6.5, 5.0)


def _pick(values, n):
    values = np.unique(np.asarray(values, float))
    if values.size <= n:
        return values
    return values[np.unique(np.round(np.linspace(0, values.size - 1, n)).astype(int))]


def _closest_pair(curves_a, curves_b):
    """The closest points ``(p, q)`` of any curve of ``curves_a`` and any of ``curves_b``
    (arrays of complex points; non-finite points ignored), or None."""
    best = None
    for a in curves_a:
        a = a[np.isfinite(a)]
        for b in curves_b:
            b = b[np.isfinite(b)]
            if not (a.size and b.size):
                continue
            d = np.abs(a[:, None] - b[None, :])
            i, j = np.unravel_index(np.argmin(d), d.shape)
            if best is None or d[i, j] < best[0]:
                best = (d[i, j], a[i], b[j])
    return None if best is None else best[1:]


def _frame(points, aspect=1.3):
    """Axis limits ``(x0, x1), (y0, y1)`` around ``points`` (complex) with a margin: the
    points' box grown by 0.6 of its size or of 0.4 of the points' distance from the origin,
    whichever is larger; ``aspect``: the x span over the y span."""
    p = np.asarray(points, complex)
    p = p[np.isfinite(p)]
    lo_x, hi_x, lo_y, hi_y = p.real.min(), p.real.max(), p.imag.min(), p.imag.max()
    size = max(hi_x - lo_x, hi_y - lo_y)
    half = 0.5 * size + 0.6 * max(size, 0.4 * np.abs(p).max(), 1e-12)
    cx, cy = 0.5 * (lo_x + hi_x), 0.5 * (lo_y + hi_y)
    return (cx - aspect * half, cx + aspect * half), (cy - half, cy + half)


def _overview_frame(curves):
    """Limits showing every curve and the origin (points beyond 99% of the distances from
    the origin left out: ``-1/N`` runs off towards infinity where ``N`` vanishes)."""
    p = np.concatenate([np.asarray(c, complex).ravel() for c in curves] + [np.zeros(1, complex)])
    p = p[np.isfinite(p)]
    p = p[np.abs(p) <= np.quantile(np.abs(p), 0.99)]
    pad = 0.05 * max(np.ptp(p.real), np.ptp(p.imag), 1e-12)
    return (p.real.min() - pad, p.real.max() + pad), (p.imag.min() - pad, p.imag.max() + pad)


def plot_nyquist(
    response,
    ax=None,
    gains=None,
    omegas=None,
    n_gains=3,
    n_loci=4,
    n_points=400,
    overview=True,
):
    """Nyquist-plane figure of a :class:`~fitdf.loop.harmonic.LimitCycleResponse`.

    The plant loci ``G(j omega)`` and the critical loci ``-1/N(A, omega)`` (one per
    frequency, amplitude along it), framed on where they meet: the cycles found (filled
    marker: stable by Loeb's criterion; open: unstable), else the first cycle, at the
    critical gain, whose plant locus is then drawn too, else where the loci come closest.
    With ``overview`` a second panel shows the whole loci, the framed region outlined.

    Parameters
    ----------
    response : LimitCycleResponse
    ax : matplotlib Axes, optional
        Draw the framed view into it (its figure is returned; no overview panel).
    gains : sequence of float, optional
        Gains whose plant loci are drawn (default: up to ``n_gains`` of the sweep).
    omegas : sequence of float, optional
        Frequencies (rad/s) of the critical loci (default: those of the intersections,
        up to ``n_loci``; else the critical point's; else a few across the searched range).
    n_points : int
        Points per curve.
    overview : bool
        Add the panel of the whole loci (when ``ax`` is not given).

    Returns
    -------
    matplotlib.figure.Figure
    """
    if ax is None:
        if overview:
            fig, axes = new_figure((11.0, 5.0), 1, 2, width_ratios=(1.7, 1.0))
        else:
            fig, axes = new_figure(FIGSIZE, 1, 1)
        ax, full = axes[0, 0], (axes[0, 1] if overview else None)
    else:
        full = None
    fig = ax.figure
    gains = _pick(response.gains, n_gains) if gains is None else np.atleast_1d(gains)
    cycles = response.intersections
    crit = response.critical_gain
    point = response.critical_point or {}
    first = None  # (gain, omega) of the first cycle, shown when no cycle is
    if not cycles and np.isfinite(crit) and np.isfinite(point.get("omega", np.nan)):
        first = (float(crit), float(point["omega"]))
    if omegas is None:
        if cycles:  # (frequencies the legend would print alike are one locus)
            by_label = {f"{c.omega:.3g}": c.omega for c in cycles}
            omegas = _pick(list(by_label.values()), n_loci)
        elif first is not None:
            omegas = [first[1]]
        else:
            omegas = np.geomspace(*response.omega_range, n_loci + 2)[1:-1]
    drawn, plant_curves, critical_curves = _nyquist_curves(response, gains, omegas, first, n_points)
    for target in (ax, full):
        if target is not None:
            _draw_loci(target, drawn, cycles, labelled=target is ax)
    focus = _mark_cycles(ax, full, cycles, first, response.plant)
    if not cycles:  # and how far the drawn plant loci stay from the critical loci
        pair = _closest_pair(plant_curves[: len(gains)], critical_curves)
        focus += list(pair) if pair is not None else []
    focus = focus or [0j]
    (x0, x1), (y0, y1) = _frame(focus)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    where = "where the loci meet" if cycles or first is not None else "where the loci come closest"
    ax.set_title(f"Nyquist plane, {where}", fontsize="medium")
    ax.legend(fontsize="x-small", loc="best")
    if full is not None:
        (fx0, fx1), (fy0, fy1) = _overview_frame(
            plant_curves + critical_curves + [np.asarray(focus)]
        )
        full.set_xlim(min(fx0, x0), max(fx1, x1))
        full.set_ylim(min(fy0, y0), max(fy1, y1))
        full.add_patch(
            Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, color="C3", lw=1.0, zorder=7)
        )
        full.set_title("whole loci (red box: left panel)", fontsize="medium")
    return fig


def _nyquist_curves(response, gains, omegas, first, n_points):
    """The curves of :func:`plot_nyquist`: ``(drawn, plant_curves, critical_curves)``, where
    ``drawn`` pairs each curve with its style (drawn alike in both panels, labelled in the
    framed one): the plant loci of ``gains`` and of the first cycle's gain, then the critical
    loci at ``omegas``."""
    lp, N = response.plant, response.describing_function
    w = np.geomspace(*response.omega_range, n_points)
    A = np.geomspace(*response.amplitude_range, n_points)
    plant_curves, critical_curves, drawn = [], [], []
    for k, g in enumerate(gains):
        G = lp.response(w, [g])[0]
        plant_curves.append(G)
        drawn.append((G, dict(color=f"C{k}", lw=1.4, label=f"G(jw), K = {g:.4g}")))
    if first is not None:
        G = lp.response(w, [first[0]])[0]
        plant_curves.append(G)
        label = f"G(jw), K = {first[0]:.4g} (critical gain)"
        drawn.append((G, dict(color="C3", lw=1.2, ls="--", label=label)))
    for k, om in enumerate(np.atleast_1d(omegas)):
        with np.errstate(all="ignore"):
            loc = -1.0 / np.asarray(N(A, np.full_like(A, om)), complex)
        critical_curves.append(loc)
        style = dict(color="0.35", lw=1.0, ls=("-", "--", ":", "-.")[k % 4])
        drawn.append((loc, {**style, "label": f"-1/N(A, w), w = {om:.3g} rad/s"}))
    return drawn, plant_curves, critical_curves


def _draw_loci(target, drawn, cycles, labelled: bool) -> None:
    """The curves ``drawn`` (labelled or not) and the cycles on one panel, with its axes."""
    for curve, style in drawn:
        target.plot(curve.real, curve.imag, **(style if labelled else {**style, "label": None}))
    # stable (small, filled) on top of unstable rings
    for c in sorted(cycles, key=lambda c: c.stable):
        target.plot(
            c.G.real,
            c.G.imag,
            "o",
            color="k",
            mfc="k" if c.stable else "white",
            ms=6 if c.stable else 11,
            zorder=6 if c.stable else 5,
        )
    target.axhline(0, color="0.8", lw=0.6)
    target.axvline(0, color="0.8", lw=0.6)
    target.set_xlabel("Re")
    target.set_ylabel("Im")


def _mark_cycles(ax, full, cycles, first, lp) -> list:
    """The cycles' legend entries and amplitudes on the framed panel ``ax``, else the first
    cycle's point (on both panels); returns the points the frame must hold."""
    if cycles:
        ax.plot([], [], "o", color="k", mfc="k", label="stable cycle (Loeb)")
        if not all(c.stable for c in cycles):
            ax.plot([], [], "o", color="k", mfc="white", label="unstable cycle (Loeb)")
        if len(cycles) <= 8:  # cycles at one point of the plane (gains apart) share a label
            spots = {}
            for c in cycles:
                key = min(
                    (k for k in spots if abs(k - c.G) < 1e-3 * abs(c.G)), default=c.G, key=abs
                )
                spots.setdefault(key, []).append(c.amplitude)
            for G, amps in spots.items():
                ax.annotate(
                    "A = " + ", ".join(f"{a:.3g}" for a in sorted(amps)) + " V",
                    (G.real, G.imag),
                    xytext=(8, -10),
                    textcoords="offset points",
                    fontsize="x-small",
                )
        return [c.G for c in cycles]
    if first is not None:
        Gc = complex(lp.response([first[1]], [first[0]])[0, 0])
        ax.plot(Gc.real, Gc.imag, "D", color="C3", ms=6, zorder=6, label="first cycle")
        if full is not None:
            full.plot(Gc.real, Gc.imag, "D", color="C3", ms=6, zorder=6)
        return [Gc]
    return []


#: How each setting of the scales is drawn: (line style, simulated-loop marker, words).
SETTING_STYLES = {
    "unscaled": ("-", "+", "unscaled (\u03b1 = \u03b2 = 1)"),
    "held_out": ("--", "1", "scales fitted to the other blocks"),
    "given": (":", "2", "scales as given"),
}


def _comparison_title(df) -> str:
    """The comparison figure's title: what was compared, and each setting of the scales."""
    settings = list(dict.fromkeys(df["setting"]))
    lines = ["Tables 5.1/5.2 (analog computer) vs harmonic balance with the Appendix B fits"]
    words = {
        "unscaled": "solid: unscaled, the plant and the system gain as printed (\u03b1 = \u03b2 = 1)",
        "held_out": "dashed: G(s/\u03b1) and loop gain \u03b2K, \u03b1 and \u03b2 fitted to "
        "the other three blocks",
        "given": "dotted: \u03b1 and \u03b2 as given",
    }
    return "\n".join(lines + [words[s] for s in settings if s in words])


def plot_thesis_comparison(df):
    """Predicted vs measured limit cycles of Tables 5.1/5.2 (:func:`~fitdf.limit_cycle_tables.thesis_limit_cycle_comparison`).

    Columns are the cores, rows the amplitude and the angular frequency against the system
    gain. Markers: measured (circles 0 ohm, squares 600 ohm; x: the values printed for a row
    marked "oscillations die out"); lines: the predicted largest stable cycle in each setting
    of the scales (solid unscaled, dashed held out, dotted given; the held-out label gives the
    block's ``alpha`` and ``beta``); ``+`` / tri markers: the simulated loop (if the frame has
    it); shaded: the measured die-out bracket (largest gain that died out to smallest that
    oscillated); vertical lines: the predicted critical gains, styled by setting. Every element
    is in the legend under its column; the title says what each setting is.
    """
    cores = list(dict.fromkeys(df["core"]))
    settings = list(dict.fromkeys(df["setting"]))
    fig, axes = new_figure((4.8 * len(cores), 9.0), 2, len(cores), sharex="col")
    for j, core in enumerate(cores):
        sub = df[df["core"] == core]
        for k, (rs, block) in enumerate(sub.groupby("source_impedance_ohm")):
            for i, columns in enumerate(
                (
                    ("amplitude_v", "amplitude_pred", "amplitude_sim"),
                    ("omega_rad_s", "omega_pred", "omega_sim"),
                )
            ):
                _draw_block(axes[i, j], block, settings, columns, rs, k)
        _finish_column(axes[:, j], core)
    fig.suptitle(_comparison_title(df), fontsize="medium")
    return fig


def _draw_block(ax, block, settings, columns, rs, k) -> None:
    """One (core, source impedance) block of :func:`plot_thesis_comparison` on one panel:
    the measured cycles (``columns``: measured, predicted and simulated column), the die-out
    bracket, and per setting of the scales the predicted cycles, the simulated loop and the
    critical gain; ``k`` numbers the block in its column (its colour and marker)."""
    meas, pred, sim = columns
    color, marker = f"C{k}", ("o", "s")[k % 2]
    first = block[block["setting"] == settings[0]].sort_values("system_gain")
    live, dead = first[~first["dies_out"]], first[first["dies_out"]]
    where = f"{rs:g} ohm ({first['table'].iloc[0]}, {first['model'].iloc[0]})"
    lo = dead["system_gain"].max() if not dead.empty else np.nan
    hi = live["system_gain"].min() if not live.empty else np.nan
    ax.plot(
        live["system_gain"], live[meas], marker, color=color, mfc="none", label=f"measured, {where}"
    )
    # the tables print values for some rows marked "oscillations die out"
    shown = dead[np.isfinite(dead[meas])]
    if not shown.empty:
        ax.plot(
            shown["system_gain"],
            shown[meas],
            "x",
            color=color,
            ms=8,
            label=f'printed in a row marked "oscillations die out", {rs:g} ohm',
        )
    if np.isfinite(lo) and np.isfinite(hi):
        ax.axvspan(
            lo, hi, color=color, alpha=0.12, lw=0, label=f"measured die-out bracket, {rs:g} ohm"
        )
    for setting in settings:
        ls, sim_marker, words = SETTING_STYLES[setting]
        b = block[block["setting"] == setting].sort_values("system_gain")
        if setting == "held_out":
            words = f"{words} (\u03b1 {b['alpha'].iloc[0]:.3g}, \u03b2 {b['beta'].iloc[0]:.3g})"
        ax.plot(
            b["system_gain"],
            b[pred],
            ls,
            color=color,
            lw=1.3,
            label=f"predicted largest stable cycle, {words}, {rs:g} ohm",
        )
        if sim in b:
            ax.plot(
                b["system_gain"],
                b[sim],
                sim_marker,
                color=color,
                ms=8,
                label=f"simulated loop, {SETTING_STYLES[setting][2]}, {rs:g} ohm",
            )
        crit = b["critical_gain_pred"].iloc[0]
        if np.isfinite(crit):
            ax.axvline(
                crit,
                color=color,
                ls=ls,
                lw=0.8,
                alpha=0.8,
                label="predicted gain below which no cycle exists, "
                f"{SETTING_STYLES[setting][2]}, {rs:g} ohm",
            )


def _finish_column(column, core) -> None:
    """A core's two panels: title, labels, log axes at 1, 2, 5 x 10^k, and one legend under
    them holding the entries of both (a panel may lack some)."""
    column[0].set_title(f"{core}", fontsize="medium")
    column[0].set_ylabel("amplitude (V)")
    column[1].set_ylabel("omega (rad/s)")
    column[1].set_xlabel("system gain K")
    for ax in column:
        ax.set_xscale("log")
        ax.set_yscale("log")
        for axis in (ax.xaxis, ax.yaxis):  # plain numbers at 1, 2, 5 x 10^k
            axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
            axis.set_major_formatter(FormatStrFormatter("%g"))
            axis.set_minor_formatter(FormatStrFormatter(""))
    entries = {}
    for ax in column:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            entries.setdefault(label, handle)
    column[1].legend(
        entries.values(),
        entries.keys(),
        fontsize="xx-small",
        loc="upper center",
        bbox_to_anchor=(0.5, -0.16),
        ncol=1,
    )


def plot_time_response(response, index=0, hb=None):
    """Error (element input), element output and probe (core current) of one batch member.

    ``hb`` (a :class:`~fitdf.loop.harmonic.LimitCycle`) draws the predicted amplitude.
    """
    n = 3 if response.probe is not None else 2
    fig, axes = new_figure((6.5, 1.8 * n + 0.8), n, 1, sharex=True)
    t = response.t
    axes[0, 0].plot(t, response.error[index], lw=0.8)
    axes[0, 0].set_ylabel("element input e")
    if hb is not None:
        for s in (1, -1):
            axes[0, 0].axhline(s * hb.amplitude, color="C3", ls="--", lw=0.8)
    axes[1, 0].plot(t, response.element_output[index], lw=0.8, color="C1")
    axes[1, 0].set_ylabel("element output")
    if response.probe is not None:
        axes[2, 0].plot(t, response.probe[index], lw=0.8, color="C2")
        axes[2, 0].set_ylabel("core current (A)")
    axes[-1, 0].set_xlabel("t (s)")
    axes[0, 0].set_title(f"closed loop, gain {response.gains[index]:.4g}", fontsize="medium")
    return fig
