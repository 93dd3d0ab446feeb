"""Column-order check (6) of the audit and the row policies that apply it (fitdf.data.audit)."""

import numpy as np
import pandas as pd
import pytest

from fitdf.data import audit, datasets
from fitdf.data.audit_rules import FLAT_RANGE, REVERSAL_FIT, REVERSAL_GAIN
from fitdf.data.resolve import resolve_data
from fitdf.errors import OptionError

B5_10_PRINTED = [44, 43, 39, 35, 30, 23, 12, 0, 4, 4, 6, 15, 41]


@pytest.fixture(scope="module")
def b():
    return datasets.load("appendix_b")


@pytest.fixture(scope="module")
def order(b):
    return audit.reversals(b)


def one(order, table, f, column):
    sel = order[
        (order["table"] == table) & (order["frequency_hz"] == f) & (order["column"] == column)
    ]
    assert len(sel) == 1
    return sel.iloc[0]


def flagged(frame):
    """(table, frequency, column) of every block whose rows a reversing policy reverses."""
    rows = frame[frame["reversed_columns"] != ""]
    return set(zip(rows["table"], rows["frequency_hz"], rows["reversed_columns"]))


def reversed_copy(b, table, f, columns):
    """Appendix B with ``columns`` of one block reversed in printed order."""
    out = b.copy()
    g = out[(out["table"] == table) & (out["frequency_hz"] == f)].sort_values("row_in_block")
    for c in columns:
        for name in (c, f"{c}_decimals"):
            if name in out:
                out.loc[g.index, name] = g[name].to_numpy()[::-1]
    return out


# ------------------------------------------------------------------ the thesis data
def test_only_b5_10_phase_reads_reversed(b, order):
    flags = order[order["reversed"]]
    assert list(zip(flags["table"], flags["frequency_hz"], flags["column"])) == [
        ("B.5", 10.0, "phase_lead_deg")
    ]
    a = audit.audit(b)
    assert flagged(a) == {("B.5", 10.0, "phase_lead_deg")}
    rows = a[a["reversed_columns"] != ""]
    assert len(rows) == 13 and (rows["flag"] == "suspect").all()
    # the printed cells keep their trust: the policy, not the trust flags, decides the order
    assert rows["phase_trusted"].all() and not rows["exclude_default"].any()


def test_b5_10_phase_evidence(order):
    r = one(order, "B.5", 10, "phase_lead_deg")
    # 5 other frequencies; 50 c/s is flat (0 deg) where it overlaps, so 4 are compared
    assert r["neighbours"] == 4
    assert r["rho_printed"] == pytest.approx(-0.08, abs=0.02)
    assert r["rho_reversed"] == pytest.approx(0.91, abs=0.02)
    assert r["gain"] >= 1.8 * REVERSAL_GAIN and r["rho_reversed"] >= 2.5 * REVERSAL_FIT
    # the distance to the neighbours' median curve falls by a factor of ~3 (degrees)
    assert r["misfit_printed"] == pytest.approx(29.2, abs=1.0)
    assert r["misfit_reversed"] == pytest.approx(9.9, abs=1.0)
    # minimum two rows past the ** row as printed (row 8, 2.5 V), at it reversed (row 6, 1.5 V)
    assert (r["extreme_printed"], r["extreme_reversed"]) == (2, 0)


def test_every_other_column_is_far_from_the_threshold(order):
    judged = order[~order["verdict"].str.startswith("cannot")]
    others = judged[~judged["reversed"]]
    assert len(judged) == 57 and len(others) == 56
    # reversing never helps a genuine column by more than a twentieth of the threshold ...
    assert others["gain"].max() == pytest.approx(0.023, abs=0.01)
    assert others["gain"].max() < REVERSAL_GAIN / 20
    # ... and every genuine printed column fits its neighbours above the fit threshold
    assert others["rho_printed"].min() == pytest.approx(0.36, abs=0.01)
    assert (others["rho_printed"] > REVERSAL_FIT).all()
    # the output rises with the input in every block: reversed it runs against the neighbours
    h1 = others[others["column"] == "h1_output_v"]
    assert len(h1) == 21 and (h1["rho_printed"] >= 0.95).all() and (h1["gain"] <= -1.6).all()


