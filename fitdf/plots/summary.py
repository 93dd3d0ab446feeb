"""The report's opening figure: every law on every block at a glance, and the best fits'
material constants against Appendix A.

* left, :func:`residual_grid`: laws (rows) x blocks (columns), each cell coloured by the
  RMS complex residual ``|fit - measured|`` of that law's least-squares fit (viridis, a
  log scale when the values span more than a decade), the number written in the cell,
  cells without a fit hatched grey, the best law of each block (:func:`best_law`: the
  lowest AICc, the report's best) framed in red;
* right, :func:`constant_rows`: for the best law of each block, the material constants
  of ``appendix_a_check`` (initial permeability, coercive force, peak flux density, ...)
  against the Appendix A range of the core -- one small panel per quantity (log axis where
  the values span more than a decade), one row per core, the range as a bar, each block's
  fitted value as a marker (filled: inside the range; open red: outside it; open grey: a
  value the fit does not determine -- an initial permeability whose small-signal limit the
  law does not reach, a maximum permeability at the edge of the data); a note under the
  panels says what "outside" means and which constants one source impedance leaves open
  (:data:`NOTE`).

The laws are named by their titles beside their code names (``results["models"]``).

Everything is read from the results record of ``fitdf report`` (the dict that becomes
``results.json``): this module never fits. :func:`plot_summary` returns the Figure.

Examples
--------
>>> import json                                                   # doctest: +SKIP
>>> results = json.load(open("reports/results.json"))             # doctest: +SKIP
>>> plot_summary(results).savefig("summary.png")                  # doctest: +SKIP
"""

from __future__ import annotations

import math
import textwrap
from dataclasses import dataclass

import numpy as np
from matplotlib.colors import LogNorm, Normalize
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Rectangle

from fitdf.data.cores import STACKING_FACTOR_RANGE
from fitdf.plots._figure import new_figure

__all__ = [
    "SummaryGrid",
    "residual_grid",
    "constant_rows",
    "plot_summary",
    "best_law",
    "CAPTION",
    "NOTE",
]

#: One sentence saying what the summary figure's colours and marks mean (the report's caption).
CAPTION = (
    "Left: RMS complex residual |fit - measured| of every law's least-squares fit on every "
    "block (colour and number; darker is closer, grey hatched: not fitted; red frame: the "
    "best law of the block, the lowest AICc); right: the material constants of each block's "
    "best fit against "
    "the Appendix A range of its core's material (green bar; circle: a 0 ohm table, square: a "
    "600 ohm table, diamond: both jointly), a filled marker inside the range, an open red one "
    "outside it (the fitted constant, at the nominal stacking factor 0.85, lies outside the "
    "catalogue range of the material; for the series resistance, outside the central 95 % of "
    "its prior), an open grey one where the fit does not determine the constant; a whisker "
    "spans an induction or permeability over the stacking factors of tape-wound cores "
    "(0.50-0.90), which the data do not determine."
)

#: What the constants panel's marks mean, and what the data leave open (drawn under it; the
#: second sentence only where a marker is grey).
NOTE = (
    "Outside: the fitted constant, at the nominal stacking factor 0.85, lies outside the "
    "Appendix A catalogue range of the core's material (series resistance: outside the "
    "central 95 % of its prior). Grey: not determined (no small-signal limit; maximum at the "
    "edge of the data). At one source impedance (circles, squares) the permeabilities and "
    "$H_c$ trade against the series resistance (*); inductions and permeabilities carry the "
    "unprinted iron fraction of the section (**): the whiskers span stacking factors 0.50-0.90."
)
_GREY = "Grey: not determined (no small-signal limit; maximum at the edge of the data). "
#: Short notes beside the panels' titles, by quantity (see :data:`NOTE`).
_PANEL_NOTES = {
    "initial_permeability": "(*, **)",
    "maximum_permeability": "(*, **)",
    "coercive_force_Hc": "(*)",
    "peak_flux_density_Bp": "(**)",
    "residual_induction_Br": "(**)",
}

