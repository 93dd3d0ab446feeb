"""Limit cycles as text: what :meth:`LimitCycleResponse.text` and
:meth:`FittedLimitCycles.text` print (the ``fitdf limit-cycle`` output).

Both render a JSON-ready record (their ``to_dict``), so a record read back from JSON prints
the same. Every line fits in :data:`~fitdf._text.TEXT_WIDTH` columns.
"""

from __future__ import annotations

from fitdf._text import TEXT_WIDTH, wrap

__all__ = ["LIMIT_CYCLE_LEGEND", "response_text", "limit_cycle_text"]

#: The legend under the table of cycles (:mod:`fitdf.loop.harmonic` for Loeb's criterion).
LIMIT_CYCLE_LEGEND = (
    "gain: the loop gain K; amplitude: peak of the sinusoid at the core's input (the plant's "
    "output); omega, f: its frequency; stable: whether a slightly larger cycle decays back to it "
    "(yes: the loop settles into this cycle) or grows away (no), by Loeb's criterion; loeb: that "
    "criterion's value, the sine of the angle at which the plant locus G(jw) crosses the critical "
    "locus -1/N(A, w), from -1 to 1: above 0 stable, below 0 unstable, near 0 a fragile verdict."
)


def _cycle_rows(record: dict) -> list[str]:
    """The table: a row per cycle of each gain, ``none`` for a gain without one."""
    lines = [
        f"{'gain':>10s} {'amplitude V':>12s} {'omega rad/s':>12s} {'f Hz':>8s} "
        f"{'stable':>7s} {'loeb':>7s}"
    ]
    by_gain = {}
    for c in record["intersections"]:
        by_gain.setdefault(c["gain"], []).append(c)
    for g in record["gains"]:
        cycles = by_gain.get(g, [])
        if not cycles:
            lines.append(f"{g:>10.4g} {'none':>12s}")
        for c in cycles:
            lines.append(
                f"{g:>10.4g} {c['amplitude']:>12.4g} {c['omega_rad_s']:>12.4g} "
                f"{c['frequency_hz']:>8.3g} {'yes' if c['stable'] else 'no':>7s} {c['loeb']:>7.2f}"
            )
    return lines


def _critical_lines(record: dict, width: int) -> list[str]:
    """Below which gain no cycle exists, and where the first one appears."""
    crit = record.get("critical_gain")
    if crit is None:
        return ["No gain gives a limit cycle in the amplitude range searched."]
    point = record.get("critical_point", {})
    where = " (at the edge of the amplitude range)" if point.get("at_boundary") else ""
    unstable = any("unstable in open loop" in w for w in record.get("warnings", ()))
    # an unstable plant may diverge instead of settling
    below = "No periodic solution below gain" if unstable else "Oscillations die out below gain"
    return wrap(
        f"{below} {crit:.4g}; the first cycle appears at "
        f"A = {point.get('amplitude'):.3g} V, omega = {point.get('omega'):.3g} rad/s{where}.",
        width,
    )


def response_text(record: dict, width: int = TEXT_WIDTH) -> str:
    """A :class:`~fitdf.loop.response.LimitCycleResponse` record (``to_dict``) as text: the
    ranges searched, the cycles of every gain, their legend, the critical gain, the warnings."""
    a, w = record["amplitude_range"], record["omega_range"]
    lines = [
        f"amplitudes searched {a[0]:.3g}..{a[1]:.3g} V, omega {w[0]:.3g}..{w[1]:.3g} rad/s",
        "",
        *_cycle_rows(record),
        "",
        *wrap(LIMIT_CYCLE_LEGEND, width),
        "",
        *_critical_lines(record, width),
    ]
    for warning in record.get("warnings", ()):
        lines += wrap(f"Warning: {warning}.", width, "", "  ")
    return "\n".join(lines)


def limit_cycle_text(record: dict, width: int = TEXT_WIDTH) -> str:
    """A :class:`~fitdf.loop.fitted.FittedLimitCycles` record (``to_dict``) as text: the
    plant and the fitted core, then :func:`response_text`."""
    head = wrap(
        f"Limit cycles of {record['plant']} with the {record['model']} core "
        f"({record['chain']} chain) fitted to {record['data']} at "
        f"{record['source_impedance_ohm']:g} ohm",
        width,
        "",
        "  ",
    )
    return "\n".join([*head, response_text(record, width)])
