"""Supermalloy's series permeability at matched flux (Table B.4): the record and its sentences.

:func:`supermalloy_record` is :func:`fitdf.inference.matched_flux.matched_flux` of Table
B.4's best law that was refitted with rate-dependent losses (static and dynamic fits), as
JSON; :func:`supermalloy_sentences` says what it finds, every number a field of the record
(:func:`sentence_fields` names them), and :func:`supermalloy_figure` draws it. The report's
physics section and its Findings read the sentences.
"""

from __future__ import annotations

from pathlib import Path

from fitdf._json import clean
from fitdf.inference.matched_flux import matched_flux
from fitdf.plots.permeability import plot_matched_flux

__all__ = [
    "supermalloy_fits",
    "supermalloy_record",
    "supermalloy_sentences",
    "sentence_fields",
    "supermalloy_figure",
    "RISE_WORDS",
    "FIGURE",
]

#: How the rows' rise of ``mu'`` at small flux compares with the laws' (:func:`sentence_fields`):
#: the small-flux sentence's opening and the Findings' clause.
RISE_WORDS = {
    "steeper": (
        "What the laws miss is how steeply mu' rises with the flux at small flux",
        "what the laws miss is its rise with flux at small flux",
    ),
    "shallower": (
        "At small flux the rows' mu' rises less steeply with the flux than the laws'",
        "at small flux it rises less steeply with flux than the laws",
    ),
    "alike": (
        "At small flux the rows' mu' rises with the flux as the laws' do, within printed precision",
        "at small flux it rises with flux as the laws do",
    ),
}
#: File name of the figure under the report's figure folder.
FIGURE = "supermalloy_matched_flux.png"


def supermalloy_fits(lsq, ranked, dynamic) -> tuple:
    """The fits the matched-flux comparison reads: Table B.4's best law that was refitted with rate-dependent losses: ``(static, dynamic)``
    fits (``(None, None)`` when B.4 was not fitted). ``lsq``: ``{(block, law): FitResult}``;
    ``ranked``: each block's laws by the least-squares ranking; ``dynamic``: ``{(block, law):
    (FitResult, cv, static cv)}`` of the refits with rate-dependent losses."""
    laws = [m for m in ranked.get("B.4", []) if ("B.4", m) in dynamic]
    if not laws:
        best = ranked.get("B.4", [None])[0]
        return (lsq.get(("B.4", best)), None) if best else (None, None)
    return lsq[("B.4", laws[0])], dynamic[("B.4", laws[0])][0]


def supermalloy_record(static, dynamic) -> dict | None:
    """The matched-flux comparison of ``static`` (and its ``dynamic`` refit) as JSON; None
    without a static fit or a core geometry."""
    if static is None or static.problem.geometry is None:
        return None
    return clean(matched_flux(static, dynamic).to_dict())


def _mv(x) -> str:
    """A flux in mV s, 3 significant digits."""
    return f"{1e3 * x:.3g}"


def _k(x) -> str:
    """A permeability in thousands: ``20.7k``."""
    return f"{x / 1e3:.3g}k"


def _g(x, digits=3) -> str:
    return f"{x:.{digits}g}"


def _s(x) -> str:
    """A power law's slope, 3 decimals."""
    return f"{x:.3f}"


def _f(x) -> str:
    return f"{x:g}"


def _list(items) -> str:
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def _shape(mu) -> str:
    """How ``mu`` (by increasing frequency) moves with frequency, in words."""
    steps = [b - a for a, b in zip(mu, mu[1:])]
    if steps and all(d < 0 for d in steps):
        return "falling with frequency"
    if steps and all(d > 0 for d in steps):
        return "rising with frequency"
    return "not monotone in frequency"