_CMAP = "viridis"
_BEST = "#d62728"
_INSIDE, _OUTSIDE, _RANGE, _OPEN = "#1f3b73", "#d62728", "#b8dfb0", "0.45"
#: Marker per kind of block: a 0 ohm table, a 600 ohm table, a joint fit of both.
_MARKERS = {"0 ohm table": "o", "600 ohm table": "s", "joint fit": "D"}
_QUANTITY_LABELS = {
    "initial_permeability": "initial permeability",
    "maximum_permeability": "maximum permeability",
    "coercive_force_Hc": "coercive force $H_c$",
    "peak_flux_density_Bp": "peak flux density $B_p$",
    "residual_induction_Br": "residual induction $B_r$",
    "squareness_Br_over_Bp": "squareness $B_r/B_p$",
    "series_resistance": "series resistance",
}


@dataclass(frozen=True)
class SummaryGrid:
    """The residual grid of :func:`plot_summary` (what the left panel draws).

    Attributes
    ----------
    laws : list of str
        Rows, top to bottom: the laws ordered by their mean rank over the blocks.
    blocks : list of str
        Columns: block keys, in the order of ``results["blocks"]``.
    labels : list of str
        Column labels (tables, core, source impedance).
    rms : numpy.ndarray
        ``(len(laws), len(blocks))`` RMS complex residuals; NaN where a law has no fit.
    best : list of int or None
        Per block, the row of its best law (:func:`best_law`).
    """

    laws: list
    blocks: list
    labels: list
    rms: np.ndarray
    best: list


def _float(v) -> float:
    return float("nan") if v is None else float(v)


def best_law(rec: dict):
    """A block record's best law: the lowest AICc of its least-squares ranking (the first of
    equals; the report's rule, :func:`fitdf.report.criteria.best_law`), or None."""
    rows = [r for r in rec.get("ranking_lsq") or [] if r.get("aicc") is not None]
    return min(rows, key=lambda r: r["aicc"])["model"] if rows else None


def _column_label(key: str, rec: dict) -> str:
    tables = rec.get("tables") or [key]
    ohms = rec.get("source_impedance_ohm") or []
    core = str(rec.get("core", "")).capitalize()
    ohm = "+".join(f"{o:g}" for o in ohms)
    return "\n".join(x for x in ("+".join(tables), core, f"{ohm} ohm" if ohm else "") if x)


def residual_grid(results: dict) -> SummaryGrid:
    """Laws x blocks of the RMS complex residual of each least-squares fit, and each block's best.

    Parameters
    ----------
    results : dict
        The results record of ``fitdf report`` (``results.json``).

    Returns
    -------
    SummaryGrid
    """
    recs = results.get("blocks") or {}
    blocks = list(recs)
    laws = list((results.get("settings") or {}).get("models") or [])
    for rec in recs.values():
        laws += [row["model"] for row in rec.get("ranking_lsq") or [] if row["model"] not in laws]
    ranks = {law: [] for law in laws}
    for rec in recs.values():
        rows = rec.get("ranking_lsq") or []
        for i, row in enumerate(rows):
            ranks[row["model"]].append(i / max(len(rows) - 1, 1))
    given = list(laws)
    laws.sort(key=lambda m: (np.mean(ranks[m]) if ranks[m] else math.inf, given.index(m)))
    rms = np.full((len(laws), len(blocks)), np.nan)
    best = []
    for j, key in enumerate(blocks):
        rows = recs[key].get("ranking_lsq") or []
        for row in rows:
            rms[laws.index(row["model"]), j] = _float(row.get("rms_complex"))
        law = best_law(recs[key])
        best.append(laws.index(law) if law is not None else None)
    labels = [_column_label(k, recs[k]) for k in blocks]
    return SummaryGrid(laws, blocks, labels, rms, best)


def _block_kind(rec: dict) -> str:
    ohms = rec.get("source_impedance_ohm") or []
    if len(ohms) > 1:
        return "joint fit"
    return "0 ohm table" if ohms and float(ohms[0]) == 0.0 else "600 ohm table"