def test_flat_columns_are_not_judged(order):
    flat = order[order["verdict"].str.startswith("cannot")]
    assert sorted(zip(flat["table"], flat["frequency_hz"], flat["column"])) == [
        ("B.1", f, c) for f in (6.0, 10.0, 20.0) for c in ("df_reported", "phase_lead_deg")
    ]
    assert flat["verdict"].str.contains("its values span only").all()
    assert FLAT_RANGE == {"phase_lead_deg": 10.0, "df_reported": 0.1}


def test_findings_state_the_evidence_and_the_decision(b):
    text = audit.findings(b)
    summary = next(s for s in text if s.startswith("Column order:"))
    assert "57 of the 63 (block, column) pairs could be judged" in summary
    assert "1 reads better in reverse order (B.5 f=10 c/s phase_lead_deg)" in summary
    assert "by at most +0.02 (threshold +0.5)" in summary
    s = next(s for s in text if s.startswith("B.5 f=10 c/s phase_lead_deg (13 rows"))
    assert "median rank correlation is -0.08 as printed and +0.91 reversed" in s
    assert "2 rows after the saturation row as printed, at the saturation row reversed" in s
    assert "printed 44, 43, 39, 35, 30, 23, 12, 0, 4, 4, 6, 15, 41" in s
    assert "The 'default' policy fits it reversed" in s and "'as_printed' fits it as printed" in s
    # said once for the block, not once per row
    assert not any(s.startswith("B.5 f=10 c/s row") for s in text)
    assert text[-1].startswith(
        "Row policies on these 264 rows: 'all' keeps 262, 'default' keeps 255 (with the 13 rows"
    )


def test_row_reasons_name_the_value_fitted(b):
    a = audit.audit(b)
    g = a[(a["table"] == "B.5") & (a["frequency_hz"] == 10)].sort_values("row_in_block")
    first, sat = g.iloc[0], g[g["saturation"]].iloc[0]
    assert "the default policy fits 41, printed in row 13" in first["reasons"]
    assert (
        sat["phase_lead_deg"] == 23
        and "the default policy fits 0, printed in row 8" in (sat["reasons"])
    )


# ------------------------------------------------------------------ synthetic reversals
@pytest.mark.parametrize(
    "table,f,column,rho_printed,rho_reversed",
    [
        ("B.5", 20, "df_reported", -0.45, 0.67),
        ("B.5", 3, "phase_lead_deg", -0.71, 0.37),
        ("B.4", 3, "phase_lead_deg", 0.0, 0.85),
        ("B.3", 6, "h1_output_v", -1.0, 1.0),
    ],
)
def test_a_reversed_clean_column_is_flagged(b, order, table, f, column, rho_printed, rho_reversed):
    clean = one(order, table, f, column)
    assert clean["verdict"] == "as printed" and clean["gain"] <= -REVERSAL_GAIN
    copy = reversed_copy(b, table, f, [column])
    r = one(audit.reversals(copy), table, f, column)
    # the copy's printed order is the thesis's reversed one, and vice versa
    assert r["rho_printed"] == pytest.approx(clean["rho_reversed"], abs=1e-9)
    assert r["rho_printed"] == pytest.approx(rho_printed, abs=0.02)
    assert r["rho_reversed"] == pytest.approx(rho_reversed, abs=0.02)
    assert r["reversed"] and r["verdict"] == "reversed"
    # nothing else changes: the genuine finding stays, no neighbour is blamed
    assert flagged(audit.audit(copy)) == {
        (table, float(f), column),
        ("B.5", 10.0, "phase_lead_deg"),
    }


