"""The sentences of the Tables 5.1/5.2 comparison, each made from named fields of its record.

:func:`limit_cycle_statements` reads the ``attrs`` of
:func:`fitdf.limit_cycle_tables.thesis_limit_cycle_comparison` (as written to the report's
``results.json``: NaN as None) and nothing else, so a sentence can always be recomputed from
the record it stands in. The verdicts follow the rules of :mod:`fitdf.limit_cycle_tables.summary`; a
check is *confirmed* when it holds in every block (or every pair of rows) it applies to.
"""

from __future__ import annotations

import math

from fitdf.limit_cycle_tables.summary import LEVEL_CONFIDENCE

__all__ = ["limit_cycle_statements", "SETTING_WORDS", "exp_or_none"]

#: The intervals' confidence as the sentences write it (``95 %``).
_PERCENT = f"{100 * LEVEL_CONFIDENCE:g} %"

#: How a sentence names each setting of the scales.
SETTING_WORDS = {
    "unscaled": "unscaled",
    "held_out": "held out",
    "given": "with the given scales",
}


def exp_or_none(x):
    """``exp(x)``, None for None (a NaN in the record)."""
    return None if x is None else math.exp(x)


def _num(x, fmt=".2f") -> str:
    return "n/a" if x is None else format(x, fmt)


def _range(values, fmt=".2f") -> str:
    v = [x for x in values if x is not None]
    return "n/a" if not v else f"{min(v):{fmt}}-{max(v):{fmt}}"


def _blocks(per_setting: dict) -> dict:
    """The per-block entries of a setting's summary (``all`` left out)."""
    return {k: v for k, v in per_setting.items() if k != "all"}


def _count(values) -> tuple[int, int, list]:
    """``(held, applicable, names held)`` of ``{name: True / False / None}`` (None: not applicable)."""
    ok = {k: v for k, v in values.items() if v is not None}
    held = [k for k, v in ok.items() if v]
    return len(held), len(ok), held


def _which(names) -> str:
    return f" ({', '.join(names)})" if names else ""


def _level(ag, setting, q):
    return _count({k: v[f"{q}_level_consistent"] for k, v in _blocks(ag[setting]).items()})


def _trend(tr, setting, q):
    return _count({k: v[q]["consistent"] for k, v in tr[setting].items()})


def _unscaled(ag) -> str:
    a = ag["unscaled"]["all"]
    blocks = _blocks(ag["unscaled"]).values()
    return (
        "Unscaled (the plant as printed, the system gain as the loop gain, nothing fitted to "
        "Tables 5.1/5.2), harmonic balance with the fitted cores puts the frequency at "
        f"{_num(a['median_omega_ratio'])} of the measured one (median predicted over measured; "
        f"per block {_range(b['median_omega_ratio'] for b in blocks)}) and the amplitude at "
        f"{_num(a['median_amplitude_ratio'])} (per block "
        f"{_range(b['median_amplitude_ratio'] for b in blocks)}), over the "
        f"{a['rows_predicted']} of {a['rows_oscillating']} rows measured oscillating that have "
        f"a predicted cycle; {a['rows_extrapolated']} of those cycles lie outside the amplitudes "
        "or frequencies the fits saw."
    )


def _scales(sc) -> str:
    sp, j = sc["spread"], sc["joint"]
    return (
        "Fitted to each block's own rows (in-sample), the computer's time scale would be "
        f"{_num(sp['alpha_min'])}-{_num(sp['alpha_max'])} and its gain scale "
        f"{_num(sp['beta_min'])}-{_num(sp['beta_max'])}; one pair fitted to all rows "
        f"(time {_num(j['alpha'])}, gain {_num(j['beta'])}) leaves "
        f"{_num(j['rms_phase_deg'], '.1f')} deg RMS of phase and a factor "
        f"{_num(j['rms_magnitude_factor'])} RMS of magnitude in the balance: an in-sample fit "
        "of the scales, not a prediction."
    )