def constant_rows(results: dict) -> list[dict]:
    """The best fit of each block against Appendix A, one row per core and quantity.

    Returns
    -------
    list of dict
        ``{core, quantity, unit, low, high, fits}`` in the order cores and quantities
        first appear; ``fits`` is a list of ``{block, kind, model, fitted, inside,
        determined, fitted_low, fitted_high}`` (``fitted_low``/``fitted_high``: the value
        over the stacking factor's range, equal to ``fitted`` where it does not depend on
        it; one per block of the core whose best least-squares fit has an
        ``appendix_a_check``; ``determined`` False for an initial permeability whose
        small-signal limit the fit does not reach, ``material.initial_converged``, and a
        maximum permeability at the edge of the data, ``material.maximum_at_edge``).
        Empty when no fit has one.
    """
    rows: dict = {}
    for key, rec in (results.get("blocks") or {}).items():
        law = best_law(rec)
        if law is None:
            continue
        fit = (rec.get("fits_lsq") or {}).get(law) or {}
        material = fit.get("material") or {}
        open_ = {
            "initial_permeability": material.get("initial_converged") is False,
            "maximum_permeability": bool(material.get("maximum_at_edge")),
        }
        for c in fit.get("appendix_a_check") or []:
            row = rows.setdefault(
                (rec["core"], c["quantity"]),
                {
                    "core": rec["core"],
                    "quantity": c["quantity"],
                    "unit": c["unit"],
                    "low": _float(c["low"]),
                    "high": _float(c["high"]),
                    "fits": [],
                },
            )
            row["fits"].append(
                {
                    "block": key,
                    "kind": _block_kind(rec),
                    "model": law,
                    "fitted": _float(c["fitted"]),
                    "fitted_low": _float(c.get("fitted_low", c["fitted"])),
                    "fitted_high": _float(c.get("fitted_high", c["fitted"])),
                    "inside": bool(c["inside"]),
                    "determined": not open_.get(c["quantity"], False),
                }
            )
    return list(rows.values())


# ------------------------------------------------------------------ drawing
#: Inches of the grid panel: per law (up to a row height of 1 inch when the constants panel
#: beside it is taller) and for the title, column labels and colour bar.
_GRID_ROW, _GRID_EXTRA = 0.62, 2.3
#: Characters per line of a law's title beside the grid.
_TITLE_WIDTH = 26


def _law_tick(name: str, titles: dict) -> str:
    """A grid row's label: the law's title (wrapped) over its code name in brackets."""
    title = titles.get(name)
    if not title:
        return name
    return "\n".join([*textwrap.wrap(title, _TITLE_WIDTH), f"[{name}]"])


def _grid_axes(fig, height, n):
    """The grid's axes and its colour bar's, at the top of ``fig``; the rest left blank."""
    grid_h = min(height - _GRID_EXTRA, 1.0 * n)
    spare = height - _GRID_EXTRA - grid_h
    ratios = [grid_h, 0.12] + ([spare] if spare > 0.05 else [])
    gs = fig.add_gridspec(len(ratios), 1, height_ratios=ratios)
    return fig.add_subplot(gs[0]), fig.add_subplot(gs[1])


def _draw_grid(ax, cax, grid: SummaryGrid, titles: dict) -> None:
    values = grid.rms[np.isfinite(grid.rms) & (grid.rms > 0)]
    lo, hi = (values.min(), values.max()) if values.size else (1e-3, 1.0)
    if hi <= lo:  # one value: a band around it
        lo, hi = 0.9 * lo, 1.1 * hi
    norm = LogNorm(lo, hi) if hi > 10 * lo else Normalize(lo, hi)
    image = ax.imshow(
        np.ma.masked_invalid(grid.rms), cmap=_CMAP, norm=norm, aspect="auto", interpolation="none"
    )
    cmap = image.get_cmap()
    n, m = grid.rms.shape
    for i in range(n):
        for j in range(m):
            v = grid.rms[i, j]
            best = grid.best[j] == i
            if not np.isfinite(v):
                ax.add_patch(
                    Rectangle(
                        (j - 0.5, i - 0.5), 1, 1, facecolor="0.88", edgecolor="0.6", hatch="///"
                    )
                )
                continue
            r, g, b, _ = cmap(norm(v))
            dark = 0.299 * r + 0.587 * g + 0.114 * b < 0.55
            ax.text(
                j,
                i,
                f"{v:.3g}",
                ha="center",
                va="center",
                fontsize=10,
                color="white" if dark else "black",
                fontweight="bold" if best else "normal",
            )
    for j, i in enumerate(grid.best):
        if i is not None:
            ax.add_patch(
                Rectangle(
                    (j - 0.46, i - 0.46), 0.92, 0.92, fill=False, edgecolor=_BEST, lw=2.8, zorder=3
                )
            )
    ax.set_xticks(range(m), grid.labels, fontsize=9)
    ax.set_yticks(range(n), [_law_tick(m, titles) for m in grid.laws], fontsize=8)
    ax.xaxis.tick_top()
    ax.tick_params(length=0)
    ax.set_xticks(np.arange(-0.5, m), minor=True)
    ax.set_yticks(np.arange(-0.5, n), minor=True)
    ax.grid(which="minor", color="white", lw=1.5)
    ax.tick_params(which="minor", length=0)
    for side in ax.spines.values():
        side.set_visible(False)
    ax.get_figure(root=False).suptitle(
        "RMS complex residual of each law's fit"
        + ("\n" if m < 6 else " ")  # a narrow grid: two lines
        + "(red frame: best of the block, lowest AICc)",
        fontsize=11,
        x=0.02,
        ha="left",
    )
    bar = ax.figure.colorbar(image, cax=cax, orientation="horizontal")
    bar.set_label(
        "RMS complex residual |fit - measured|" + (" (log scale)" if hi > 10 * lo else ""),
        fontsize=9,
    )
    bar.ax.tick_params(labelsize=8)


