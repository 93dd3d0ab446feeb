"""Which law is best: the one rule of ``fitdf fit``, ``fitdf limit-cycle``, the thesis's
comparisons and the report (the method: ``docs/method/ranking.rst``, *Model selection*).

1. **Enough rows for AICc.** ``n`` rows give ``N = 2 n`` numbers (magnitude and phase); a
   law with ``k`` fitted parameters is ranked only when ``N >= k + 2``
   (:func:`rows_needed`), where AICc's correction ``2k(k+1)/(N-k-1)`` is finite. Near that
   line the correction is large (144 for 8 parameters on 5 rows), so such a law is called
   best only when it fits far better. ``benchmarks/selection_study.py`` measured the
   stricter line of a row per parameter (``n >= k``) against it: on 7 rows the 8-parameter
   law was the true law and best by AICc in every trial, which that line would not have
   ranked (``docs/method/ranking.rst``). A law below the line is not fitted by
   :func:`~fitdf.inference.ranking.compare_fits` and not ranked (:func:`rank_reason`).
2. **The lowest AICc.** Among the ranked laws the best has the lowest AICc
   (:mod:`fitdf.inference.metrics`): every method computes it, at the least-squares
   optimum or the posterior's point estimate. Where least-squares rows are present they
   decide (the other methods' points are not optima of the same objective); the first of
   equals wins.
3. **Ties are named.** A law whose AICc is within :data:`TIE_AICC` of the best's is a tie
   (an Akaike weight at least ``e^-1`` of the best's): the rows do not prefer one of them.
4. **Second opinions.** The leave-one-frequency-out residual, the Bayesian evidence and
   PSIS-LOO, where they were computed, do not change the pick: each names its own best, and
   where one names another law a single line says so (:attr:`Selection.disagreement`),
   with whether the rule's law is within that criterion's own tie.

In-sample residuals (``rms_complex``) never choose: a law with more parameters never fits
worse, so the residual's order rewards parameters (``--rank-by rms_complex`` still orders
the table by it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from fitdf._text import TEXT_WIDTH, wrap
from fitdf.errors import DataError

__all__ = [
    "ROWS_RULE",
    "TIE_AICC",
    "TIE_TWO_LN_B",
    "TIE_LOO_SE",
    "TIE_RULES",
    "aicc_tie",
    "evidence_tie",
    "loo_tie",
    "SECOND_OPINIONS",
    "rows_needed",
    "rank_reason",
    "not_ranked_record",
    "too_few_rows_message",
    "pick",
    "best_result",
    "Selection",
    "select",
]

#: Two laws whose AICc differ by less than this are a tie (Burnham & Anderson 2002, sec
#: 2.6: within 2, both have substantial support).
TIE_AICC = 2.0
#: Two evidences are a tie when ``2 |ln B|`` is below this: a Bayes factor "not worth more
#: than a bare mention" (Kass & Raftery 1995).
TIE_TWO_LN_B = 2.0
#: Two PSIS-LOO fits are a tie when their elpd differ by less than this many standard errors
#: of the difference (``dse`` of :func:`arviz.compare`).
TIE_LOO_SE = 2.0


#: Each method's tie rule in words (the ranking's ``ties``, :func:`aicc_tie`,
#: :func:`loo_tie`, :func:`evidence_tie`), rendered from the thresholds above.
TIE_RULES = {
    "lsq": f"AICc within {TIE_AICC:g}",
    "mcmc": f"elpd_loo within {TIE_LOO_SE:g} standard errors of the difference",
    "nested": f"2 ln B < {TIE_TWO_LN_B:g} (a Bayes factor below {math.exp(TIE_TWO_LN_B / 2):.3g})",
}


def aicc_tie(aicc_a: float, aicc_b: float) -> bool:
    """Two AICc within :data:`TIE_AICC` of each other."""
    return bool(abs(aicc_a - aicc_b) < TIE_AICC)


def evidence_tie(log_z_a: float, log_z_b: float) -> bool:
    """Two log-evidences whose Bayes factor has ``2 |ln B|`` below :data:`TIE_TWO_LN_B`."""
    return bool(2.0 * abs(log_z_a - log_z_b) < TIE_TWO_LN_B)


def loo_tie(elpd_diff: float, dse: float) -> bool:
    """An elpd_loo difference below :data:`TIE_LOO_SE` standard errors ``dse`` (identical
    pointwise elpd, a difference of exactly 0, is a tie)."""
    return bool(elpd_diff == 0 or abs(elpd_diff) < TIE_LOO_SE * dse)


#: The criteria computed besides AICc: column of the ranking table, whether larger is
#: better, and how the output names it.
SECOND_OPINIONS = (
    ("cv_rms_complex", False, "cross-validation"),
    ("log_evidence", True, "the evidence"),
    ("looic", False, "PSIS-LOO"),
)


#: Why a law needs the rows of :func:`rows_needed` (the words of every message).
ROWS_RULE = "AICc needs two numbers a row, at least the parameters plus two"


def rows_needed(n_params: int) -> int:
    """Rows a law of ``n_params`` fitted parameters needs to be ranked: ``2 n >= k + 2``."""
    return (int(n_params) + 3) // 2


def rank_reason(n_rows: int, n_params: int) -> str | None:
    """Why a law of ``n_params`` parameters cannot be ranked on ``n_rows`` rows, or None."""
    need = rows_needed(n_params)
    if n_rows >= need:
        return None
    many = f"{n_params} parameters need" if n_params != 1 else "1 parameter needs"
    return f"{many} {need} rows ({ROWS_RULE}); the data have {n_rows}"


def not_ranked_record(model: str, chain: str, n_rows: int, n_params: int) -> dict | None:
    """A law left out of the ranking, with the reason (JSON-ready), or None if it is ranked."""
    reason = rank_reason(n_rows, n_params)
    if reason is None:
        return None
    return {
        "model": model,
        "chain": chain,
        "n_params": int(n_params),
        "n_points": int(n_rows),
        "rows_needed": rows_needed(n_params),
        "reason": reason,
    }


def too_few_rows_message(label: str, n_rows: int, not_ranked) -> str:
    """The one line for data too small to rank any law (``not_ranked`` records)."""
    smallest = min(not_ranked, key=lambda r: (r["n_params"], r["model"]))
    return (
        f"{label}: {n_rows} row{'s' if n_rows != 1 else ''} cannot rank any law: the smallest, "
        f"{smallest['model']}, has {smallest['n_params']} parameters and needs "
        f"{smallest['rows_needed']} rows ({ROWS_RULE})"
    )


def _law(row) -> str:
    return f"{row['model']}/{row['chain']}"


def pick(rows) -> tuple[int | None, list[int]]:
    """The rule's steps 2-3 on ``rows`` (mappings with ``method`` and ``aicc``), all ranked:
    ``(index of the best, indices of its ties)``, ``(None, [])`` when none has a finite AICc.

    Least-squares rows decide when there are any; the ties are rows of the best's method.
    """
    rows = list(rows)
    deciding = {"lsq"} if any(r["method"] == "lsq" for r in rows) else {r["method"] for r in rows}
    finite = [i for i, r in enumerate(rows) if r["method"] in deciding and math.isfinite(r["aicc"])]
    if not finite:
        return None, []
    best = min(finite, key=lambda i: (rows[i]["aicc"], i))
    low = rows[best]["aicc"]
    ties = [
        i
        for i in finite
        if i != best
        and rows[i]["method"] == rows[best]["method"]
        and aicc_tie(rows[i]["aicc"], low)
    ]
    return best, ties


def _as_row(result) -> dict:
    m = result.metrics
    return {
        "model": result.model,
        "chain": result.chain,
        "method": result.method,
        "n_points": m["n_points"],
        "n_params": m["n_params"],
        "aicc": float(m["aicc"]),
    }


def best_result(results):
    """The best of fitted ``results`` (all on the same rows) by the rule (module docstring).

    Raises
    ------
    DataError
        When the rows can rank none of them (:func:`too_few_rows_message`).
    """
    results = list(results)
    rows = [_as_row(r) for r in results]
    ranked = [i for i, r in enumerate(rows) if rank_reason(r["n_points"], r["n_params"]) is None]
    best, _ = pick([rows[i] for i in ranked])
    if best is None:
        records = [
            not_ranked_record(r["model"], r["chain"], r["n_points"], r["n_params"]) for r in rows
        ]
        n = rows[0]["n_points"] if rows else 0
        label = results[0].label if results else "data"
        if not all(records):  # ranked, but no AICc is finite
            raise DataError(f"{label}: no law has a finite AICc on these {n} rows")
        raise DataError(too_few_rows_message(label, n, records))
    return results[ranked[best]]


@dataclass(frozen=True)
class Selection:
    """The rule applied to a ranking (:func:`select`); JSON-ready by :meth:`to_dict`.

    Attributes
    ----------
    best : dict or None
        ``model``, ``chain``, ``method`` and ``aicc`` of the law called best (None when no
        law could be ranked).
    ties : tuple of str
        ``model/chain`` of the laws within :data:`TIE_AICC` of it.
    opinions : tuple of dict
        Per second opinion computed on two laws or more: ``criterion`` (the table's
        column), ``name``, ``pick`` (``model/chain``), ``value``, ``n_laws``, ``agrees``
        (it picks the rule's law) and ``within_tie`` (the rule's law is within that
        criterion's own tie of its pick: 2 ln B < 2, elpd within two standard errors;
        None for cross-validation, which has none).
    not_ranked : tuple of dict
        The laws left out, with the reason (:func:`not_ranked_record`).
    """

    best: dict | None
    ties: tuple = ()
    opinions: tuple = ()
    not_ranked: tuple = field(default=())

    @property
    def criterion(self) -> str:
        return "aicc"

    @property
    def agree(self) -> bool:
        """Every second opinion picks the rule's law."""
        return all(o["agrees"] for o in self.opinions)

    @property
    def sentence(self) -> str:
        """What is best and why, in one line."""
        if self.best is None:
            return "No law can be ranked: too few rows for every law."
        b = self.best
        text = f"Best law: {b['model']} ({b['chain']} chain), the lowest AICc ({b['aicc']:.4g})"
        if self.ties:
            text += f"; within AICc {TIE_AICC:g} of it (a tie): {', '.join(self.ties)}"
        return text + "."

    @property
    def disagreement(self) -> str:
        """One line naming the criteria that pick another law, or "" when all agree."""
        others = [o for o in self.opinions if not o["agrees"]]
        if self.best is None or not others:
            return ""
        parts = []
        for o in others:
            tie = ""
            if o["within_tie"] is not None:
                tie = " (a tie by its own rule)" if o["within_tie"] else " (not a tie by its rule)"
            parts.append(f"{o['name']} picks {o['pick']}{tie}")
        return (
            f"The criteria disagree: AICc picks {self.best['model']}/{self.best['chain']}, "
            + ", ".join(parts)
            + "."
        )

    def text(self, width: int = TEXT_WIDTH) -> str:
        """What the rule calls best, the criteria that disagree and the laws not ranked, as
        lines wrapped at ``width``."""
        lines = wrap(self.sentence, width)
        if self.disagreement:
            lines += wrap(self.disagreement, width)
        if self.not_ranked:
            laws = ", ".join(f"{r['model']} ({r['n_params']} parameters)" for r in self.not_ranked)
            n = self.not_ranked[0]["n_points"]
            lines += wrap(
                f"Not fitted or ranked, {n} rows being too few ({ROWS_RULE}): {laws}.", width
            )
        return "\n".join(lines)

    def __str__(self):
        return self.text()

    def to_dict(self) -> dict:
        return {
            "criterion": self.criterion,
            "best": None if self.best is None else dict(self.best),
            "ties": list(self.ties),
            "tie_rule": TIE_RULES["lsq"],
            "opinions": [dict(o) for o in self.opinions],
            "agree": self.agree,
            "not_ranked": [dict(r) for r in self.not_ranked],
            "sentence": self.sentence,
            "disagreement": self.disagreement,
        }