def sentence_fields(rec: dict) -> dict:
    """The parts of the record the sentences read, and the words they choose: ``common``
    (the per-level row at the common level), ``at_common`` (its per-frequency rows, by frequency), ``levels`` (the
    per-level rows with at least three frequencies), ``pairs`` (those with two), ``deepest`` (the per-frequency small-flux
    row of the smallest flux), ``small`` (the small-flux rows, by frequency), ``dynamic``
    (whether a refit is in the record); ``flux_word`` ("rises" when every frequency's
    ``mu'`` rises from its smallest flux to the common level), ``steep`` (:data:`RISE_WORDS`'s
    key: the rows' rise at the smallest flux above every law's over all of its
    printed-precision range, below them, or neither) and its words, ``shape`` (how the rows'
    ``mu'`` at the common level moves with frequency)."""
    common = rec["common_vs"]
    by_level = rec["frequency"]
    small = sorted(rec["small_flux"], key=lambda r: r["frequency_hz"])
    below = [r for r in small if r["flux_vs"] < r["common_vs"]]
    deepest = min(small, key=lambda r: r["flux_vs"])
    dynamic = "dynamic" in rec["fits"]
    laws = [deepest["rise_static"]] + ([deepest["rise_dynamic"]] if dynamic else [])
    steep = (
        "steeper"
        if deepest["rise_lo"] > max(laws)
        else "shallower"
        if deepest["rise_hi"] < min(laws)
        else "alike"
    )
    at_common = sorted(
        (r for r in rec["levels"] if r["level_vs"] == common), key=lambda r: r["frequency_hz"]
    )
    return {
        "common": next(r for r in by_level if r["level_vs"] == common),
        "at_common": at_common,
        "levels": [r for r in by_level if r["n_frequencies"] >= 3],
        "pairs": [r for r in by_level if r["n_frequencies"] == 2],
        "deepest": deepest,
        "small": small,
        "dynamic": dynamic,
        "flux_word": "rises" if all(r["rise"] > 1 for r in below) else "changes",
        "rise_words": RISE_WORDS[steep][0],
        "rise_short": RISE_WORDS[steep][1],
        "steep": steep,
        "shape": _shape([r["mu"] for r in at_common]),
    }


def _code(name: str) -> str:
    return f"`{name}`"


