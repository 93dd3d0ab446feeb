"""Transcription of the thesis tables and the validating loader (fitdf.datasets)."""

import math
import tomllib
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from fitdf.data import datasets
from fitdf.errors import DataError

REPO = Path(__file__).resolve().parent.parent
#: Appendix B of the thesis text (lines 1676-2034 of thesis.txt, verbatim), which the rows of
#: appendix_b.csv cite by line number.
THESIS_APPENDIX_B = REPO / "tests" / "data" / "thesis_appendix_b.txt"
FIRST_LINE = 1676
#: The whole thesis text, where a checkout sits beside it (the project's work tree).
THESIS = REPO.parent / "shared" / "thesis.txt"

# Rows per (table, frequency) block, counted in Appendix B of the thesis (continuation
# pages included: the B.2, B.4 and B.5 continuations carry on their f = 10 c/s blocks).
EXPECTED_ROWS = {
    ("B.1", 3): 9,
    ("B.1", 6): 6,
    ("B.1", 10): 11,
    ("B.1", 20): 11,
    ("B.2", 3): 8,
    ("B.2", 6): 12,
    ("B.2", 10): 15,
    ("B.3", 3): 11,
    ("B.3", 6): 13,
    ("B.3", 10): 13,
    ("B.4", 3): 13,
    ("B.4", 6): 13,
    ("B.4", 10): 13,
    ("B.4", 30): 14,
    ("B.4", 50): 10,
    ("B.5", 3): 15,
    ("B.5", 6): 12,
    ("B.5", 10): 13,
    ("B.5", 20): 15,
    ("B.5", 30): 16,
    ("B.5", 50): 21,
}
# Input voltage of the row marked ** (saturation) in each block; B.4 f = 50 c/s has none.
SATURATION_INPUT = {
    ("B.1", 3): 0.75,
    ("B.1", 6): 1,
    ("B.1", 10): 2.25,
    ("B.1", 20): 4.5,
    ("B.2", 3): 0.3,
    ("B.2", 6): 0.7,
    ("B.2", 10): 1.1,
    ("B.3", 3): 1,
    ("B.3", 6): 1.5,
    ("B.3", 10): 2,
    ("B.4", 3): 1,
    ("B.4", 6): 1.5,
    ("B.4", 10): 2,
    ("B.4", 30): 8,
    ("B.5", 3): 0.7,
    ("B.5", 6): 1,
    ("B.5", 10): 1.5,
    ("B.5", 20): 3.5,
    ("B.5", 30): 4.5,
    ("B.5", 50): 7.5,
}
TABLE_META = {  # graph, core, core part, source impedance, footnote factor
    "B.1": ("5.1", "permalloy", "4178-P1", 0, 1250 / 417),
    "B.2": ("5.5", "deltamax", "4168-D2", 0, 2000 / 500),
    "B.3": ("5.7", "permalloy", "4178-P1", 600, 1),
    "B.4": ("5.13", "supermalloy", "4178-S4", 600, 1),
    "B.5": ("5.16", "deltamax", "4168-D2", 600, 1),
}


@pytest.fixture(scope="module")
def b():
    return datasets.load("appendix_b")


def row(b, table, f, n):
    sel = b[(b["table"] == table) & (b["frequency_hz"] == f) & (b["row_in_block"] == n)]
    assert len(sel) == 1
    return sel.iloc[0]


# ------------------------------------------------------------------ transcription
def test_row_counts_per_block(b):
    counts = b.groupby(["table", "frequency_hz"]).size()
    assert {(t, int(f)): int(n) for (t, f), n in counts.items()} == EXPECTED_ROWS
    assert len(b) == 264
    # row_in_block is 1..n in printed order, continuations included
    for (t, f), g in b.groupby(["table", "frequency_hz"]):
        assert g["row_in_block"].tolist() == list(range(1, EXPECTED_ROWS[(t, int(f))] + 1))


def test_saturation_rows(b):
    sat = b[b["saturation"]]
    assert {
        (t, int(f)): a for t, f, a in sat[["table", "frequency_hz", "input_v"]].values
    } == SATURATION_INPUT
    assert len(sat) == 20


