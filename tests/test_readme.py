"""The README's examples work as written: its CSV is a valid dataset, its geometry parses, its
Python runs (slow: it fits), and its commands are the ones the command line has."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

import fitdf
from fitdf.cli import build_parser
from fitdf.data.cores import parse_geometry

README = Path(__file__).resolve().parents[1] / "README.md"


def blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def test_the_csv_example_is_a_valid_dataset_and_its_geometry_parses(tmp_path):
    (csv,) = blocks("csv")
    path = tmp_path / "my_core.csv"
    path.write_text(csv, encoding="utf-8")
    rows = fitdf.datasets.load(str(path))
    assert len(rows) == 5 and set(rows["source_impedance_ohm"]) == {600.0}
    command = next(line for line in blocks("bash")[1].splitlines() if "my_core.csv" in line)
    args = build_parser().parse_args(shlex.split(command)[1:])
    g = parse_geometry(args.geometry)
    assert g.turns == 1250 and g.l_e == pytest.approx(3.14159265 * 2.25 * 0.0254, rel=1e-8)


def test_every_command_of_the_command_table_parses():
    text = README.read_text(encoding="utf-8")
    commands = re.findall(r"^\| `(fitdf [^`]*)` \|", text, flags=re.M)
    assert len(commands) >= 6
    for command in commands:
        words = [w for w in shlex.split(command.replace("[LAW]", "preisach"))[1:]]
        words = ["B.1" if w == "DATA..." or w == "DATA" else w for w in words]
        build_parser().parse_args(words)  # an unknown option or command exits with 2


@pytest.mark.slow
def test_the_python_example_runs():
    (code,) = blocks("python")
    namespace: dict = {}
    exec(compile(code, str(README), "exec"), namespace)
    assert namespace["result"].metrics["rms_complex"] < 0.06
    assert namespace["df"].shape == (3,)
    assert list(namespace["ranking"]["model"])[0] == "preisach"
