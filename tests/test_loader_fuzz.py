"""Fuzzing the CSV loader: whatever the bytes, load() returns a frame or raises DataError."""

import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fitdf.data import datasets
from fitdf.errors import DataError

SETTINGS = settings(
    max_examples=120, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow]
)
VALID = (
    "table,input_v,h1_output_v,phase_lead_deg,df_reported,frequency_hz,saturation\n"
    "T,0.1,0.04,66,0.4,3,false\nT,0.2,0.11,40,0.5,3,false\nT,1,0.77,21,0.77,3,true\n"
)


@pytest.fixture(scope="module")
def target(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz") / "fuzz.csv"


def outcome(path, data: bytes):
    """Load ``data`` from ``path``; only a DataFrame or a one-line DataError may come out."""
    path.write_bytes(data)
    try:
        frame = datasets.load(path)
    except DataError as exc:
        assert "\n" not in str(exc) and str(exc).startswith(str(path))
        return None
    assert isinstance(frame, pd.DataFrame) and len(frame) > 0
    assert (frame["input_v"] > 0).all() and (frame["df_reported"] >= 0).all()
    assert frame["phase_lead_deg"].between(-180, 180, inclusive="right").all()
    return frame


@SETTINGS
@given(st.binary(max_size=400))
def test_random_bytes(target, data):
    outcome(target, data)


cells = st.one_of(
    st.sampled_from(
        [
            "",
            "0",
            "1",
            "-1",
            "0.5",
            ".5",
            "1e3",
            "1e999",
            "nan",
            "--",
            "inf",
            "abc",
            '"',
            '""',
            "1,5",
            "true",
            "false",
            "**",
            "180",
            "-180",
            "1_0",
            "\t",
            " 2 ",
            "٣",
            "0x10",
            "1e-400",
        ]
    ),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(max_size=6),
)
columns = st.sampled_from(
    list(datasets.APPENDIX_B_COLUMNS) + ["df_reportd", "Input_V", " frequency_hz ", "x", ""]
)


@st.composite
def csv_text(draw):
    header = draw(st.lists(columns, min_size=1, max_size=9))
    sep = draw(st.sampled_from([",", ",", ",", ";", "\t"]))
    rows = draw(
        st.lists(st.lists(cells, min_size=len(header) - 1, max_size=len(header) + 1), max_size=6)
    )
    newline = draw(st.sampled_from(["\n", "\r\n", "\r"]))
    return newline.join(sep.join(r) for r in [header, *rows]) + draw(st.sampled_from(["", newline]))


@SETTINGS
@given(csv_text())
def test_random_csv_text(target, text):
    outcome(target, text.encode("utf-8"))


@SETTINGS
@given(
    st.lists(
        st.tuples(st.integers(0, len(VALID)), st.integers(0, 3), st.text(max_size=3)), max_size=4
    ),
    st.sampled_from(["utf-8", "utf-16", "latin-1"]),
)
def test_mutated_valid_file(target, edits, encoding):
    text = VALID
    for pos, cut, insert in edits:
        text = text[:pos] + insert + text[pos + cut :]
    outcome(target, text.encode(encoding, errors="replace"))


def test_unmutated_valid_file_loads(target):
    frame = outcome(target, VALID.encode())
    assert frame is not None and frame["saturation"].tolist() == [False, False, True]
