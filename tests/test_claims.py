"""Every sentence the report generates, made again from results.json (fitdf.report.claims).

The mechanism first (paths, templates, the numbers a template may print), then one generic
test over every claim of a report made here and of the committed report: each is made again
from the fields it names and must come out the same, its template prints no number of its
own, and the words the report shows are the claims' words.
"""

from __future__ import annotations

import json
import re
import string
from pathlib import Path

import pytest

from fitdf.report import audit_claims, claims, criteria, findings, physics_claims
from fitdf.report.claims import claim, literal_numbers, paragraph, recompute, resolve, rule, say
from fitdf.report.render import render_markdown
from fitdf.report.upgrade import read_results, upgrade
from fitdf.report.words import every_claim, report_words

RESULTS = {
    "models": [{"name": "a", "title": "Law A"}, {"name": "b", "title": "Law B"}],
    "blocks": {
        "B.1": {"ranking": [{"model": "a", "rms": 0.5}, {"model": "b", "rms": 0.25}]},
        "B.2": {"ranking": [{"model": "b", "rms": 0.125}]},
    },
}


@rule("test.lowest", models="blocks/{block}/ranking/*/model", rms="blocks/{block}/ranking/*/rms")
def _lowest(models, rms, block):
    if not models:
        return None
    i = rms.index(min(rms))
    return say(
        "On {block}, {law:law} has the lowest RMS, {rms:.3f} (of {n}).",
        block=block,
        law=models[i],
        rms=rms[i],
        n=len(models),
    )


def test_paths_read_lists_dicts_and_subjects():
    assert resolve(RESULTS, "blocks/B.1/ranking/*/model") == ["a", "b"]
    assert resolve(RESULTS, "blocks/*/ranking/0/rms") == {"B.1": 0.5, "B.2": 0.125}
    assert resolve(RESULTS, "blocks/B.1/ranking/1/rms") == 0.25
    assert resolve(RESULTS, "blocks/B.9/ranking") is None
    assert resolve(RESULTS, "blocks/B.1/ranking/7/rms") is None


def test_a_claim_records_its_fields_values_and_words():
    c = claim("test.lowest", RESULTS, block="B.1")
    assert c["text"] == "On B.1, Law B `b` has the lowest RMS, 0.250 (of 2)."
    assert c["fields"] == {
        "models": "blocks/B.1/ranking/*/model",
        "rms": "blocks/B.1/ranking/*/rms",
    }
    assert c["values"] == {"block": "B.1", "law": "b", "rms": 0.25, "n": 2}
    assert c["subject"] == {"block": "B.1"} and c["named_before"] == []
    assert recompute(c, RESULTS) == c
    # a changed field changes the claim made again: the test of a sentence can fail
    changed = {**RESULTS, "blocks": {**RESULTS["blocks"], "B.1": {"ranking": [
        {"model": "a", "rms": 0.5}, {"model": "b", "rms": 0.75}]}}}  # fmt: skip
    again = recompute(c, changed)
    assert again["text"] == "On B.1, Law A `a` has the lowest RMS, 0.500 (of 2)." != c["text"]
    assert claim("test.lowest", {"blocks": {}}, block="B.1") is None


def test_a_paragraph_names_a_law_in_full_once():
    first, second = paragraph(
        RESULTS, ("test.lowest", {"block": "B.1"}), ("test.lowest", {"block": "B.2"})
    )
    assert first["text"].startswith("On B.1, Law B `b`")
    assert second["text"] == "On B.2, `b` has the lowest RMS, 0.125 (of 1)."
    assert second["named_before"] == ["b"] and recompute(second, RESULTS) == second


def test_a_template_prints_no_number_of_its_own():
    assert literal_numbers("{n} of {m} rows: median {x:.2f}.") == []
    assert literal_numbers("Tables 5.1, 5.2 and Table B.5, Graphs 4.1-4.7, Fig 5.10: {x}") == []
    assert literal_numbers("within 2 of the best AICc") == ["2"]
    assert literal_numbers("a shift of 6.9 on B.2") == ["6.9"]