def _held_out(ag, sc) -> str:
    a = ag["held_out"]["all"]
    blocks = _blocks(ag["held_out"]).values()
    h = sc["held_out"].values()
    return (
        "With the scales fitted to three blocks and used on the fourth (leave one block out; "
        f"time scale {_range(x['alpha'] for x in h)}, gain scale "
        f"{_range(x['beta'] for x in h)} across the four fits), the frequency comes out at "
        f"{_num(a['median_omega_ratio'])} of the measured one (per block "
        f"{_range(b['median_omega_ratio'] for b in blocks)}) and the amplitude at "
        f"{_num(a['median_amplitude_ratio'])} (per block "
        f"{_range(b['median_amplitude_ratio'] for b in blocks)}); {a['rows_extrapolated']} of "
        f"the {a['rows_predicted']} predicted cycles lie outside the amplitudes or frequencies "
        "the fits saw."
    )


def _levels(ag) -> str:
    parts = []
    for q, word in (("omega", "frequency"), ("amplitude", "amplitude")):
        per = []
        for setting in [s for s in ("unscaled", "held_out") if s in ag]:
            k, n, names = _level(ag, setting, q)
            per.append(f"{k} of {n} blocks {SETTING_WORDS[setting]}{_which(names)}")
        parts.append(f"the {word} in {' and '.join(per)}")
    return (
        f"The level of the prediction is within its rows' scatter (the {_PERCENT} interval of the "
        f"mean log ratio holds 0) for {parts[0]}, and for {parts[1]}."
    )


def _trends(tr) -> str:
    parts = []
    for q, word in (("amplitude", "amplitude"), ("omega", "frequency")):
        blocks = tr["unscaled"].values()
        k, n, _ = _trend(tr, "unscaled", q)
        parts.append(
            f"the exponent of {word} in the system gain, measured "
            f"{_range(b[q]['measured_slope'] for b in blocks)} across the blocks, is predicted "
            f"within its {_PERCENT} interval in {k} of {n} blocks (predicted "
            f"{_range(b[q]['predicted_slope'] for b in blocks)})"
        )
    return f"Unscaled, {parts[0]}; {parts[1]}."


def _order(io) -> str:
    o = io["unscaled"]
    ranges = []
    for q, word in (("amplitude", "amplitude"), ("omega", "frequency")):
        m = [exp_or_none(p[f"log_{q}_ratio_measured"]) for p in o["rows"]]
        p_ = [exp_or_none(p[f"log_{q}_ratio_predicted"]) for p in o["rows"]]
        ranges.append(f"{word} measured {_range(m)}, predicted {_range(p_)}")
    return (
        f"At the {o['pairs']} system gains where both source impedances of a core oscillated, "
        "the unscaled prediction has the sign of the difference between the two impedances "
        f"as measured for the frequency at {o['omega_agree']} of {o['pairs']} and for the "
        f"amplitude at {o['amplitude_agree']} of {o['pairs']} (the value at the higher "
        "impedance over that at the lower: "
        f"{'; '.join(ranges)})."
    )


def _positions(cg, setting) -> str:
    """``below the measured bracket in k, inside it in i and above it in a of the n blocks``."""
    pos = [c["predicted"][setting]["position"] for c in cg]
    return (
        f"below the measured die-out bracket in {pos.count('below')}, inside it in "
        f"{pos.count('inside')} and above it in {pos.count('above')} of the {len(cg)} blocks"
    )


def _critical(cg, dead) -> str:
    settings = [s for s in ("unscaled", "held_out") if s in cg[0]["predicted"]]
    detail = "; ".join(
        f"{c['table']} {_num(c['predicted']['unscaled']['critical_gain'], '.0f')} against "
        f"{_num(c['measured_dies_out_at'], '.0f')}-{_num(c['measured_lowest_oscillating'], '.0f')}"
        for c in cg
    )
    where = [f"{SETTING_WORDS[s]}, {_positions(cg, s)}" for s in settings]
    where[0] += f" ({detail})"
    osc = [
        f"{sum(d['settings'][s]['predicted_to_oscillate'] for d in dead)} ({SETTING_WORDS[s]})"
        for s in settings
    ]
    return (
        "The predicted critical gain (below it harmonic balance finds no cycle) against the "
        "measured bracket (the largest gain at which the oscillations died out, the smallest "
        f"at which they did not): {'; '.join(where)}. Harmonic balance predicts an "
        f'oscillation at {" and ".join(osc)} of the {len(dead)} rows marked "oscillations die '
        'out".'
    )


