"""Shared pieces of the fit figures: panel layout, measured points, labels and legends.

Conventions (thesis Chapter V): input volts on x, the measured DF is ``|DF|`` (output
over input volts) and a *phase lead* in degrees; measured rows are black dots. Several
results are drawn in the order given, with colours ``C0, C1, ...``; the first one is
"the best" (pass a ranking's order).
"""

from __future__ import annotations

import textwrap

import numpy as np

from fitdf.errors import ModelError
from fitdf.models import get_model

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


def law_label(name: str, width: int | None = None) -> str:
    """A law's human name beside its code name, ``Title [code]`` (the law's ``title``); the
    code name alone for a law not registered. ``width``: wrap the title to lines of that
    many characters, the code name on a line of its own."""
    try:
        title = get_model(name).title
    except ModelError:
        return str(name)
    if width is None:
        return f"{title} [{name}]"
    return "\n".join([*textwrap.wrap(title, width), f"[{name}]"])


def _label(result, results, width=None):
    """Legend label: the law (:func:`law_label`), plus the method when methods are mixed."""
    methods = {r.method for r in results}
    text = law_label(result.model, width)
    return text if len(methods) == 1 else f"{text} ({result.method})"


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


#: Points per character of the legends' text (8.3 pt "small" type, on average).
_CHAR_PT = 4.6


def _legend(fig, handles, ncol=None):
    """The figure's legend below its panels; long labels (laws' names) in two columns, and
    wrapped where a column would not fit the figure's width."""
    if ncol is None:
        long = max(len(h.get_label()) for h in handles) > 40
        ncol = min(len(handles), 2 if long else 4)
    chars = int(fig.get_figwidth() * 72 / ncol / _CHAR_PT) - 8  # (the handle and the gap)
    for h in handles:
        h.set_label("\n".join(textwrap.wrap(h.get_label(), max(chars, 20))))
    fig.legend(
        handles=handles,
        loc="outside lower center",
        ncol=ncol,
        fontsize="small",
        frameon=False,
    )