def supermalloy_sentences(rec: dict, law_name=_code) -> dict[str, str]:
    """``{"matched", "small_flux", "quality", "finding"}``: what the comparison finds at
    matched flux, what the laws miss at small flux, the quality factor of the smallest
    readings, and the Findings' bullet. ``law_name``: how to name a law from its code name."""
    s = sentence_fields(rec)
    c, deep = s["common"], s["deepest"]
    static = rec["fits"]["static"]
    freqs = [_f(r["frequency_hz"]) for r in s["at_common"]]
    shape = s["shape"]
    matched = (
        f"Supermalloy's series permeability mu' (Table B.4, each reading inverted through the "
        f"circuit of Fig 5.10 with the series resistance R_source + r_series = "
        f"{_g(static['r_total_ohm'], 4)} ohm and gain {_g(static['gain'], 4)} of the static fit, "
        f"{law_name(static['model'])}) {s['flux_word']} with the flux amplitude, so the "
        f"frequencies are compared at matched flux. At {_mv(c['level_vs'])} mV s, the smallest flux all "
        f"{c['n_frequencies']} frequencies reach, the rows give mu' "
        f"{_list([_k(r['mu']) for r in s['at_common']])} at {_list(freqs)} c/s: "
        f"{_g(c['ratio'])}x between the largest and the smallest, {shape}, "
        f"{_g(c['first_over_last'])}x from {freqs[0]} to {freqs[-1]} c/s. A power law "
        f"mu' ~ f^s through them has s = {_s(c['slope'])} (95 % interval {_s(c['slope_lo'])} to "
        f"{_s(c['slope_hi'])}); the frequencies scatter {100 * c['scatter']:.3g} % (RMS) about it, "
        f"the printed precision of the readings {100 * c['precision']:.3g} %."
    )
    levels = s["levels"]

    def slopes(key):
        return _list([_s(r[key]) for r in levels])

    matched += (
        f" At the {len(levels)} flux levels three or more frequencies reach "
        f"({_list([_mv(r['level_vs']) for r in levels])} mV s) s = {slopes('slope')}; the "
        f"95 % interval holds the static law's slope ({slopes('slope_static')}) at "
        f"{sum(bool(r['contains_static']) for r in levels)} of {len(levels)}"
    )
    if s["dynamic"]:
        matched += (
            f" and that of its refit with rate-dependent losses ({slopes('slope_dynamic')}) "
            f"at {sum(bool(r['contains_dynamic']) for r in levels)} of {len(levels)}"
        )
    matched += "."
    dyn = (
        f", its refit with rate-dependent losses {_g(deep['rise_dynamic'])}x"
        if s["dynamic"]
        else ""
    )
    small_flux = (
        f"{s['rise_words']}: from "
        f"{_mv(deep['flux_vs'])} to {_mv(deep['common_vs'])} mV s at {_f(deep['frequency_hz'])} c/s "
        f"the rows' mu' rises {_g(deep['rise'])}x ({_g(deep['rise_lo'])}-{_g(deep['rise_hi'])} "
        f"at printed precision), the static law's {_g(deep['rise_static'])}x{dyn}. At "
        f"{_mv(deep['flux_vs'])} mV s the rows give {_k(deep['mu'])} against the static law's "
        f"{_k(deep['mu_static'])}, {_g(deep['over_static'])} times it, a deviation of "
        f"{abs(deep['scatters_from_static']):.3g} times the frequencies' RMS scatter at matched "
        f"flux; "
        f"at each frequency's smallest flux the rows over the static law are "
        f"{_list([_g(r['over_static']) for r in s['small']])} at "
        f"{_list([_f(r['frequency_hz']) for r in s['small']])} c/s."
    )
    if s["pairs"]:
        small_flux += (
            f" Below {_mv(levels[0]['level_vs'])} mV s fewer than three frequencies reach, so "
            "amplitude and rate are not told apart there: "
            + "; ".join(
                f"at {_mv(r['level_vs'])} mV s the {_f(r['frequencies_hz'][0])} c/s rows give "
                f"{_g(r['first_over_last'])} times the {_f(r['frequencies_hz'][1])} c/s ones"
                for r in s["pairs"]
            )
            + "."
        )
    qs = [
        f"{_g(r['q'])} (above {_g(r['q_lo'])})"
        if r["q_hi"] is None
        else f"{_g(r['q'])} ({_g(r['q_lo'])}-{_g(r['q_hi'])})"
        for r in s["small"]
    ]
    quality = (
        "The quality factor Q = mu'/mu'' of each frequency's smallest reading, with its range "
        f"at printed precision, is {_list(qs)} at "
        f"{_list([_f(r['frequency_hz']) for r in s['small']])} c/s."
    )
    finding = (
        f"Supermalloy (Table B.4, {law_name(static['model'])}) at matched flux: at "
        f"{_mv(c['level_vs'])} mV s mu' differs {_g(c['ratio'])}x over {freqs[0]}-{freqs[-1]} c/s, "
        f"{shape} (power law f^{_s(c['slope'])}, 95 % interval {_s(c['slope_lo'])} to "
        f"{_s(c['slope_hi'])}); {s['rise_short']} "
        f"({_f(deep['frequency_hz'])} c/s, {_mv(deep['flux_vs'])} to {_mv(deep['common_vs'])} mV s: "
        f"rows {_g(deep['rise'])}x, static law {_g(deep['rise_static'])}x"
        + (
            f", refit with rate-dependent losses {_g(deep['rise_dynamic'])}x)."
            if s["dynamic"]
            else ")."
        )
    )
    return {"matched": matched, "small_flux": small_flux, "quality": quality, "finding": finding}


def supermalloy_figure(rec: dict | None, figdir) -> str | None:
    """Draw :func:`fitdf.plots.permeability.plot_matched_flux` of ``rec`` into ``figdir``;
    its path relative to the report (None without a record)."""
    if not rec:
        return None
    fig = plot_matched_flux(rec)
    fig.savefig(Path(figdir) / FIGURE, format="png")
    return f"figures/{FIGURE}"
