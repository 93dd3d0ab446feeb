"""Figures for limit-cycle prediction (thesis V.6, Graphs 5.21 and 5.22).

* :func:`plot_nyquist` -- the Nyquist plane: the plant locus ``K G0(j omega)`` for a few
  gains and the critical loci ``-1/N(A, omega)`` for a few frequencies, with the
  harmonic-balance intersections marked (filled: stable by Loeb's criterion; open:
  unstable). For a measured core the loci lie in the second quadrant (phase lead,
  Fig 5.10).
* :func:`plot_thesis_comparison` -- predicted vs measured amplitude and frequency
  against the system gain for Tables 5.1 and 5.2, with the predicted and measured
  gains at which the oscillation dies out.
* :func:`plot_time_response` -- a simulated loop (:mod:`fitdf.loop.simulate`).

Like :mod:`fitdf.plots.thesis`, figures are built on the Agg canvas without
``pyplot``: no global backend switch and no figure registry that could leak (and warn,
an error under ``filterwarnings = error``). Every function returns the Figure.
"""

from __future__ import annotations

import numpy as np

from fitdf.plots._figure import new_figure

__all__ = ["plot_nyquist", "plot_thesis_comparison", "plot_time_response"]

FIGSIZE = (6.5, 5.0)


def _pick(values, n):
    values = np.unique(np.asarray(values, float))
    if values.size <= n:
        return values
    return values[np.unique(np.round(np.linspace(0, values.size - 1, n)).astype(int))]