def _span_is_log(values) -> bool:
    """Log axis when the positive values span more than a decade (zeros sit at the left edge)."""
    v = np.asarray([x for x in values if np.isfinite(x)], float)
    return bool(v.size and np.all(v >= 0) and np.any(v > 0) and v.max() > 10 * v[v > 0].min())


def _note(ax, x, y, text, color, dx=2):
    ax.annotate(
        text,
        (x, y),
        xytext=(dx, 0),
        textcoords="offset points",
        va="center",
        fontsize=7,
        color=color,
    )


def _draw_quantity(ax, rows: list[dict], cores: list[str], show_xlabel_unit=True) -> None:
    """One quantity: a row per core, the Appendix A range as a bar, each block's best fit a marker."""
    q, unit = rows[0]["quantity"], rows[0]["unit"]
    finite = [r["low"] for r in rows] + [r["high"] for r in rows]
    finite += [
        f[k]
        for r in rows
        for f in r["fits"]
        for k in ("fitted", "fitted_low", "fitted_high")
        if k in f
    ]
    log = _span_is_log(finite)
    vals = np.asarray([x for x in finite if np.isfinite(x) and (x > 0 or not log)], float)
    if log:
        ax.set_xscale("log")
        lo, hi = vals.min() / 3.0, vals.max() * 2.0  # room at the left for zeros
    else:
        pad = 0.08 * (vals.max() - vals.min() or max(abs(vals.max()), 1.0)) if vals.size else 1.0
        lo, hi = (vals.min() - pad, vals.max() + pad) if vals.size else (0.0, 1.0)
    ax.set_xlim(lo, hi)
    for r in rows:
        y = cores.index(r["core"])
        high = r["high"] if np.isfinite(r["high"]) else hi
        ax.barh(y, high - r["low"], left=r["low"], height=0.62, color=_RANGE, lw=0, zorder=1)
        if not np.isfinite(r["high"]):  # no upper limit: the bar runs off the panel
            ax.plot(hi, y, ">", color=_RANGE, ms=9, clip_on=False, zorder=1)
        offsets = np.linspace(-0.2, 0.2, len(r["fits"])) if len(r["fits"]) > 1 else [0.0]
        at_edge = []  # values off a log axis (zeros): drawn just inside the left edge, written once
        for f, dy in zip(r["fits"], offsets):
            marker = _MARKERS.get(f["kind"], "o")
            if not np.isfinite(f["fitted"]):  # the loop does not define it
                _note(ax, lo, y + dy, "n/a", "0.35")
                continue
            x = f["fitted"]
            if log and x <= lo:
                x = lo * 1.4
                at_edge.append(f"{f['fitted']:.3g}")
            edge = _OPEN if not f.get("determined", True) else _INSIDE if f["inside"] else _OUTSIDE
            f_lo, f_hi = f.get("fitted_low", f["fitted"]), f.get("fitted_high", f["fitted"])
            if np.isfinite(f_lo) and np.isfinite(f_hi) and f_hi > f_lo and not (log and f_lo <= 0):
                # the value over the stacking factor's range (the data do not determine it)
                ax.plot([f_lo, f_hi], [y + dy] * 2, color=edge, lw=1.0, zorder=2, clip_on=False)
            ax.plot(
                x,
                y + dy,
                marker,
                ms=6.5,
                mew=1.6,
                mfc=_INSIDE if f["inside"] and f.get("determined", True) else "white",
                mec=edge,
                zorder=3,
                clip_on=False,
            )
        if at_edge:
            _note(ax, lo * 1.4, y, " ".join(dict.fromkeys(at_edge)), _OUTSIDE, dx=7)
    ax.set_ylim(len(cores) - 0.5, -0.5)
    ax.set_yticks(range(len(cores)), [c.capitalize() for c in cores], fontsize=8)
    ax.tick_params(axis="x", labelsize=8, pad=1)
    ax.tick_params(axis="y", length=0)
    ax.grid(axis="x", color="0.9", lw=0.6)
    ax.set_axisbelow(True)
    label = _QUANTITY_LABELS.get(q, q.replace("_", " "))
    note = _PANEL_NOTES.get(q, "")
    ax.set_title(
        (f"{label} ({unit})" if unit else label) + (f" {note}" if note else ""),
        fontsize=9,
        loc="left",
        pad=2,
    )


