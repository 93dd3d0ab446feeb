"""The criteria the report's sentences name, each on its own numbers of ``results.json``.

A sentence that names a criterion is made by that criterion's function here, from that
criterion's fields of a ranking (lists of one column, in the ranking's order):

* **AICc** (least squares): the lowest ``aicc``; a tie is an AICc within :data:`AICC_TIE`.
* **the evidence** (nested sampling): the highest ``log_evidence``; a tie is a Bayes factor
  ``B`` with ``2 ln B`` below :data:`BARE_MENTION` (Kass and Raftery: "not worth more than a
  bare mention").
* **LOO-IC** (posteriors): the lowest ``looic``; a tie is an ``elpd_loo_diff`` (to the best)
  smaller than :data:`LOO_TIE_SE` times its standard error ``elpd_loo_dse``, or zero.
* **cross-validation**: the lowest ``cv_rms_complex``.

These are the rules of :mod:`fitdf.inference.selection` (its thresholds and tie tests),
read back from the records. The report's "best law", named without a criterion, is
:func:`best_law`: the lowest AICc among the laws ranked (the selection rule; a ranking in
``results.json`` holds only the laws its rows can rank).
"""

from __future__ import annotations

import math

from fitdf.inference.selection import (
    TIE_AICC,
    TIE_LOO_SE,
    TIE_TWO_LN_B,
    aicc_tie,
    evidence_tie,
    loo_tie,
)

__all__ = [
    "AICC_TIE",
    "BARE_MENTION",
    "LOO_TIE_SE",
    "best_by",
    "best_law",
    "aicc_ties",
    "evidence_ties",
    "loo_ties",
    "known",
]

#: AICc differences below this are ties (least squares).
AICC_TIE = TIE_AICC
#: ``2 ln B`` below this is "not worth more than a bare mention" (Kass and Raftery 1995).
BARE_MENTION = TIE_TWO_LN_B
#: An elpd difference below this many of its standard errors is a tie (LOO-IC).
LOO_TIE_SE = TIE_LOO_SE


def known(values) -> list:
    """Indices of the finite numbers of ``values`` (None and NaN are not known)."""
    return [
        i
        for i, v in enumerate(values or [])
        if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
    ]


def best_by(models, values, larger: bool = False):
    """The model with the lowest (``larger``: highest) known value, the first of equals;
    None when no value is known."""
    idx = known(values)
    if not idx:
        return None
    pick = max if larger else min
    top = pick(values[i] for i in idx)
    return models[next(i for i in idx if values[i] == top)]


def best_law(models, aicc):
    """The report's best law: the lowest AICc (least squares)."""
    return best_by(models, aicc)


def aicc_ties(models, aicc) -> list[tuple]:
    """``(model, dAICc)`` of the laws within :data:`AICC_TIE` of the lowest AICc."""
    best = best_by(models, aicc)
    if best is None:
        return []
    low = aicc[models.index(best)]
    return [
        (models[i], aicc[i] - low)
        for i in known(aicc)
        if models[i] != best and aicc_tie(aicc[i], low)
    ]


def evidence_ties(models, log_evidence) -> list[tuple]:
    """``(model, 2 ln B)`` of the laws whose Bayes factor against the highest evidence is not
    worth more than a bare mention (``2 ln B`` below :data:`BARE_MENTION`)."""
    best = best_by(models, log_evidence, larger=True)
    if best is None:
        return []
    top = log_evidence[models.index(best)]
    return [
        (models[i], 2.0 * (top - log_evidence[i]))
        for i in known(log_evidence)
        if models[i] != best and evidence_tie(log_evidence[i], top)
    ]


def loo_ties(models, looic, elpd_diff, elpd_dse) -> list[tuple]:
    """``(model, elpd difference, its standard error)`` of the laws whose ``elpd_loo`` lies
    within :data:`LOO_TIE_SE` standard errors of the best LOO-IC's (``elpd_loo_diff`` and
    ``elpd_loo_dse`` are to that law), or equals it."""
    best = best_by(models, looic)
    if best is None:
        return []
    out = []
    for i in known(elpd_diff):
        se = elpd_dse[i] if i < len(elpd_dse) and elpd_dse[i] is not None else 0.0
        if models[i] != best and loo_tie(elpd_diff[i], se):
            out.append((models[i], elpd_diff[i], se))
    return out