def _rows_imply(cg, implied) -> str | None:
    """What the Appendix B rows say of the critical gains with no law fitted
    (:mod:`fitdf.limit_cycle_tables.data_bound`), and where the laws' critical points lie."""
    cg = [c for c in cg if c["table"] in implied and implied[c["table"]]["critical_gain"]]
    if not cg:
        return None
    rows = "; ".join(
        f"{c['table']} {_num(implied[c['table']]['critical_gain'], '.0f')} (at "
        f"{_num(implied[c['table']]['lowest_frequency_hz'], 'g')} c/s; "
        f"{_num(c['measured_dies_out_at'], '.0f')} died out, "
        f"{_num(_ratio(c['measured_dies_out_at'], implied[c['table']]['critical_gain']), '.1f')} "
        "times higher)"
        for c in cg
    )
    rise = ", ".join(f"{c['table']} {_num(implied[c['table']]['rise'], '.2f')}" for c in cg)
    omega = [c["predicted"]["unscaled"].get("critical_omega_rad_s") for c in cg]
    where = ""
    if all(w is not None for w in omega):
        lowest = min(implied[c["table"]]["lowest_frequency_hz"] for c in cg)
        below = sum(w / (2 * math.pi) < lowest for w in omega)
        where = (
            f" The unscaled critical points lie at {_range(omega, '.2g')} rad/s "
            f"({_range([w / (2 * math.pi) for w in omega], '.2g')} c/s), below every measured "
            f"frequency in {below} of the {len(cg)} blocks: there the critical gain rests on "
            "the law's describing function below the rows, an extrapolation no row measures."
        )
    return (
        "With no law fitted, each Appendix B row taken as the core's describing function where "
        "it balances the printed plant closes the loop at a gain; the smallest at each "
        f"table's lowest measured frequency: {rows}. From the highest measured frequency to the "
        f"lowest these gains change by a factor {rise}.{where}"
    )


def _ratio(a, b):
    return None if a is None or not b else a / b


def _time_domain(td, dead, setting) -> str:
    a = td[setting]["all"]
    rows = [d["settings"][setting] for d in dead]
    h = sum(r["predicted_to_oscillate"] for r in rows)
    sims = [r["sim_state"] for r in rows]
    s, u = sims.count("oscillates"), sims.count("unsettled")
    # row by row: the simulation oscillates exactly where harmonic balance predicts a cycle
    agree = all((r["sim_state"] == "oscillates") == r["predicted_to_oscillate"] for r in rows)
    verdict = (
        ": harmonic balance and the simulation agree there, so the describing-function "
        "approximation does not explain those rows"
        if agree and u == 0
        else f" and has not settled at {u} (harmonic balance predicts an oscillation at {h})"
    )
    return (
        f"Simulated in time with the same fitted cores ({SETTING_WORDS[setting]}), the loop "
        f"settles to the cycle harmonic balance predicts at {a['rows_compared']} of the "
        f"{a['rows_oscillating']} rows measured oscillating; there harmonic balance is within "
        f"{_num(a['rms_log_amplitude_hb_over_sim'], '.3f')} (amplitude) and "
        f"{_num(a['rms_log_omega_hb_over_sim'], '.3f')} (frequency) RMS log ratio of the "
        "simulation -- the describing-function approximation -- while the simulation differs "
        f"from the table by {_num(a['rms_log_amplitude_sim_over_measured'])} and "
        f"{_num(a['rms_log_omega_sim_over_measured'])} -- the law, the loop's assumptions and "
        f"the scales. The simulated loop oscillates at {s} of the {len(dead)} rows marked "
        f'"oscillations die out"{verdict}.'
    )