def plot_nyquist(response, ax=None, gains=None, omegas=None, n_gains=3, n_loci=4, n_points=400):
    """Nyquist-plane figure of a :class:`~fitdf.loop.harmonic.LimitCycleResponse`.

    Parameters
    ----------
    response : LimitCycleResponse
    ax : matplotlib Axes, optional
        Draw into it (its figure is returned).
    gains : sequence of float, optional
        Gains whose plant loci are drawn (default: up to ``n_gains`` of the sweep).
    omegas : sequence of float, optional
        Frequencies (rad/s) of the critical loci (default: those of the intersections,
        up to ``n_loci``; else a few across the searched range).
    n_points : int
        Points per curve.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if ax is None:
        fig, axes = new_figure(FIGSIZE, 1, 1)
        ax = axes[0, 0]
    fig = ax.figure
    lp, N = response.plant, response.describing_function
    gains = _pick(response.gains, n_gains) if gains is None else np.atleast_1d(gains)
    cycles = response.intersections
    if omegas is None:
        omegas = (
            _pick([c.omega for c in cycles], n_loci)
            if cycles
            else np.geomspace(*response.omega_range, n_loci + 2)[1:-1]
        )
    w = np.geomspace(*response.omega_range, n_points)
    A = np.geomspace(*response.amplitude_range, n_points)
    pts = [0j]
    for k, g in enumerate(gains):
        G = lp.response(w, [g])[0]
        ax.plot(G.real, G.imag, color=f"C{k}", lw=1.4, label=f"G(jw), K = {g:.4g}")
    for k, om in enumerate(np.atleast_1d(omegas)):
        with np.errstate(all="ignore"):
            loc = -1.0 / np.asarray(N(A, np.full_like(A, om)), complex)
        ax.plot(
            loc.real,
            loc.imag,
            color="0.35",
            lw=1.0,
            ls=("-", "--", ":", "-.")[k % 4],
            label=f"-1/N(A), w = {om:.3g} rad/s",
        )
        pts.extend(loc[np.isfinite(loc)])
    for c in sorted(
        cycles, key=lambda c: c.stable
    ):  # stable (small, filled) on top of unstable rings
        ax.plot(
            c.G.real,
            c.G.imag,
            "o",
            color="k",
            mfc="k" if c.stable else "white",
            ms=6 if c.stable else 11,
            zorder=6 if c.stable else 5,
        )
        pts.append(c.G)
    if cycles:
        ax.plot([], [], "o", color="k", mfc="k", label="stable cycle")
        if not all(c.stable for c in cycles):
            ax.plot([], [], "o", color="k", mfc="white", label="unstable cycle")
    pts = np.asarray(pts)
    focus = np.array([c.G for c in cycles] + [0j]) if cycles else pts
    span = max(np.max(np.abs(focus)) * 1.8, 1e-12)
    ax.set_xlim(-span, span * 0.6)
    ax.set_ylim(-span * 0.8, span * 0.8)
    ax.axhline(0, color="0.8", lw=0.6)
    ax.axvline(0, color="0.8", lw=0.6)
    ax.set_xlabel("Re")
    ax.set_ylabel("Im")
    ax.set_title("Nyquist plane: plant loci and critical loci -1/N(A, w)", fontsize="medium")
    ax.legend(fontsize="x-small", loc="lower left")
    return fig


def plot_thesis_comparison(df):
    """Predicted vs measured limit cycles of Tables 5.1/5.2 (:func:`~fitdf.thesis.thesis_limit_cycle_comparison`).

    Columns are the cores, rows the amplitude and the angular frequency against the
    system gain. Markers: measured (circles 0 ohm, squares 600 ohm; x: the values
    printed for a row marked "oscillations die out"); lines: predicted largest stable cycle; plus signs:
    the simulated loop (if the frame has them); dotted verticals: the predicted gain
    below which no cycle exists.
    """
    cores = list(dict.fromkeys(df["core"]))
    fig, axes = new_figure((4.2 * len(cores), 6.2), 2, len(cores), sharex="col")
    for j, core in enumerate(cores):
        sub = df[df["core"] == core]
        for k, (rs, block) in enumerate(sub.groupby("source_impedance_ohm")):
            color, marker = f"C{k}", ("o", "s")[k % 2]
            b = block.sort_values("system_gain")
            live = b[~b["dies_out"]]
            dead = b[b["dies_out"]]
            label = f"{rs:g} ohm ({b['table'].iloc[0]}, {b['model'].iloc[0]})"
            for i, (meas, pred) in enumerate(
                (("amplitude_v", "amplitude_pred"), ("omega_rad_s", "omega_pred"))
            ):
                ax = axes[i, j]
                ax.plot(
                    live["system_gain"],
                    live[meas],
                    marker,
                    color=color,
                    mfc="none",
                    label=f"measured {label}",
                )
                ax.plot(
                    b["system_gain"],
                    b[pred],
                    "-",
                    color=color,
                    lw=1.3,
                    label=f"predicted {rs:g} ohm",
                )
                sim = {"amplitude_pred": "amplitude_sim", "omega_pred": "omega_sim"}[pred]
                if sim in b:
                    ax.plot(
                        b["system_gain"],
                        b[sim],
                        "+",
                        color=color,
                        ms=7,
                        label=f"simulated {rs:g} ohm",
                    )
                shown = dead[
                    np.isfinite(dead[meas])
                ]  # the tables print values for some of these rows
                if not shown.empty:
                    ax.plot(shown["system_gain"], shown[meas], "x", color=color, ms=8)
                crit = b["critical_gain_pred"].iloc[0]
                if np.isfinite(crit):
                    ax.axvline(crit, color=color, ls=":", lw=1.0)
        axes[0, j].set_title(f"{core}", fontsize="medium")
        axes[0, j].set_ylabel("amplitude (V)")
        axes[1, j].set_ylabel("omega (rad/s)")
        axes[1, j].set_xlabel("system gain K")
        for ax in axes[:, j]:
            ax.set_xscale("log")
        axes[0, j].legend(fontsize="x-small")
    alpha, beta = df.attrs.get("alpha", np.nan), df.attrs.get("beta", np.nan)
    fig.suptitle(
        f"Tables 5.1/5.2 vs harmonic balance: G(s/{alpha:.3g}), loop gain {beta:.3g} K",
        fontsize="medium",
    )
    return fig


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