def test_templates_convert_laws_and_lists():
    @rule("test.listing", models="blocks/B.1/ranking/*/model")
    def _listing(models):
        return say("{ms:laws}; {ms:and}; {one:code}.", ms=models, one=models[0])

    c = claim("test.listing", RESULTS)
    assert c["text"] == "Law A `a` and Law B `b`; a and b; `a`."
    with pytest.raises(ValueError, match="twice"):
        rule("test.listing")(lambda: None)
    del claims.RULES["test.listing"]


# ------------------------------------------------------------------ the criteria, at their bounds
def test_each_criterion_picks_its_best_and_its_ties_at_the_bound():
    models = ["a", "b", "c"]
    assert criteria.best_by(models, [3.0, None, 1.0]) == "c"
    assert criteria.best_by(models, [3.0, float("nan"), 1.0], larger=True) == "a"
    assert criteria.best_by(models, [1.0, 1.0, 2.0]) == "a"  # the first of equals
    assert criteria.best_by(models, [None, None, None]) is None
    assert criteria.best_law(models, [10.0, 9.0, 12.0]) == "b"  # the lowest AICc
    # AICc: a difference below 2 is a tie, 2 is not
    assert criteria.aicc_ties(models, [10.0, 11.999, 12.0]) == [("b", pytest.approx(1.999))]
    # the evidence: 2 ln B below 2 (ln B below 1) is a tie, ln B of 1 is not
    ties = criteria.evidence_ties(models, [5.0, 4.0001, 4.0])
    assert ties == [("b", pytest.approx(1.9998))]
    # LOO-IC: an elpd difference below twice its standard error is a tie, or zero
    looic = [-100.0, -99.0, -90.0]
    assert criteria.loo_ties(models, looic, [0.0, 1.999, 2.0], [0.0, 1.0, 1.0]) == [
        ("b", 1.999, 1.0)
    ]
    assert criteria.loo_ties(models, looic, [0.0, 0.0, 5.0], [0.0, 0.0, 1.0]) == [("b", 0.0, 0.0)]
    assert criteria.loo_ties(models, [None] * 3, [0.0] * 3, [1.0] * 3) == []


# ------------------------------------------------------------------ what each kind of claim says
def _row(model, aicc, rms, **more):
    return {"model": model, "aicc": aicc, "rms_complex": rms, "n_params": 5, **more}


def _post(model, log_evidence, looic, elpd_diff, elpd_dse):
    return {
        "model": model,
        "log_evidence": log_evidence,
        "looic": looic,
        "elpd_loo_diff": elpd_diff,
        "elpd_loo_dse": elpd_dse,
    }


def _fit(rows=4):
    return {"rows": {"df_measured": [0.5] * rows}, "appendix_a_check": [], "material": {}}


def _nested(converged=True):
    return {"method": "nested", "diagnostics": {"converged": converged}}


def _results() -> dict:
    """Two blocks of three laws: on B.1 a tie of ``a`` and ``b`` by every criterion; on B.2
    (as Deltamax on Table B.2) ``a`` best by AICc and by the evidence, ``b`` by LOO-IC,
    within its standard error."""
    blocks = {
        "B.1": (
            [_row("a", 100.0, 0.030), _row("b", 101.5, 0.028), _row("c", 130.0, 0.050)],
            [_post("a", 50.0, -100.0, 0.0, 0.0), _post("b", 49.6, -98.0, 1.0, 3.0)],
        ),
        "B.2": (
            [_row("a", 200.0, 0.048), _row("b", 236.0, 0.066), _row("c", 240.0, 0.070)],
            [_post("a", 83.4, -172.3, 2.09, 12.1), _post("b", 69.5, -176.5, 0.0, 0.0)],
        ),
    }
    return {
        "models": [{"name": m, "title": f"Law {m.upper()}"} for m in "abc"],
        "blocks": {
            key: {
                "key": key,
                "title": f"Table {key}",
                "core": "deltamax",
                "tables": [key],
                "source_impedance_ohm": [0.0],
                "ranking_lsq": lsq,
                "ranking_posterior": post,
                "fits_lsq": {r["model"]: _fit() for r in lsq},
                "fits_posterior": {r["model"]: _nested() for r in post},
            }
            for key, (lsq, post) in blocks.items()
        },
    }


