"""The computed graphs of thesis Chapter IV (Graphs 4.1-4.7), redrawn from fitdf's models.

Each ``graph_4_*`` function returns a :class:`matplotlib.figure.Figure`; nothing is
shown or saved unless asked (:func:`save_thesis_graphs`). Figures are built with
:class:`~matplotlib.figure.Figure` and the Agg canvas directly rather than through
``pyplot``: no global backend switch, no figure registry to leak (pyplot warns after 20
open figures, an error under ``filterwarnings = error``).

The thesis computed its graphs on an IBM 1620 with ``k = 1`` and ``c = 5``; so do
these, so inputs and outputs are in the thesis's normalised units (``N`` in units of
``k``, amplitudes in the units of ``c/k``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fitdf.models.cubic_hc import (
    KS_MAGNET_STEEL,
    KS_MAGNET_STEEL_SHAPE,
    CubicHc,
    cubic_width,
    ks_magnet_steel_hc,
)
from fitdf.models.proportional_width import (
    ProportionalWidth,
    ProportionalWidthFig42,
    saturation_amplitude,
)
from fitdf.plots._figure import DPI, new_figure

__all__ = [
    "graph_4_1",
    "graph_4_2",
    "graph_4_3",
    "graph_4_4",
    "graph_4_5",
    "graph_4_6",
    "graph_4_7",
    "save_thesis_graphs",
    "THESIS_GRAPHS",
    "KS_SATURATION_C",
]

FIGSIZE = (6.5, 4.5)
K, C = 1.0, 5.0  # the thesis's k = 1, c = 5
M_CURVES = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5)
A_LABEL = "input amplitude A (units of c/k; k = 1, c = 5)"
N_LABEL = "|N| (units of k)"
PHASE_LABEL = "phase of N (deg)"

#: Saturation level of Graph 4.7: the tips of the loop reach ``c`` at ``A = 5``, i.e.
#: ``k (5 - b(5)) = 3.2375`` with the continuous eq 4.11 law (``b(5) = 1.7625``).
KS_SATURATION_C = K * (5.0 - float(cubic_width(5.0, **KS_MAGNET_STEEL)))


def _df_vs_m(model, title):
    m = np.linspace(0.0, 1.0, 401)
    N = model.describing_function(1.0, k=K, c=np.inf, m=m)
    fig, axes = new_figure(FIGSIZE, 2, 1, sharex=True)
    top, bottom = axes.ravel()
    top.plot(m, np.abs(N), label="|N|")
    top.plot(m, N.real, "--", label="Re N")
    top.plot(m, N.imag, ":", label="Im N")
    top.axhline(0.0, color="0.7", lw=0.6)
    top.set_ylabel("N (units of k)")
    top.legend(loc="upper center", ncol=3, fontsize="small")
    # N = 0 at m = 1 (model of Fig 2.3): the phase is undefined there, not 0
    bottom.plot(m, np.where(np.abs(N) > 0, np.degrees(np.angle(N)), np.nan), color="C3")
    bottom.set_ylabel(PHASE_LABEL)
    bottom.set_xlabel("m = b/A (width over amplitude, eq 4.2)")
    fig.suptitle(title)
    return fig


def _df_vs_a(axes, model, ms, a_max=60.0):
    mag, phase = axes
    A = np.linspace(0.05, a_max, 1200)
    for i, m in enumerate(ms):
        N = model.describing_function(A, k=K, c=C, m=m)
        mag.plot(A, np.abs(N), color=f"C{i}", label=f"m = {m:g}")
        phase.plot(A, np.degrees(np.angle(N)), color=f"C{i}")
        a_sat = saturation_amplitude(K, C, m)
        mag.plot(
            [a_sat],
            [np.abs(model.describing_function(a_sat, k=K, c=C, m=m))],
            "o",
            color=f"C{i}",
            ms=3,
        )
    mag.set_ylabel(N_LABEL)
    mag.legend(fontsize="x-small", ncol=2)
    phase.set_ylabel(PHASE_LABEL)
    phase.set_xlabel(A_LABEL)


def _loci(ax, model, ms, a_max=200.0):
    """Critical loci ``-1/N(A)``; arrows point the way of increasing ``A``."""
    for i, m in enumerate(ms):
        a_sat = float(saturation_amplitude(K, C, m))
        A = np.geomspace(0.5 * a_sat, a_max, 600)
        L = -1.0 / model.describing_function(A, k=K, c=C, m=m)
        ax.plot(L.real, L.imag, color=f"C{i}", label=f"m = {m:g}")
        ax.plot(L.real[0], L.imag[0], "o", color=f"C{i}", ms=4)  # A <= A_sat: one point
        for a in (1.5 * a_sat, 4.0 * a_sat):
            j = int(np.searchsorted(A, a))
            if j + 1 < A.size:
                ax.annotate(
                    "",
                    xy=(L.real[j + 1], L.imag[j + 1]),
                    xytext=(L.real[j], L.imag[j]),
                    arrowprops=dict(arrowstyle="-|>", color=f"C{i}", lw=1.2, mutation_scale=12),
                )
    ax.axhline(0.0, color="0.7", lw=0.6)
    ax.axvline(0.0, color="0.7", lw=0.6)
    ax.set_xlim(-8.0, 0.5)
    ax.set_ylim(-4.0, 0.5)
    ax.set_xlabel("Re(-1/N) (units of 1/k)")
    ax.set_ylabel("Im(-1/N) (units of 1/k)")
    ax.legend(
        fontsize="x-small",
        loc="lower right",
        title="dots: A <= A_sat; arrows: A grows",
        title_fontsize="x-small",
    )


def graph_4_1():
    """Graph 4.1: DF of the non-saturating proportional-width loop vs ``m`` (eqs 4.4, 4.5).

    Top: ``|N|``, ``Re N``, ``Im N``; bottom: phase. ``A`` does not enter (``c = inf``);
    ``m = 0`` gives ``1 at 0 degrees``. Two axes.
    """
    return _df_vs_m(
        ProportionalWidth, "Graph 4.1: DF of the non-saturating model (Fig 2.3 loop, b = mA)"
    )


def graph_4_2(ms=M_CURVES):
    """Graph 4.2: DF of the proportional-width loop vs ``A`` with saturation (k=1, c=5).

    ``|N|`` (top) and phase (bottom) for several ``m``; dots mark
    ``A_sat = (c/k)/(1-m)``, below which ``N`` is the Graph 4.1 value. Two axes.
    """
    fig, axes = new_figure(FIGSIZE, 2, 1, sharex=True)
    axes = axes.ravel()
    _df_vs_a(axes, ProportionalWidth, ms)
    fig.suptitle("Graph 4.2: DF with saturation (Fig 2.3 loop, b = mA, k = 1, c = 5)")
    return fig


def graph_4_3(ms=M_CURVES):
    """Graph 4.3: critical loci ``-1/N`` of the proportional-width loop (k=1, c=5).

    Each locus stays at one point up to ``A_sat`` and then runs off to ``-inf`` in the
    third quadrant; arrows show the direction of increasing ``A``. One axis.
    """
    fig, axes = new_figure(FIGSIZE, 1, 1)
    ax = axes[0, 0]
    _loci(ax, ProportionalWidth, ms)
    ax.set_title("Graph 4.3: critical loci -1/N (Fig 2.3 loop, b = mA, k = 1, c = 5)")
    return fig


def graph_4_4():
    """Graph 4.4: DF of the Fig 4.2 loop without saturation vs ``m``: ``1 - m - j 2m/pi``.

    Same layout as :func:`graph_4_1` (two axes); equal to it at ``m = 0.5``.
    """
    return _df_vs_m(
        ProportionalWidthFig42, "Graph 4.4: DF of the second model (Fig 4.2 loop), no saturation"
    )


def graph_4_5(ms=M_CURVES):
    """Graph 4.5: DF of the Fig 4.2 loop with saturation (k=1, c=5), eqs 4.6, 4.7.

    Left: ``|N|`` and phase vs ``A``; right: critical loci ``-1/N`` with arrows of
    increasing ``A``. Three axes. ``m <= 0.5`` only (the thesis calls ``m > 0.5``
    impractical).
    """
    fig = new_figure(FIGSIZE)
    grid = fig.add_gridspec(2, 2)
    mag = fig.add_subplot(grid[0, 0])
    phase = fig.add_subplot(grid[1, 0], sharex=mag)
    loci = fig.add_subplot(grid[:, 1])
    _df_vs_a((mag, phase), ProportionalWidthFig42, ms)
    phase.set_xlabel("A (units of c/k)")
    _loci(loci, ProportionalWidthFig42, ms)
    loci.get_legend().remove()
    fig.suptitle("Graph 4.5: DF of the second model (Fig 4.2 loop), saturation, k = 1, c = 5")
    return fig


def graph_4_6():
    """Graph 4.6: coercive force of K-S magnet steel vs peak field (eq 4.11).

    The printed law (jumps from 1.7625 to 1.8 at ``H_m = 5``) and fitdf's continuous
    version (tail started from the cubic's value). The thesis's experimental curve is
    not in the available copy. One axis.
    """
    hm = np.linspace(0.0, 10.0, 2001)
    fig, axes = new_figure(FIGSIZE, 1, 1)
    ax = axes[0, 0]
    ax.plot(hm, ks_magnet_steel_hc(hm), label="eq 4.11 as printed")
    ax.plot(hm, cubic_width(hm, **KS_MAGNET_STEEL), "--", label="continuous version (cubic_hc)")
    ax.axvline(5.0, color="0.7", lw=0.6)
    ax.set_xlabel("peak field H_m (field units of eq 4.11)")
    ax.set_ylabel("coercive force H_c = b (same units)")
    ax.legend(loc="lower right")
    ax.set_title("Graph 4.6: approximated relation between b and A (K-S magnet steel)")
    return fig


def graph_4_7(c=KS_SATURATION_C):
    """Graph 4.7: DF of the Fig 4.2 loop with the eq 4.11 width law (``A_sat = 5``).

    The graph's title gives the saturation value as ``A = 5``, not ``c``. With the
    width law of eq 4.11 the loop's tips reach ``c`` when ``k (A - b(A)) = c``; choosing
    ``c = k (5 - b(5)) = 3.2375`` (:data:`KS_SATURATION_C`) makes saturation begin at
    ``A = 5`` as titled. (``c = 5`` as in Graphs 4.2-4.5 would move the onset to
    ``A = 6.84``.) Top: ``|N|``, ``Re N``, ``Im N``; bottom: phase. Two axes.
    """
    A = np.linspace(0.02, 20.0, 2000)
    N = CubicHc.describing_function(A, k=K, c=c, **KS_MAGNET_STEEL_SHAPE)
    fig, axes = new_figure(FIGSIZE, 2, 1, sharex=True)
    top, bottom = axes.ravel()
    top.plot(A, np.abs(N), label="|N|")
    top.plot(A, N.real, "--", label="Re N")
    top.plot(A, N.imag, ":", label="Im N")
    top.axhline(0.0, color="0.7", lw=0.6)
    top.set_ylabel("N (units of k)")
    top.legend(fontsize="small")
    bottom.plot(A, np.degrees(np.angle(N)), color="C3")
    bottom.set_ylabel(PHASE_LABEL)
    bottom.set_xlabel("input amplitude A = H_m (field units of eq 4.11; k = 1)")
    for ax in (top, bottom):
        ax.axvline(5.0, color="0.7", lw=0.6)
    fig.suptitle(f"Graph 4.7: DF with the eq 4.11 width law (saturation from A = 5, c = {c:.4g})")
    return fig


#: Thesis graph number -> function.
THESIS_GRAPHS = {
    "4.1": graph_4_1,
    "4.2": graph_4_2,
    "4.3": graph_4_3,
    "4.4": graph_4_4,
    "4.5": graph_4_5,
    "4.6": graph_4_6,
    "4.7": graph_4_7,
}


def save_thesis_graphs(outdir) -> list[Path]:
    """Write Graphs 4.1-4.7 as ``graph_4_N.png`` into ``outdir`` (created if missing).

    Returns
    -------
    list of pathlib.Path
        The files written, in graph order.
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    paths = []
    for number, make in THESIS_GRAPHS.items():
        path = outdir / f"graph_{number.replace('.', '_')}.png"
        make().savefig(path, dpi=DPI)
        paths.append(path)
    return paths
