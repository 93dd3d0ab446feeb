"""results.json of schema version 1 read as version 2 (fitdf.report.upgrade).

The renames are written out here by hand (not taken from the module), and a record is checked
leaf by leaf: every value of the old record sits at its renamed path in the upgraded one, and
the upgraded one holds nothing else but its ``schema_version``.
"""

from __future__ import annotations

import copy
import json
import subprocess
import sys
from pathlib import Path

import pytest

from fitdf.report.claims import claim, rule, say
from fitdf.report.upgrade import SCHEMA_VERSION, read_results, upgrade, upgrade_path

COMMITTED = Path(__file__).resolve().parents[1] / "reports" / "results.json"

#: Version 1's key -> version 2's, by where it sits (``*``: any block).
RENAMES = {
    ("settings", "mcmc_top"): ("settings", "posterior_top"),
    ("settings", "mcmc_skip"): ("settings", "posterior_skip"),
    ("blocks", "*", "fits_mcmc"): ("blocks", "*", "fits_posterior"),
    ("blocks", "*", "ranking_mcmc"): ("blocks", "*", "ranking_posterior"),
    ("blocks", "*", "order_mcmc"): ("blocks", "*", "order_posterior"),
    ("timing", "mcmc_cv_cross_limit_s"): ("timing", "second_phase_s"),
}


def _leaves(node, path=()):
    """``{path: value}`` of every leaf of a JSON record (an empty dict or list is a leaf)."""
    if isinstance(node, dict) and node:
        return {p: v for k, c in node.items() for p, v in _leaves(c, (*path, k)).items()}
    if isinstance(node, list) and node:
        return {p: v for i, c in enumerate(node) for p, v in _leaves(c, (*path, i)).items()}
    return {path: node}


def _renamed(path: tuple) -> tuple:
    for old, new in RENAMES.items():
        n = len(old)
        if len(path) >= n and all(o in ("*", p) for o, p in zip(old, path)):
            return tuple(p if o == "*" else nw for o, nw, p in zip(old, new, path)) + path[n:]
    return path


def _v1_record() -> dict:
    """A version 1 record with every renamed key, a claim reading them, and an emcee fit."""
    fit = {"method": "mcmc", "diagnostics": {"converged": True}}
    return {
        "fitdf_version": "0.1.0",
        "settings": {"methods": ["lsq", "mcmc"], "mcmc_top": 2, "mcmc_skip": ["preisach"],
                     "sampler": "emcee", "posterior_blocks": None},
        "blocks": {
            "B.1": {"ranking_lsq": [{"model": "a"}], "ranking_mcmc": [{"model": "a", "looic": 1.5}],
                    "fits_mcmc": {"a": fit}, "order_mcmc": ["a"], "order_lsq": ["a"]},
            "B.2": {"ranking_mcmc": [], "fits_mcmc": {}, "order_mcmc": []},
        },
        "timing": {"least_squares_s": 1.0, "mcmc_cv_cross_limit_s": 2.0, "jobs_s": {"mcmc B.1 a": 2.0}},
        "claims": {"conclusion": [{"kind": "conclusion.chains", "subject": {}, "text": "x",
                                   "fields": {"converged": "blocks/*/fits_mcmc/*/diagnostics/converged",
                                              "looic": "blocks/B.1/ranking_mcmc/*/looic",
                                              "top": "settings/mcmc_top", "aicc": "blocks/*/ranking_lsq/*/aicc"}}],
                   "findings": [[{"kind": "findings.x", "fields": {"t": "timing/mcmc_cv_cross_limit_s"}}]]},
    }  # fmt: skip


def test_an_old_record_upgraded_is_the_new_one():
    old = _v1_record()
    before = copy.deepcopy(old)
    new = upgrade(old)
    assert old == before  # the input is not changed
    assert new["schema_version"] == SCHEMA_VERSION == 2
    assert new["settings"]["methods"] == ["lsq", "posterior"]
    claims = {k: new["claims"]["conclusion"][0]["fields"][k] for k in ("converged", "looic", "top")}
    assert claims == {
        "converged": "blocks/*/fits_posterior/*/diagnostics/converged",
        "looic": "blocks/B.1/ranking_posterior/*/looic",
        "top": "settings/posterior_top",
    }
    assert new["claims"]["findings"][0][0]["fields"]["t"] == "timing/second_phase_s"
    # leaf by leaf: each old value at its renamed path, nothing else (the methods and the
    # claims' paths aside, checked above)
    moved = {_renamed(p): v for p, v in _leaves(old).items()}
    got = _leaves(new)
    del got[("schema_version",)]
    for leaves in (moved, got):
        for p in [p for p in leaves if p[:2] == ("settings", "methods") or p[0] == "claims"]:
            del leaves[p]
    assert got == moved
    # the job keys name the sampler that ran (emcee: "mcmc"), and the fits their method
    assert new["timing"]["jobs_s"] == {"mcmc B.1 a": 2.0}
    assert new["blocks"]["B.1"]["fits_posterior"]["a"]["method"] == "mcmc"