def test_table_metadata(b):
    for table, (graph, core, part, rs, factor) in TABLE_META.items():
        g = b[b["table"] == table]
        assert (
            set(g["graph"]) == {graph}
            and set(g["core"]) == {core}
            and set(g["core_part"]) == {part}
        )
        assert set(g["source_impedance_ohm"]) == {rs}
        assert np.allclose(g["df_factor_printed"], factor, rtol=1e-12, atol=0)


@pytest.mark.parametrize(
    "table,f,n,cells",
    [
        ("B.1", 3, 1, (0.05, 0.014, 22, 0.922)),
        ("B.1", 3, 9, (1, 2.50, 15, 0.825)),
        ("B.1", 10, 6, (1.5, 0.435, 0.5, 0.955)),  # phase printed $\frac{1}{2}$
        ("B.1", 20, 1, (0.01, 0.003, 6, 0.99)),
        ("B.1", 20, 11, (5, 1.35, 2, 0.98)),
        ("B.2", 3, 1, (0.01, 0, 0, 0)),
        ("B.2", 10, 13, (1.1, 0.245, 1, 0.935)),  # first row of the continuation
        ("B.2", 10, 15, (1.3, 0.285, 6, 0.92)),
        ("B.3", 3, 11, (5.25, 0.91, 69, 0.158)),
        ("B.3", 10, 1, (0.01, 0.065, 45, 0.6)),  # 0.01 kept as printed
        ("B.4", 10, 9, (3, 2.88, 10, 0.96)),
        ("B.4", 10, 10, (3.5, 3.06, 18, 0.87)),  # B.4 continuation goes on at f=10
        ("B.4", 10, 13, (5, 3.31, 31, 0.66)),
        ("B.4", 50, 10, (16, 15.5, 6, 0.98)),
        ("B.5", 3, 1, (0.1, 0, 58, 0)),
        ("B.5", 20, 2, (0.2, 0.62, 48, 0.1)),  # 0.62 kept as printed
        ("B.5", 30, 5, (1, 0.63, 1.5, 0.63)),  # phase printed 1½
        ("B.5", 50, 6, (1.5, 0.01, 0, 0.672)),
        ("B.5", 50, 8, (2.5, 0.85, 0, 0.74)),  # both kept as printed
        ("B.5", 50, 21, (9.8, 6.55, 10, 0.667)),
    ],
)
def test_spot_values(b, table, f, n, cells):
    r = row(b, table, f, n)
    assert (r["input_v"], r["h1_output_v"], r["phase_lead_deg"], r["df_reported"]) == pytest.approx(
        cells, abs=1e-12
    )


def test_printed_duplicate_and_missing_phase_kept(b):
    r7, r8 = row(b, "B.2", 3, 7), row(b, "B.2", 3, 8)
    for r in (r7, r8):
        assert (r["input_v"], r["h1_output_v"], r["df_reported"]) == (0.6, 0.0865, 0.605)
        assert math.isnan(r["phase_lead_deg"])
    assert b["phase_lead_deg"].isna().sum() == 2


def test_printed_decimals_recorded(b):
    r = row(b, "B.4", 3, 6)  # printed "1.5  0.90  36  0.60": trailing zeros matter for the audit
    assert (r["input_v_decimals"], r["h1_output_v_decimals"], r["df_reported_decimals"]) == (
        1,
        2,
        2,
    )


def test_source_lines_increase(b):
    lines = b["source"].str.extract(r"^thesis\.txt line (\d+)$")[0].astype(int)
    assert lines.is_monotonic_increasing and lines.is_unique
    assert lines.iloc[0] == 1676 and lines.iloc[-1] == 2034