def _constants_legend(fig, kinds, undetermined: bool) -> None:
    """The markers' key, then :data:`NOTE`, under the constants panels."""
    handles = [
        Line2D([], [], ls="none", marker=_MARKERS[k], ms=6.5, mfc="0.5", mec="0.5", label=k)
        for k in _MARKERS
        if k in kinds
    ]
    marks = [("inside the range", _INSIDE, _INSIDE), ("outside it", "white", _OUTSIDE)]
    if undetermined:
        marks.append(("not determined", "white", _OPEN))
    handles += [
        Line2D([], [], ls="none", marker="o", ms=6.5, mew=1.6, mfc=face, mec=edge, label=text)
        for text, face, edge in marks
    ]
    handles.append(Patch(color=_RANGE, label="Appendix A range"))
    handles.append(
        Line2D(
            [],
            [],
            color="0.3",
            lw=1.0,
            label=f"stacking factor {STACKING_FACTOR_RANGE[0]:.2f}-{STACKING_FACTOR_RANGE[1]:.2f}",
        )
    )
    legend = fig.legend(
        handles=handles,
        loc="outside lower center",
        ncol=3,
        fontsize=8,
        frameon=False,
        columnspacing=1.0,
        handletextpad=0.3,
        title="\n".join(textwrap.wrap(NOTE if undetermined else NOTE.replace(_GREY, ""), 88)),
        title_fontsize=7,
    )
    legend.get_title().set_multialignment("left")
    legend._legend_box.align = "left"  # the note's lines flush left above the key


def plot_summary(results: dict):
    """The summary figure of a report's results record (see the module docstring).

    Parameters
    ----------
    results : dict
        The results record of ``fitdf report`` (``results.json``).

    Returns
    -------
    matplotlib.figure.Figure
        ``fig.axes[0]`` is the residual grid (its image holds :func:`residual_grid`'s
        ``rms``, masked where NaN); the constants panels follow.

    Raises
    ------
    ValueError
        When the record holds no block with a ranking.
    """
    grid = residual_grid(results)
    titles = {m["name"]: m.get("title") for m in results.get("models") or []}
    if not grid.blocks or all(b is None for b in grid.best):
        raise ValueError("the results record holds no ranked block to summarise")
    consts = constant_rows(results)
    n, m = grid.rms.shape
    width = max(4.4, 1.7 + 0.92 * m)  # inches of the grid panel
    height = _GRID_EXTRA + _GRID_ROW * n
    if not consts:
        fig = new_figure((width, height))
        _draw_grid(*_grid_axes(fig, height, n), grid, titles)
        return fig
    quantities = list(dict.fromkeys(r["quantity"] for r in consts))
    cores = list(dict.fromkeys(r["core"] for r in consts))
    height = max(height, 0.55 + len(quantities) * (0.5 + 0.24 * len(cores)))
    fig = new_figure((width + 4.6, height))
    left, right = fig.subfigures(1, 2, width_ratios=[width, 4.6], wspace=0.02)
    _draw_grid(*_grid_axes(left, height, n), grid, titles)
    axes = right.subplots(len(quantities), 1, squeeze=False)[:, 0]
    for a, q in zip(axes, quantities):
        _draw_quantity(a, [r for r in consts if r["quantity"] == q], cores)
    right.suptitle("Best fit of each block against Appendix A", fontsize=11, x=0.02, ha="left")
    fits = [f for r in consts for f in r["fits"]]
    _constants_legend(
        right, {f["kind"] for f in fits}, any(not f.get("determined", True) for f in fits)
    )
    return fig