def _checks(attrs) -> list:
    """``(phrase, held, applicable, unit)`` of every check the tables can confirm."""
    ag, tr = attrs["agreement"], attrs["trends"]
    io, cg = attrs["impedance_order"], attrs["critical_gains"]
    out = []
    for q, word in (("amplitude", "amplitude"), ("omega", "frequency")):
        k, n, _ = _trend(tr, "unscaled", q)
        out.append((f"the exponent of {word} in the system gain", k, n, "blocks"))
    o = io["unscaled"]
    out.append(
        (
            "the sign of the source impedance's effect on the frequency at equal gain",
            o["omega_agree"],
            o["pairs"],
            "gains",
        )
    )
    out.append(
        (
            "the sign of its effect on the amplitude",
            o["amplitude_agree"],
            o["pairs"],
            "gains",
        )
    )
    for q, word in (("omega", "frequency"), ("amplitude", "amplitude")):
        k, n, _ = _level(ag, "unscaled", q)
        out.append((f"the unscaled {word} level", k, n, "blocks"))
    if "held_out" in ag:
        held = {
            name: (b["omega_level_consistent"] and b["amplitude_level_consistent"])
            if None not in (b["omega_level_consistent"], b["amplitude_level_consistent"])
            else None
            for name, b in _blocks(ag["held_out"]).items()
        }
        k, n, _ = _count(held)
        out.append(("one pair of scales for every block, held out", k, n, "blocks"))
    k = sum(c["predicted"]["unscaled"]["position"] == "inside" for c in cg)
    out.append(("the critical gains, unscaled, inside the measured brackets", k, len(cg), "blocks"))
    return out


def _verdicts(attrs) -> tuple[str, str]:
    checks = [c for c in _checks(attrs) if c[2] > 0]
    yes = [f"{p} (all {n} {unit})" for p, k, n, unit in checks if k == n]
    no = [f"{p} (it holds in {k} of {n} {unit})" for p, k, n, unit in checks if k < n]
    confirm = (
        f"Tables 5.1 and 5.2 confirm {'; '.join(yes)}."
        if yes
        else "Tables 5.1 and 5.2 confirm none of these checks."
    )
    deny = (
        f"They do not confirm {'; '.join(no)}." if no else "They confirm every one of these checks."
    )
    return confirm, deny


def _finding(ag, cg, dead) -> str:
    u, h = ag["unscaled"]["all"], ag.get("held_out", {}).get("all")
    osc = sum(d["settings"]["unscaled"]["predicted_to_oscillate"] for d in dead)
    held = (
        f"; with the scales fitted to three blocks and used on the fourth, at "
        f"{_num(h['median_omega_ratio'])} and {_num(h['median_amplitude_ratio'])}"
        if h
        else ""
    )
    return (
        "Limit cycles (Tables 5.1, 5.2): unscaled, harmonic balance puts the frequency at "
        f"{_num(u['median_omega_ratio'])} and the amplitude at "
        f"{_num(u['median_amplitude_ratio'])} of the measured (medians over "
        f"{u['rows_predicted']} rows){held}; the unscaled critical gain lies "
        f"{_positions(cg, 'unscaled')}, and {osc} of the "
        f'{len(dead)} rows marked "oscillations die out" are predicted to oscillate.'
    )


def limit_cycle_statements(attrs: dict) -> dict:
    """The comparison's sentences by name, from the named fields of its record.

    Parameters
    ----------
    attrs : dict
        ``DataFrame.attrs`` of :func:`~fitdf.limit_cycle_tables.thesis_limit_cycle_comparison` (or the
        ``attrs`` of the report's ``limit_cycles`` record): ``agreement``, ``scales``,
        ``trends``, ``impedance_order``, ``critical_gains``, ``dies_out_rows``,
        ``time_domain``.

    Returns
    -------
    dict
        ``finding`` (the report's one-line finding), ``unscaled``, ``scales``, ``held_out``,
        ``levels``, ``trends``, ``order``, ``critical``, ``rows_imply`` (with the record's
        ``data_implied``), ``time_domain_<setting>`` for each
        simulated setting, ``confirmed`` and ``not_confirmed``, in that order.
    """
    ag, sc, cg, dead = (
        attrs["agreement"],
        attrs["scales"],
        attrs["critical_gains"],
        attrs["dies_out_rows"],
    )
    out = {
        "finding": _finding(ag, cg, dead),
        "unscaled": _unscaled(ag),
        "scales": _scales(sc),
    }
    if "held_out" in ag:
        out["held_out"] = _held_out(ag, sc)
    out["levels"] = _levels(ag)
    out["trends"] = _trends(attrs["trends"])
    out["order"] = _order(attrs["impedance_order"])
    out["critical"] = _critical(cg, dead)
    implied = _rows_imply(cg, attrs.get("data_implied") or {})
    if implied:
        out["rows_imply"] = implied
    for setting in attrs.get("time_domain") or {}:
        out[f"time_domain_{setting}"] = _time_domain(attrs["time_domain"], dead, setting)
    out["confirmed"], out["not_confirmed"] = _verdicts(attrs)
    return out