def _clauses(text: str) -> tuple[str, str, str]:
    """The AICc, evidence and LOO-IC clauses of the ties sentence, each without its name."""
    parts = text[len("By ") :].rstrip(".").split("; by ")
    names = ("AICc ", "the evidence ", "LOO-IC ")
    assert [p.startswith(n) for p, n in zip(parts, names)] == [True] * 3, parts
    return tuple(p[len(n) :] for p, n in zip(parts, names))


def test_ties_are_named_by_each_criterion_on_its_own_numbers():
    res = _results()
    ties = claim("conclusion.ties", res)
    aicc, evidence, loo = _clauses(ties["text"])
    # AICc: within 2 on B.1 only (B.2's runner-up is 36 above)
    assert aicc.startswith("(within 2) the data cannot tell Law A `a` from Law B `b` on B.1")
    assert "B.2" not in aicc
    # the evidence: 2 ln B = 0.8 on B.1; on B.2 ln B = 13.9
    assert "`a` from `b` on B.1" in evidence and "B.2" not in evidence
    # LOO-IC: B.2's LOO-IC prefers b, a within 2.09 +- 12.1 of it: a tie, by LOO
    assert "`b` from `a` on B.2 (elpd apart by 2.1 +- 12.1)" in loo
    assert "`a` from `b` on B.1 (elpd apart by 1.0 +- 3.0)" in loo
    assert {"looic", "elpd_diff", "elpd_dse", "log_evidence", "aicc"} <= set(ties["fields"])
    # the bound: an elpd difference of more than twice its error is no tie
    res["blocks"]["B.2"]["ranking_posterior"][0]["elpd_loo_dse"] = 1.0
    assert "on B.2" not in claim("conclusion.ties", res)["text"]


def test_no_tie_is_claimed_by_a_criterion_that_has_one():
    """The report once said no law came "within the uncertainty of its LOO-IC" on Table B.2,
    testing the evidence's tie; each criterion now answers for itself."""
    res = _results()
    del res["blocks"]["B.1"]
    text = claim("conclusion.ties", res)["text"]
    aicc, evidence, loo = _clauses(text)
    assert aicc == "no other law comes within 2 of the best on any block"
    assert evidence == (
        "every Bayes factor to the best on the 1 block sampled is worth more than a bare "
        "mention (ln B at least 1)"
    )
    assert loo.startswith("(an elpd difference below 2 standard errors) it cannot tell")
    for block in res["blocks"].values():  # and with LOO far apart: no LOO tie either
        block["ranking_posterior"][0]["elpd_loo_dse"] = 0.5
    assert claim("conclusion.ties", res)["text"].endswith(
        "by LOO-IC no other law's elpd comes within 2 standard errors of the best's."
    )


def test_the_posteriors_agree_only_when_their_criterion_picks_the_best_law():
    res = _results()
    said = claim("block.posteriors", res, block="B.2")["text"]
    assert said.startswith("The evidence agrees (2 laws sampled).")
    assert (
        "LOO-IC prefers Law B `b` (elpd ahead by 2.1 +- 12.1, less than 2 standard errors" in said
    )
    assert "LOO-IC agrees." in claim("block.posteriors", res, block="B.1")["text"]
    # the evidence turned: it prefers b, and says by how much
    res["blocks"]["B.2"]["ranking_posterior"][1]["log_evidence"] = 90.0
    said = claim("block.posteriors", res, block="B.2")["text"]
    assert said.startswith("Of the 2 laws sampled, the evidence prefers Law B `b` (ln B 6.6 over")
    # the best law by AICc not sampled
    res["blocks"]["B.2"]["ranking_lsq"][2]["aicc"] = 150.0
    assert "which do not include Law C `c`" in claim("block.posteriors", res, block="B.2")["text"]