def test_every_row_matches_its_source_line():
    text = THESIS_APPENDIX_B.read_text(encoding="utf-8").split("\n")
    raw = pd.read_csv(
        datasets.data_dir().joinpath("appendix_b.csv"), dtype=str, keep_default_na=False
    )
    half = {"$\\frac{1}{2}$": "0.5", "1½": "1.5", "--": ""}
    for _, r in raw.iterrows():
        line = text[int(r["source"].split()[-1]) - FIRST_LINE]
        cells = [c for c in line.split() if c.lower() not in ("volts", "deg.")]
        assert cells[0].endswith("**") == (r["saturation"] == "true")
        printed = [cells[0].rstrip("*"), cells[1], half.get(cells[2], cells[2]), cells[3]]
        assert printed == [r["input_v"], r["h1_output_v"], r["phase_lead_deg"], r["df_reported"]], (
            line
        )


@pytest.mark.skipif(not THESIS.exists(), reason="the whole thesis text is not beside this checkout")
def test_appendix_b_excerpt_is_the_thesis_text():
    lines = THESIS.read_text(encoding="utf-8").split("\n")
    excerpt = THESIS_APPENDIX_B.read_text(encoding="utf-8").split("\n")[:-1]
    assert excerpt == lines[FIRST_LINE - 1 : FIRST_LINE - 1 + len(excerpt)]
    assert len(excerpt) == 2034 - FIRST_LINE + 1


def test_limit_cycle_tables():
    t1, t2 = datasets.load("table_5_1"), datasets.load("table_5_2")
    assert len(t1) == 14 and (t1["source_impedance_ohm"] == 600).sum() == 6
    assert len(t2) == 24 and (t2["source_impedance_ohm"] == 600).sum() == 11
    assert t1.loc[t1["dies_out"], "system_gain"].tolist() == [325, 50]
    assert t2.loc[t2["dies_out"], "system_gain"].tolist() == [250, 50]
    assert t1.loc[t1["system_gain"] == 50, ["frequency_hz", "omega_rad_s"]].isna().all(axis=None)
    assert (
        t2.loc[
            t2["dies_out"] & (t2["source_impedance_ohm"] == 600),
            ["amplitude_v", "frequency_hz", "omega_rad_s"],
        ]
        .isna()
        .all(axis=None)
    )
    # omega = 2 pi f at printed precision (f to 0.005 c/s, omega to half its last digit) everywhere
    # except the printed Table 5.2 gain 5000 row (3.7 c/s but 27.2 rad/s), kept as printed.
    raw = pd.concat(
        [
            pd.read_csv(datasets.data_dir().joinpath(f"table_5_{i}.csv"), dtype=str).assign(
                t=f"5.{i}"
            )
            for i in (1, 2)
        ]
    ).dropna(subset=["omega_rad_s"])
    half = lambda cells: 0.5 * 10.0 ** -cells.str.partition(".")[2].str.len()  # noqa: E731
    f, w = raw["frequency_hz"].astype(float), raw["omega_rad_s"].astype(float)
    bad = raw[
        np.abs(2 * np.pi * f - w) > half(raw["omega_rad_s"]) + 2 * np.pi * half(raw["frequency_hz"])
    ]
    assert bad[["t", "system_gain", "omega_rad_s"]].values.tolist() == [["5.2", "5000", "27.2"]]


def test_table_3_1_and_the_095_column():
    t = datasets.load("table_3_1")
    assert t["material"].tolist() == ["4-79 Mo Permalloy", "Iron", "Mild Steel", "Honda Steel"]
    assert t[["a1", "hc_inf", "hm_for_095"]].values.tolist() == [
        [0.3, 0.037, 0.2],
        [0.25, 0.73, 3.7],
        [0.26, 4.1, 23],
        [0.4, 220, 1750],
    ]
    # eq 3.12 gives H_c = 0.95 H_c_inf at H_m = 19 a1 H_c_inf; only the Permalloy cell agrees
    # within two significant digits (Iron 3.47, Mild Steel 20.3, Honda 1672 are printed 3.7, 23, 1750).
    ratio = t["hm_for_095"] / (19 * t["a1"] * t["hc_inf"])
    assert (np.abs(ratio - 1) < 0.06).tolist() == [True, False, False, True]
    assert ratio.iloc[3] == pytest.approx(1.047, abs=1e-3)