def _finite(value) -> bool:
    try:
        return math.isfinite(float(value))
    except (TypeError, ValueError):
        return False


def _opinion(rows, column, larger, name, best) -> dict | None:
    """The pick of one second opinion over the rows that have it, or None (fewer than two)."""
    have = [r for r in rows if _finite(r.get(column))]
    if len({_law(r) for r in have}) < 2:
        return None
    top = (max if larger else min)(have, key=lambda r: float(r[column]))
    law = _law(best)
    mine = [r for r in have if _law(r) == law]
    within = None
    if column == "log_evidence" and mine:
        within = evidence_tie(float(top[column]), float(mine[0][column]))
    elif column == "looic" and mine and _finite(mine[0].get("elpd_loo_dse")):
        # elpd_loo_diff and its dse are against the top LOO row (arviz.compare)
        within = loo_tie(float(mine[0]["elpd_loo_diff"]), float(mine[0]["elpd_loo_dse"]))
    return {
        "criterion": column,
        "name": name,
        "pick": _law(top),
        "value": float(top[column]),
        "n_laws": len({_law(r) for r in have}),
        "agrees": _law(top) == law,
        "within_tie": within,
    }


def select(rows, not_ranked=()) -> Selection:
    """The rule on ranked ``rows`` (the records of a ranking table, any order).

    ``not_ranked``: the laws left out (:func:`not_ranked_record`), carried along.
    """
    rows = [dict(r) for r in rows]
    best, ties = pick(rows)
    if best is None:
        return Selection(None, not_ranked=tuple(not_ranked))
    b = rows[best]
    opinions = []
    for column, larger, name in SECOND_OPINIONS:
        o = _opinion(rows, column, larger, name, b)
        if o is not None:
            opinions.append(o)
    return Selection(
        best={k: b[k] for k in ("model", "chain", "method")} | {"aicc": float(b["aicc"])},
        ties=tuple(_law(rows[i]) for i in ties),
        opinions=tuple(opinions),
        not_ranked=tuple(not_ranked),
    )