def test_a_current_record_is_read_as_it_is_and_a_later_one_refused():
    new = upgrade(_v1_record())
    assert upgrade(new) is new
    with pytest.raises(ValueError, match="schema version 3"):
        upgrade({**new, "schema_version": 3})
    assert upgrade_path("blocks/B.5/order_mcmc") == "blocks/B.5/order_posterior"
    assert upgrade_path("blocks/B.5/ranking_lsq/*/aicc") == "blocks/B.5/ranking_lsq/*/aicc"
    assert upgrade_path("physics/fits_mcmc") == "physics/fits_mcmc"  # only where the key sits


def test_read_results_takes_a_file_or_its_folder(tmp_path):
    (tmp_path / "results.json").write_text(json.dumps(_v1_record()))
    assert read_results(tmp_path) == read_results(tmp_path / "results.json")
    assert read_results(tmp_path) == upgrade(_v1_record())


@pytest.mark.skipif(not COMMITTED.exists(), reason="no committed reports/results.json")
def test_the_committed_report_read_as_the_current_schema():
    raw = json.loads(COMMITTED.read_text())
    new = read_results(COMMITTED)
    assert new["schema_version"] == SCHEMA_VERSION
    if raw.get("schema_version") == SCHEMA_VERSION:
        assert new == raw
        return
    methods = [{"mcmc": "posterior"}.get(m, m) for m in raw["settings"].get("methods", [])]
    assert new["settings"].get("methods", []) == methods

    def kept(record):
        return {
            p: v
            for p, v in _leaves(record).items()
            if p[0] not in ("claims", "schema_version") and p[:2] != ("settings", "methods")
        }

    assert kept(new) == {_renamed(p): v for p, v in kept(raw).items()}
    for key, block in new["blocks"].items():
        assert block["fits_posterior"] == raw["blocks"][key]["fits_mcmc"]
        assert "fits_mcmc" not in block and "ranking_mcmc" not in block


def _by_hand(old: dict) -> dict:
    """Version 2 of ``old`` by text substitution (independent of the module's mapping)."""
    text = json.dumps(old)
    for was, new in (
        ('["lsq", "mcmc"]', '["lsq", "posterior"]'),
        ("fits_mcmc", "fits_posterior"),
        ("ranking_mcmc", "ranking_posterior"),
        ("order_mcmc", "order_posterior"),
        ("mcmc_top", "posterior_top"),
        ("mcmc_skip", "posterior_skip"),
        ("mcmc_cv_cross_limit_s", "second_phase_s"),
    ):
        text = text.replace(was, new)
    return {"schema_version": 2, **json.loads(text)}


def test_the_comparison_script_compares_an_old_file_with_a_new_one(tmp_path):
    """.ci/compare_results.py reads both files as the current schema: an old-key file and its
    new-key twin compare equal (and differ as written, --as-is); a changed number is found."""
    script = Path(__file__).resolve().parents[1] / ".ci" / "compare_results.py"
    old, new = _v1_record(), _by_hand(_v1_record())
    assert upgrade(old) == new
    paths = {}
    for name, record in (("old", old), ("new", new)):
        paths[name] = tmp_path / f"{name}.json"
        paths[name].write_text(json.dumps(record))

    def compare(*extra):
        cmd = [sys.executable, str(script), str(paths["old"]), str(paths["new"]), *extra]
        return subprocess.run(cmd, capture_output=True, text=True, timeout=60)

    same = compare()
    assert same.returncode == 0 and same.stdout.strip() == "0 differences", same.stdout
    as_is = compare("--as-is")
    assert as_is.returncode == 1 and "/blocks/B.1/fits_mcmc: only in old" in as_is.stdout
    new["blocks"]["B.1"]["ranking_posterior"][0]["looic"] = 1.6
    paths["new"].write_text(json.dumps(new))
    changed = compare()
    assert changed.returncode == 1
    assert "/blocks/B.1/ranking_posterior[0]/looic: 1.5 != 1.6" in changed.stdout


@rule("test.upgrade.sampled", models="blocks/{block}/ranking_posterior/*/model")
def _sampled(models, block):
    return say("{n} sampled on {block}.", n=len(models or []), block=block)


def test_a_claim_reads_an_old_record_by_the_current_paths():
    """A rule reads version 2's paths; given a version 1 record, the claim reads it as
    version 2 (a claim made again from a report written before the renames)."""
    old = _v1_record()
    said = claim("test.upgrade.sampled", old, block="B.1")
    assert said["text"] == "1 sampled on B.1."
    assert said["fields"] == {"models": "blocks/B.1/ranking_posterior/*/model"}
    assert said == claim("test.upgrade.sampled", upgrade(old), block="B.1")