def test_eq_4_11_pieces():
    e = datasets.load("eq_4_11")
    hc = lambda p, h: p["constant"] + p["linear"] * h + p["cubic"] * h**3  # noqa: E731
    p1, p2, p3 = (e.iloc[i] for i in range(3))
    assert (p1["hm_min"], p1["hm_max"], p2["hm_max"], p3["hm_min"]) == (
        0,
        0.5,
        5,
        5,
    ) and math.isnan(p3["hm_max"])
    assert hc(p2, 0.5) == pytest.approx(0, abs=1e-3)  # the pieces meet at H_m = 0.5 ...
    assert hc(p3, 5) - hc(p2, 5) == pytest.approx(
        0.0375, abs=1e-12
    )  # ... but jump by 0.0375 at H_m = 5


def test_appendix_a_turns_match_the_footnotes(b):
    a = datasets.load("appendix_a")
    turns = a[a["quantity"].isin(["primary_turns", "secondary_turns"])].pivot(
        index="core", columns="quantity", values="value_min"
    )
    assert turns.loc["deltamax"].tolist() == [2000, 500]
    assert turns.loc["permalloy"].tolist() == turns.loc["supermalloy"].tolist() == [1250, 417]
    for table, core in (("B.1", "permalloy"), ("B.2", "deltamax")):
        ratio = turns.loc[core, "primary_turns"] / turns.loc[core, "secondary_turns"]
        assert b.loc[b["table"] == table, "df_factor_printed"].iloc[0] == pytest.approx(
            ratio, rel=1e-12
        )
    hc = a[a["quantity"] == "coercive_force_Hc"]
    assert hc.groupby("core").size().to_dict() == {"deltamax": 3, "permalloy": 3, "supermalloy": 3}
    assert hc.loc[hc["core"] == "supermalloy", "value_printed"].tolist() == [
        "0.003 - 0.009",
        "0.02 - 0.06",
        "0.03 - 0.10",
    ]
    assert a["source"].str.fullmatch(r"thesis\.txt line \d+").all()
    assert (a["note"].str.len() > 0).sum() >= 40  # the garbled rows say so


# ------------------------------------------------------------------ library API
def test_names_and_core_selection():
    assert datasets.names() == [
        "B.1",
        "B.2",
        "B.3",
        "B.4",
        "B.5",
        "table_5_1",
        "table_5_2",
        "table_3_1",
        "appendix_a",
        "eq_4_11",
        "permalloy",
        "deltamax",
        "supermalloy",
    ]
    assert (
        set(datasets.load("permalloy")["table"]) == {"B.1", "B.3"}
        and len(datasets.load("permalloy")) == 74
    )
    assert (
        set(datasets.load("deltamax")["table"]) == {"B.2", "B.5"}
        and len(datasets.load("deltamax")) == 127
    )
    assert len(datasets.load("supermalloy")) == 63


def test_load_returns_a_copy():
    a = datasets.load("B.1")
    a.loc[0, "df_reported"] = -1.0
    assert datasets.load("B.1").loc[0, "df_reported"] == 0.922


def test_summary_counts():
    s = datasets.summary()
    assert {
        (t, int(f)): n for t, f, n in s[["table", "frequency_hz", "rows"]].values
    } == EXPECTED_ROWS
    assert s["saturation_rows"].sum() == 20 and s["missing_phase"].sum() == 2


def test_bundled_data_resolve_installed_or_checkout(monkeypatch):
    folder = datasets.data_dir()
    assert folder.joinpath("appendix_b.csv").is_file()
    try:  # installed (wheel or editable): the package fitdf._bundled; else the checkout's datasets/
        expected = Path(str(resources.files("fitdf._bundled")))
    except ModuleNotFoundError:
        expected = REPO / "datasets"
    assert Path(str(folder)) == expected

    def not_installed(name):
        raise ModuleNotFoundError(name)

    monkeypatch.setattr(datasets.resources, "files", not_installed)
    assert datasets.data_dir() == REPO / "datasets"
    for name in ("table_5_1", "table_5_2", "table_3_1", "appendix_a", "eq_4_11"):
        assert folder.joinpath(f"{name}.csv").is_file()
    # the wheel ships datasets/ as fitdf._bundled with its CSV and Markdown files
    cfg = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert (
        cfg["package-dir"]["fitdf._bundled"] == "datasets" and "fitdf._bundled" in cfg["packages"]
    )
    assert {"*.csv", "*.md"} <= set(cfg["package-data"]["fitdf._bundled"])
    assert (REPO / "datasets" / "__init__.py").is_file() and (
        REPO / "datasets" / "README.md"
    ).is_file()