def test_a_near_symmetric_column_cannot_be_told(b, order):
    """B.5 20 c/s phase (minimum in mid-block) reads nearly alike either way: not claimed."""
    clean = one(order, "B.5", 20, "phase_lead_deg")
    assert clean["verdict"] == "as printed" and clean["gain"] == pytest.approx(-0.21, abs=0.02)
    r = one(
        audit.reversals(reversed_copy(b, "B.5", 20, ["phase_lead_deg"])),
        "B.5",
        20,
        "phase_lead_deg",
    )
    assert r["gain"] == pytest.approx(0.21, abs=0.02) and not r["reversed"]
    # the extreme veto alone would not have saved it: reversed back, the minimum is 1 row off
    assert (r["extreme_printed"], r["extreme_reversed"]) == (-4, -1)


def test_the_table_with_b5_10_phase_put_back_is_clean(b):
    fixed = reversed_copy(b, "B.5", 10, ["phase_lead_deg"])
    assert flagged(audit.audit(fixed)) == set()
    r = one(audit.reversals(fixed), "B.5", 10, "phase_lead_deg")
    assert r["rho_printed"] == pytest.approx(0.91, abs=0.02)


def test_a_reversed_input_column_is_reported_as_the_input(b):
    """Input and its ** mark reversed: output, DF and phase all read reversed against it."""
    copy = reversed_copy(b, "B.3", 3, ["input_v", "saturation"])
    a = audit.audit(copy)
    assert flagged(a) == {("B.3", 3.0, "input_v"), ("B.5", 10.0, "phase_lead_deg")}
    rec = one(audit.reversals(copy), "B.3", 3, "input_v")
    assert rec["verdict"].startswith("reversed: phase_lead_deg, df_reported, h1_output_v")
    text = audit.findings(copy)
    assert any(
        s.startswith("B.3 f=3 c/s input_v (11 rows") and "none reads better as printed" in s
        for s in text
    )
    # the default policy puts the inputs back: the same measurements as the thesis block
    key = ["input_v", "df_reported", "phase_lead_deg"]
    got = resolve_data(copy[copy["table"] == "B.3"], "default").rows
    want = resolve_data(b[b["table"] == "B.3"], "default").rows
    pick = lambda d: d[d["frequency_hz"] == 3][key].sort_values("input_v").to_numpy()  # noqa: E731
    np.testing.assert_array_equal(pick(got), pick(want))


def test_a_reversed_output_beside_a_duplicate_does_not_crash(b):
    # B.2 3 c/s prints row 7 twice; with its outputs reversed the repeat is inconsistent
    copy = reversed_copy(b, "B.2", 3, ["h1_output_v"])
    a = audit.audit(copy)
    assert ("B.2", 3.0, "h1_output_v") in flagged(a)


# ------------------------------------------------------------------ no neighbours
def single_block(tmp_path, freqs=(10,)):
    a_v = np.array([0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0, 2.5, 3.0])
    d = np.round(0.3 + 0.4 * a_v / (a_v + 0.3), 3)
    p = np.round(40 / (1 + 5 * a_v), 1)
    path = tmp_path / "bench.csv"
    lines = ["input_v,df_reported,phase_lead_deg,frequency_hz"]
    lines += [f"{x:g},{y:.3f},{z:.1f},{f}" for f in freqs for x, y, z in zip(a_v, d, p)]
    path.write_text("\n".join(lines) + "\n")
    return datasets.load(path)


