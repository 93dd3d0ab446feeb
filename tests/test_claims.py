"""Every sentence the report generates, made again from results.json (fitdf.report.claims).

The mechanism first (paths, templates, the numbers a template may print), then one generic
test over every claim of a report made here and of the committed report: each is made again
from the fields it names and must come out the same, its template prints no number of its
own, and the words the report shows are the claims' words.
"""

from __future__ import annotations

import pytest

from fitdf.report import claims
from fitdf.report.claims import claim, literal_numbers, paragraph, recompute, resolve, rule, say

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
