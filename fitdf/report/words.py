"""The report's words: every claim it makes, by section, and the Findings as sentences.

:func:`report_words` gathers the claims of :mod:`fitdf.report.overview` (the opening, how to
regenerate, the summary table), :mod:`fitdf.report.conclusion`,
:mod:`fitdf.report.findings` and :mod:`fitdf.report.physics_claims` from a results record.
The report shows these words and ``results.json`` keeps them (``claims``, and the Findings'
sentences as ``findings``); :func:`every_claim` walks them for the test that makes each again.
"""

from __future__ import annotations

from fitdf.report.claims import text
from fitdf.report.conclusion import conclusion_claims
from fitdf.report.findings import findings
from fitdf.report.overview import intro_claims, regenerate_claims, summary_claims
from fitdf.report.physics_claims import physics_claims, physics_findings
from fitdf.report.small_signal_claims import small_signal_claims, small_signal_findings
from fitdf.report.upgrade import upgrade

__all__ = ["report_words", "every_claim", "sentence"]


def sentence(statement) -> str:
    """A Findings statement's words: a paragraph of claims, or a plain sentence."""
    return statement if isinstance(statement, str) else text(statement)


def report_words(results: dict) -> dict:
    """``{"claims": {section: ...}, "findings": [sentence, ...]}`` of ``results``.

    ``claims``: ``intro``, ``regenerate`` and ``conclusion`` (one paragraph each),
    ``findings`` (the statements made of claims, one paragraph each), ``summary`` (one claim
    per block), ``physics`` (:func:`fitdf.report.physics_claims.physics_claims`),
    ``small_signal`` (:func:`fitdf.report.small_signal_claims.small_signal_claims`).
    ``findings``: every statement of the Findings list, in order, as its words. A record of
    an earlier schema is read as the current one (:func:`fitdf.report.upgrade.upgrade`)."""
    results = upgrade(results)
    statements = findings(results, physics_findings(results) + small_signal_findings(results))
    return {
        "claims": {
            "intro": intro_claims(results),
            "regenerate": regenerate_claims(results),
            "conclusion": conclusion_claims(results),
            "findings": [s for s in statements if not isinstance(s, str)],
            "summary": summary_claims(results),
            "physics": physics_claims(results) if results.get("physics") else {},
            "small_signal": small_signal_claims(results),
        },
        "findings": [sentence(s) for s in statements],
    }


def every_claim(tree):
    """Every claim record in ``tree`` (the ``claims`` of :func:`report_words`, or any part)."""
    if isinstance(tree, dict):
        if "kind" in tree and "text" in tree:
            yield tree
            return
        for v in tree.values():
            yield from every_claim(v)
    elif isinstance(tree, list):
        for v in tree:
            yield from every_claim(v)