def test_disagreement_is_one_sentence_naming_each_criterion():
    res = _results()
    said = claim("block.disagreement", res, block="B.2")["text"]
    assert said == (
        "The criteria disagree on the 2 laws sampled: AICc prefers Law A `a`; LOO-IC prefers "
        "Law B `b`; the evidence prefers `a`."
    )
    assert claim("block.disagreement", res, block="B.1") is None  # all prefer a


def test_the_summary_row_takes_each_criterion_by_its_own_numbers():
    res = _results()
    row = claim("summary.block", res, block="B.2")["values"]
    assert (row["aicc_best"], row["evidence_best"], row["loo_best"]) == ("a", "a", "b")
    assert row["second"] == "b" and row["d_aicc"] == 36.0 and row["rms"] == 0.048
    res["blocks"]["B.2"]["ranking_posterior"] = []
    row = claim("summary.block", res, block="B.2")["values"]
    assert row["evidence_best"] is None and row["loo_best"] is None


def test_which_law_to_use_names_where_a_criterion_disagrees():
    res = _results()
    text = claim("conclusion.use", res)["text"]
    assert text == (
        "Use Law A `a` for Deltamax: it has the lowest AICc (least squares) on both blocks; "
        "the evidence agrees on the 2 blocks sampled; LOO-IC prefers Law B `b` on B.2."
    )
    # the best by AICc differs between the blocks
    res["blocks"]["B.2"]["ranking_lsq"][1]["aicc"] = 150.0
    text = claim("conclusion.use", res)["text"]
    assert text.startswith("The law with the lowest AICc (least squares) depends on the core.")
    assert "Law A `a` (on B.1); Law B `b` (on B.2)" in text


def test_the_best_law_of_a_block_is_the_lowest_aicc_and_the_lowest_rms_is_named():
    res = _results()
    said = claim("block.best", res, block="B.1")["text"]
    assert said.startswith("**Table B.1**: the best law by AICc is Law A `a` (5 parameters;")
    assert "has an AICc higher by 1.5 (within 2: a tie) and RMS 0.0280" in said
    assert "The smallest RMS complex residual is `b`'s (0.0280, 5 parameters)" in said
    said = claim("block.best", res, block="B.2")["text"]
    assert "higher by 36.0 and RMS" in said and "smallest RMS" not in said


# ------------------------------------------------------------------ every claim of a report
REPO = Path(__file__).resolve().parents[1]
COMMITTED = REPO / "reports" / "results.json"

#: How a template says a criterion chose or compared laws, and the fields it must then read.
CRITERIA = {
    r"by AICc|lowest AICc|lower AICc|AICc (prefers|higher|lower)": ("aicc",),
    r"LOO-IC (agrees|prefers)|by LOO-IC": ("looic", "elpd_loo"),
    r"the evidence (agrees|prefers)|by the evidence": ("log_evidence",),
    r"cross-validation prefers": ("cv_rms_complex",),
}


def _literal(template: str) -> str:
    return "".join(part for part, *_ in string.Formatter().parse(template))


def _made_again(results: dict, tree) -> int:
    """Every claim of ``tree`` made again from ``results``: the same fields, template, values
    and words; no number of its template's own; a criterion it names read from its fields."""
    n = 0
    for c in every_claim(tree):
        assert recompute(c, results) == c, c["kind"]
        assert literal_numbers(c["template"]) == [], (c["kind"], c["template"])
        for words, columns in CRITERIA.items():
            if re.search(words, _literal(c["template"])):
                last = [path.rsplit("/", 1)[-1] for path in c["fields"].values()]
                assert any(col in f for f in last for col in columns), (c["kind"], words)
        n += 1
    return n


def _plain_statements(results: dict) -> list[str]:
    """The Findings statements still written without claims (the limit cycles', made and
    tested by fitdf.limit_cycle_tables; Supermalloy's, by fitdf.report.supermalloy)."""
    out = [
        physics_claims._supermalloy_finding((results.get("physics") or {}).get("supermalloy")),
        findings._limit_finding(results.get("limit_cycles", {})),
    ]
    return [s for s in out if s]