# ------------------------------------------------------------------ user CSV files
HEADER = "input_v,df_reported,phase_lead_deg,frequency_hz\n"


def write(tmp_path, text, name="mine.csv"):
    p = tmp_path / name
    p.write_bytes(text if isinstance(text, bytes) else text.encode("utf-8"))
    return p


def test_minimal_user_file(tmp_path):
    p = write(
        tmp_path,
        "\ufeff Input_V ,df_reported,phase_lead_deg,frequency_hz,comment\n0.5,0.8,10,3,a\n"
        "1,0.9,5,3,b\n\n0.5,0.7,20,6,c\n",
    )
    d = datasets.load(p)
    assert d["core"].tolist() == ["mine"] * 3 and d["table"].tolist() == ["mine"] * 3
    assert d["source_impedance_ohm"].tolist() == [0, 0, 0] and not d["saturation"].any()
    assert d["row_in_block"].tolist() == [1, 2, 1] and d["comment"].tolist() == ["a", "b", "c"]
    assert d["source"].tolist() == ["mine.csv line 2", "mine.csv line 3", "mine.csv line 5"]
    assert d["h1_output_v"].isna().all() and d["input_v"].dtype == float
    assert list(d.columns[: len(datasets.APPENDIX_B_COLUMNS)]) == list(datasets.APPENDIX_B_COLUMNS)


def test_bundled_rows_roundtrip_as_user_file(tmp_path):
    b4 = datasets.load("B.4")
    p = tmp_path / "b4.csv"
    b4[list(datasets.APPENDIX_B_COLUMNS)].to_csv(p, index=False)
    back = datasets.load(p)
    pd.testing.assert_frame_equal(
        back[list(datasets.APPENDIX_B_COLUMNS[:-1])], b4[list(datasets.APPENDIX_B_COLUMNS[:-1])]
    )