@pytest.mark.parametrize("freqs,most", [((10,), 0), ((10, 20), 1)])
def test_without_two_neighbours_the_rule_cannot_judge(tmp_path, freqs, most):
    frame = single_block(tmp_path, freqs)
    order = audit.reversals(frame)
    assert list(order["column"]) == ["phase_lead_deg", "df_reported"] * len(freqs)  # no h1
    # one frequency: no neighbour; two: at most one (with one, either block could be reversed)
    found = order["verdict"].str.extract(
        r"^cannot judge: (\d) comparable neighbour\(s\), 2 needed$"
    )
    assert found[0].notna().all() and found[0].astype(int).max() == most
    assert not order["reversed"].any() and order["rho_printed"].isna().all()
    text = audit.findings(frame)
    assert any(
        s.startswith(f"Column order: 0 of the {2 * len(freqs)} (block, column) pairs") for s in text
    )
    for policy in audit.POLICIES[:3]:
        assert len(audit.select_rows(frame, policy)) == 10 * len(freqs)


def test_a_reversed_single_block_is_not_blamed(tmp_path):
    frame = single_block(tmp_path)
    frame["phase_lead_deg"] = frame["phase_lead_deg"].to_numpy()[::-1]
    out = audit.audit(frame)
    assert (out["reversed_columns"] == "").all()
    assert audit.select_rows(out, "default")["phase_lead_deg"].tolist() == (
        frame["phase_lead_deg"].tolist()
    )


# ------------------------------------------------------------------ policies
def test_policy_names():
    assert audit.POLICIES == ("default", "as_printed", "all", "strict")
    with pytest.raises(OptionError, match="choose one of default, as_printed, all, strict"):
        audit.select_rows(pd.DataFrame(), "reversed")


def test_policy_counts(b):
    a = audit.audit(b)
    counts = {p: len(audit.select_rows(a, p)) for p in audit.POLICIES}
    assert counts == {"default": 255, "as_printed": 255, "all": 262, "strict": 210}
    assert (a["exclude_default"] == a["exclude_as_printed"]).all()


def b5_10_phases(data):
    """Phases the fit receives for Table B.5 at 10 c/s, in increasing input order."""
    m = (data.group == "B.5") & (data.frequency == 10)
    order = np.argsort(data.amplitude[m], kind="stable")
    return np.round(np.degrees(np.angle(data.measured[m][order])), 6).tolist()


@pytest.mark.parametrize("src,ohm", [("B.5", None), ("deltamax", 600), ("appendix_b", None)])
def test_the_reversing_policy_delivers_the_reversed_phases_to_the_fit(src, ohm):
    default, printed = (resolve_data(src, p, ohm) for p in ("default", "as_printed"))
    assert b5_10_phases(default) == B5_10_PRINTED[::-1]
    assert b5_10_phases(printed) == B5_10_PRINTED
    assert b5_10_phases(resolve_data(src, "all", ohm)) == B5_10_PRINTED
    assert b5_10_phases(resolve_data(src, "strict", ohm)) == []  # its rows are suspect
    # the magnitudes, the other blocks and the rows are untouched
    m = (default.group == "B.5") & (default.frequency == 10)
    assert default.n == printed.n
    np.testing.assert_array_equal(default.amplitude, printed.amplitude)
    np.testing.assert_allclose(np.abs(default.measured), np.abs(printed.measured), rtol=1e-12)
    np.testing.assert_array_equal(default.measured[~m], printed.measured[~m])
    rows = default.rows[m]
    assert (rows["reversed_columns"] == "phase_lead_deg").all()
    assert rows.sort_values("input_v")["phase_lead_deg_printed"].tolist() == B5_10_PRINTED
    assert rows["phase_trusted"].all() and (rows["flag"] == "note").all()
    assert rows["reasons"].str.contains("phase_lead_deg taken in reverse order").all()
    assert (printed.rows["reversed_columns"][m] == "phase_lead_deg").all()  # said, not applied
    assert "phase_lead_deg_printed" not in printed.rows


def test_selecting_twice_does_not_reverse_twice(b):
    once = audit.select_rows(audit.audit(b), "default")
    twice = audit.select_rows(once, "default")
    pd.testing.assert_frame_equal(once, twice)
    # and a re-audit of the fitted values finds nothing left to reverse
    assert flagged(audit.audit(once)) == set()