def test_every_sentence_of_a_report_is_made_again_from_its_results(tiny_report):
    """The tiny report (conftest.py): every claim results.json holds is made again from the
    fields it names, they are the claims this code makes of those results, and the report
    shows their words."""
    results = json.loads((tiny_report / "results.json").read_text())
    stored = results["claims"]
    assert _made_again(results, stored) >= 15
    assert report_words(results) == {"claims": stored, "findings": results["findings"]}
    md = (tiny_report / "README.md").read_text()
    findings_md = md.split("## Findings\n\n", 1)[1].split("\n## ", 1)[0]
    assert findings_md.startswith(claims.text(stored["conclusion"]) + "\n\n")
    bullets = [ln[2:] for ln in findings_md.splitlines() if ln.startswith("- ")]
    assert bullets == results["findings"]
    made = [claims.text(p) for p in stored["findings"]]
    assert [b for b in bullets if b not in made] == _plain_statements(results)
    assert claims.text(stored["intro"]) in md and claims.text(stored["regenerate"]) in md
    for c in stored["summary"]:
        assert f"[{c['values']['block']}](#" in md
    for part in ("precision", "catalogue"):
        assert claims.text(stored["physics"][part]) in md


#: Version 1's names of the posteriors' keys (written out here, not taken from the upgrade).
_V1 = {"fits_posterior": "fits_mcmc", "ranking_posterior": "ranking_mcmc",
       "order_posterior": "order_mcmc"}  # fmt: skip


def _as_version_1(results: dict) -> dict:
    """``results`` as fitdf wrote it before the posteriors were renamed: the blocks' keys,
    the settings' and the timing's, and the paths in the stored claims."""
    old = json.loads(json.dumps(results))
    del old["schema_version"]
    for block in old["blocks"].values():
        for new, was in _V1.items():
            block[was] = block.pop(new)
    s = old["settings"]
    s["mcmc_top"], s["mcmc_skip"] = s.pop("posterior_top"), s.pop("posterior_skip")
    s["methods"] = ["mcmc" if m == "posterior" else m for m in s["methods"]]
    old["timing"]["mcmc_cv_cross_limit_s"] = old["timing"].pop("second_phase_s")
    text = json.dumps(old["claims"])
    for new, was in _V1.items():
        text = text.replace(f"/{new}/", f"/{was}/")
    old["claims"] = json.loads(text)
    return old


def test_a_report_of_the_earlier_schema_says_what_its_numbers_say(tiny_report):
    """The tiny report written with version 1's keys and claim paths: read through the
    upgrade, every stored claim is made again from its fields, the words are this code's,
    and it renders as the report it was."""
    results = json.loads((tiny_report / "results.json").read_text())
    old = _as_version_1(results)
    assert "fits_mcmc" in old["blocks"]["B.1"] and "/ranking_mcmc/" in json.dumps(old["claims"])
    upgraded = upgrade(old)
    assert upgraded == results
    assert _made_again(upgraded, upgraded["claims"]) >= 15
    assert report_words(old) == {"claims": results["claims"], "findings": results["findings"]}
    assert render_markdown(old) == (tiny_report / "README.md").read_text()


def test_the_claims_of_a_record_of_many_laws_are_made_again():
    """The rules on the committed report's numbers (eight laws, seven blocks, posteriors; read
    through the schema upgrade): every claim this code makes of them is made again from its fields, each criterion named
    read from its own."""
    results = read_results(COMMITTED)
    words = report_words(results)
    assert _made_again(results, words["claims"]) >= 40
    kinds = {c["kind"] for c in every_claim(words["claims"])}
    assert {"conclusion.ties", "block.posteriors", "block.disagreement", "summary.block"} <= kinds