@pytest.mark.parametrize(
    "text,pattern",
    [
        ("", r"mine\.csv: the file is empty"),
        ("  \n\n", r"mine\.csv: the file is empty"),
        (HEADER, r"mine\.csv: no data rows"),
        (b"\x89PNG\r\n\x1a\n\x00\x00", r"mine\.csv: binary content \(NUL byte"),
        (b"input_v,df\xff\xfe\n", r"mine\.csv: not UTF-8 text"),
        (
            "input_v;df_reported;phase_lead_deg;frequency_hz\n1;0.5;3;3\n",
            r"mine\.csv: line 1: .*semicolon-separated",
        ),
        (
            HEADER + "1,0.5,3,3\n2,0.5,3,3,9\n",
            r"mine\.csv: row 2 \(line 3\): 5 fields but the header has 4",
        ),
        (HEADER + '1,0.5,"3,3\n', r"mine\.csv: not valid CSV"),
        (
            "input_v,phase_lead_deg,frequency_hz\n1,3,3\n",
            r"mine\.csv: column 'df_reported': missing required column",
        ),
        (
            "input_v,df_reportd,phase_lead_deg,frequency_hz\n1,0.5,3,3\n",
            r"mine\.csv: column 'df_reportd': unknown column 'df_reportd'; did you mean 'df_reported'\?",
        ),
        (
            "input_v,df_reported,phase_lead_deg,frequency_hz,saturaton\n1,0.5,3,3,true\n",
            r"column 'saturaton': unknown column 'saturaton'; did you mean 'saturation'\?",
        ),
        (
            "input_v,input_v,df_reported,phase_lead_deg,frequency_hz\n1,1,0.5,3,3\n",
            r"'input_v' appears twice",
        ),
        (
            HEADER + "1,0.5,3,3\n2,0.6,3,3\nabc,0.7,3,3\n",
            r"mine\.csv: row 3 \(line 4\), column 'input_v': 'abc' is not a number",
        ),
        (
            HEADER + "1,0.5,3,3\n1_0,0.5,3,3\n",
            r"row 2 \(line 3\), column 'input_v': '1_0' is not a number",
        ),
        (
            HEADER + "1,0.5,3,inf\n",
            r"row 1 \(line 2\), column 'frequency_hz': 'inf' is not a number",
        ),
        (
            HEADER + "1,0.5,3,1e999\n",
            r"row 1 \(line 2\), column 'frequency_hz': '1e999' is not a finite number",
        ),
        (HEADER + "0,0.5,3,3\n", r"row 1 \(line 2\), column 'input_v': amplitude must be positive"),
        (
            HEADER + "1,0.5,3,3\n-1,0.5,3,3\n",
            r"row 2 \(line 3\), column 'input_v': amplitude must be positive",
        ),
        (HEADER + "1,0.5,3,0\n", r"column 'frequency_hz': frequency must be positive"),
        (
            HEADER + "1,0.5,180.5,3\n",
            r"row 1 \(line 2\), column 'phase_lead_deg': phase must lie in \(-180, 180\]",
        ),
        (HEADER + "1,0.5,-180,3\n", r"column 'phase_lead_deg': phase must lie in \(-180, 180\]"),
        (
            HEADER + "1,-0.5,3,3\n",
            r"row 1 \(line 2\), column 'df_reported': describing-function magnitude must not be negative",
        ),
        (
            HEADER + "1,0.5,3,3\n2,,3,3\n",
            r"row 2 \(line 3\), column 'df_reported': value required but the cell is empty",
        ),
        (HEADER + "1,0.5,--,3\n", r"row 1 \(line 2\), column 'phase_lead_deg': value required"),
        (
            "input_v,df_reported,phase_lead_deg,frequency_hz,h1_output_v\n1,0.5,3,3,-2\n",
            r"column 'h1_output_v': output amplitude must not be negative",
        ),
        (
            "input_v,df_reported,phase_lead_deg,frequency_hz,source_impedance_ohm\n1,0.5,3,3,\n",
            r"column 'source_impedance_ohm': value required",
        ),
        (
            "input_v,df_reported,phase_lead_deg,frequency_hz,saturation\n1,0.5,3,3,maybe\n",
            r"row 1 \(line 2\), column 'saturation': 'maybe' is not true/false",
        ),
        (
            HEADER + "1,0.5,3,3\n2,0.6,3,3\n1,0.5,3,3\n",
            r"row 3 \(line 4\), column 'input_v': duplicates row 1 \(line 2\)",
        ),
    ],
)
def test_bad_user_files(tmp_path, text, pattern):
    with pytest.raises(DataError, match=pattern) as info:
        datasets.load(write(tmp_path, text))
    assert "\n" not in str(info.value)


def test_phase_180_and_duplicates_across_tables_are_fine(tmp_path):
    text = "table,input_v,df_reported,phase_lead_deg,frequency_hz\nA,1,0.5,180,3\nB,1,0.5,180,3\n"
    assert len(datasets.load(write(tmp_path, text))) == 2


def test_missing_file_directory_and_unknown_name(tmp_path):
    with pytest.raises(DataError, match=r"nope\.csv: file not found"):
        datasets.load(tmp_path / "nope.csv")
    with pytest.raises(DataError, match=r"is a directory"):
        datasets.load(tmp_path)
    with pytest.raises(
        DataError, match=r"unknown dataset 'B\.9'.*B\.1, B\.2, B\.3, B\.4, B\.5.*permalloy"
    ):
        datasets.load("B.9")
    with pytest.raises(DataError, match="expected a dataset name or a CSV path"):
        datasets.load(3)


def test_message_names_the_file_and_row_in_one_line(tmp_path):
    p = write(tmp_path, HEADER + '1,0.5,3,3\n"x\ny",0.5,3,3\n', name="weird name.csv")
    with pytest.raises(DataError) as info:
        datasets.load(p)
    msg = str(info.value)
    assert msg.startswith(str(p) + ": row 2 (line 4), column 'input_v': ") and "\n" not in msg