def test_the_report_states_each_rule_from_its_constant(monkeypatch):
    """The convergence rule, the Kass-Raftery scale, the quadrature nodes and the prior boxes
    the report states are rendered from the constants the code applies: changing one changes
    the text."""
    import fitdf.report.block_outline as block_outline
    import fitdf.report.document as document
    import fitdf.report.outline as outline

    results = read_results(COMMITTED)
    before = render_markdown(results)
    assert (
        "converged means at least 400 effective draws (Kish) and an evidence error of at most 0.3."
        in before
    )
    assert (
        "(2 ln B: below 2 not worth more than a bare mention, 2-6 positive, 6-10 strong, above 10 very strong)"
        in before
    )
    assert "converged at 400 effective draws and an evidence error of at most 0.3)" in before
    assert "the prior's three quadrature nodes (median and median x/÷ e^(1.73 sigma))" in before
    assert "halved (about the best fit) and doubled (about its centre); a shift" in before
    monkeypatch.setattr(block_outline, "MIN_EFFECTIVE", 401)
    monkeypatch.setattr(block_outline, "MAX_LOG_EVIDENCE_ERROR", 0.25)
    monkeypatch.setattr(block_outline, "KASS_RAFTERY", ((2.5, "bare"), (7.0, "positive")))
    monkeypatch.setattr(outline, "MIN_EFFECTIVE", 402)
    monkeypatch.setattr(outline, "PRIOR_NODES", (-2.0, -1.0, 0.0, 1.0, 2.0))
    monkeypatch.setattr(document, "SENSITIVITY_FACTORS", (0.5, 3.0))
    after = render_markdown(results)
    assert (
        "converged means at least 401 effective draws (Kish) and an evidence error of at most 0.25."
        in after
    )
    assert "(2 ln B: below 2.5 bare, 2.5-7 positive, above 7 very strong)" in after
    assert "converged at 402 effective draws" in after
    assert "the prior's five quadrature nodes (median and median x/÷ e^(2.00 sigma))" in after
    assert "400 effective draws (Kish)" not in after
    assert "halved (about the best fit) and tripled (about its centre); a shift" in after
    assert "the prior box halved and tripled for the best 2 of each block" in after


def test_the_committed_report_says_what_its_numbers_say():
    """The committed results.json holds its claims, each made again from its fields, and
    they are what this code says of its numbers (read through the schema upgrade,
    fitdf.report.upgrade; fails until the report is regenerated with this code:
    ``fitdf report --full --out reports``)."""
    results = read_results(COMMITTED)
    assert "claims" in results, "reports/results.json holds no claims: regenerate it"
    assert _made_again(results, results["claims"]) >= 40
    assert report_words(results) == {"claims": results["claims"], "findings": results["findings"]}
    assert results["run"]["command"] is not None
    assert claims.text(results["claims"]["intro"]) in (REPO / "reports" / "README.md").read_text()


def test_a_range_prints_once_when_its_ends_print_alike():
    assert claims.span(0.0042, 0.00424, ".4f", "lo", "hi") == "{lo:.4f}"
    assert claims.span(0.0042, 0.0048, ".4f", "lo", "hi") == "{lo:.4f}-{hi:.4f}"


def test_the_posteriors_statement_counts_the_widened_boxes_that_missed():
    res = _results()
    fits = res["blocks"]["B.1"]["fits_posterior"]
    for fit in list(fits.values()) + list(res["blocks"]["B.2"]["fits_posterior"].values()):
        fit["diagnostics"].update(n_likelihood_evaluations=20000, log_evidence_error=0.04)
    boxes = [{"factor": 0.5}, {"factor": 2.0, "consistent": True}]
    fits["a"]["diagnostics"]["prior_sensitivity"] = {"boxes": boxes}
    fits["b"]["diagnostics"]["prior_sensitivity"] = {"boxes": [{"factor": 2.0, "consistent": True}]}
    said = claim("findings.posteriors", res)["text"]
    assert said.startswith("Nested sampling: 4 of 4 posteriors meet the convergence rule (400 ")
    assert "in 20,000 likelihood evaluations; evidence errors 0.04." in said
    assert said.endswith("none of the 2 runs missed the posterior the prior's box holds.")
    fits["b"]["diagnostics"]["prior_sensitivity"]["boxes"][0]["consistent"] = False
    said = claim("findings.posteriors", res)["text"]
    assert "With the prior box widened, 1 of 2 runs missed the posterior" in said
    assert "more than 3 errors below the exact part inside it): not converged" in said
    del fits["b"]["diagnostics"]["prior_sensitivity"]["boxes"][0]["consistent"]  # an old record
    said = claim("findings.posteriors", res)["text"]
    assert "the one run did not miss the posterior" in said
    assert said.endswith("1 of the widened boxes hold no stratified estimate (a record from "
                         "before it): their evidence is not a result.")  # fmt: skip


def test_the_sentences_best_law_is_the_selection_rules(tiny_report):
    """The best law and its AICc ties that the sentences recompute from the ranking's columns
    (fitdf.report.criteria) are the selection rule's record of the block
    (fitdf.inference.selection), so that the report and `fitdf fit` mean one thing by best."""
    results = json.loads((tiny_report / "results.json").read_text())
    for key, rec in results["blocks"].items():
        rows = rec["ranking_lsq"]
        models, aicc = [r["model"] for r in rows], [r["aicc"] for r in rows]
        sel = rec["selection"]
        assert criteria.best_law(models, aicc) == sel["best"]["model"], key
        tied = {m for m, _ in criteria.aicc_ties(models, aicc)}
        assert tied == {t.split("/")[0] for t in sel["ties"]}, key


def _factor_results(rows):
    keys = ("table", "frequency_hz", "factor_printed", "factor_data", "follows_printed")
    blocks = [
        dict(zip(keys, r), rows_printed_ok=2, rows_with_output=5, source_impedance_ohm=0.0)
        for r in rows
    ]
    tables = [{"table": "B.9", "flagged": 3, "excluded_by_default": 1, "rows": 10}]
    return {"audit": {"tables": tables, "block_factors": blocks, "findings": []}}


def test_the_audit_statements_are_the_audits_own_sentences(tiny_report):
    """The audit's Findings claims (fitdf.report.audit_claims) say what the audit's own
    sentences (fitdf.data.audit, computed from the tables by another path) say of the tables
    whose rows do not follow their footnote factor, and count the flagged rows."""
    results = json.loads((tiny_report / "results.json").read_text())
    audit = results["audit"]
    said = [claims.text(p) for p in audit_claims.audit_findings(results)]
    n_flag = sum(t["flagged"] for t in audit["tables"])
    assert said[0].startswith(f"The audit of the printed tables flags {n_flag} of ")
    theirs = [f for f in audit["findings"] if "footnote factor" in f and "followed by all" not in f]
    assert said[1:] == theirs and len(theirs) >= 2  # B.1 and B.2 print a factor they do not follow


def test_the_audit_factor_statement_at_its_boundaries():
    """All blocks following the footnote: nothing to say; one block off: '1 of 2'; every block
    off: 'all'; no footnote printed: the factor the data follow."""
    follow = _factor_results([("B.9", 3.0, 2.0, 2.0, True), ("B.9", 6.0, 2.0, 2.0, None)])
    assert audit_claims.audit_findings(follow)[1:] == []
    one = _factor_results([("B.9", 3.0, 2.0, 2.2, False), ("B.9", 6.0, 2.0, 2.0, True)])
    (c,) = audit_claims.audit_findings(one)[1]
    assert c["text"] == (
        "B.9: the footnote factor 2 fits 2 of 5 rows in 1 of 2 frequency blocks (3 c/s); the "
        "data follow 2.100 (blocks 2.000-2.200), i.e. 1.050 x the footnote."
    )
    both = _factor_results([("B.9", 3.0, 2.0, 2.2, False), ("B.9", 6.0, 2.0, 2.2, False)])
    (c,) = audit_claims.audit_findings(both)[1]
    assert "4 of 10 rows in all frequency blocks (3, 6 c/s)" in c["text"]
    assert "(blocks 2.200)" in c["text"]  # a spread whose ends print alike prints once
    none = _factor_results([("B.9", 3.0, None, 1.5, None)])
    (c,) = audit_claims.audit_findings(none)[1]
    assert c["text"] == (
        "B.9: no footnote factor; the data follow DF = 1.500 x output / input (blocks 1.500)."
    )
    (c,) = audit_claims.audit_findings(none)[0]
    assert c["text"].startswith(
        "The audit of the printed tables flags 3 of 10 rows and excludes 1 "
    )
