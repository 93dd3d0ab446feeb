"""The README's examples work as written: its CSV is a valid dataset, its geometry parses, its
Python runs (slow: it fits), and its commands are the ones the command line has."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from test_cli import run_here

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
    assert list(namespace["ranking"]["model"])[0] == "preisach"  # by AICc (the default order)


def _fit_readme_example(tmp_path, *extra):
    """``fitdf fit`` on the README's CSV with its geometry (in this process), and its text."""
    (csv,) = blocks("csv")
    path = tmp_path / "my_core.csv"
    path.write_text(csv, encoding="utf-8")
    command = next(line for line in blocks("bash")[1].splitlines() if "my_core.csv" in line)
    args = shlex.split(command)[1:]
    args[args.index("my_core.csv")] = str(path)
    p = run_here(*args, "--quiet", "--no-cache", "--workers", "1", *extra)
    assert p.returncode == 0, p.stderr
    return " ".join(p.stdout.split())  # (the lines are wrapped)


def test_the_csv_example_ranks_only_the_laws_its_rows_can_carry(tmp_path):
    """Five rows, ten numbers: a law of 9 parameters is not fitted (AICc needs 11), and the
    best law is one of 5 (through the fast winding chain and three laws)."""
    text = _fit_readme_example(
        tmp_path, "--chain", "winding", "--models", "rayleigh", "constant_width", "cubic_hc"
    )
    assert (
        "Not fitted or ranked, 5 rows being too few (AICc needs two numbers a row, at least the "
        "parameters plus two): cubic_hc (9 parameters)." in text
    )
    best = re.search(r"Best law: (\w+) \(winding chain\)", text).group(1)
    assert best in ("rayleigh", "constant_width")
    # its material constants carry the caveat, naming the parameters the warnings say the
    # five rows leave open (and not the calibration gain, which no constant uses)
    named = re.search(r"caveat: the data do not determine ([\w, ]+) \(on a bound", text).group(1)
    named = named.split(", ")
    assert named and "gain" not in named
    for name in named:
        assert f"do not determine {name}:" in text or f"parameter {name} sits on its" in text


@pytest.mark.slow  # about 40 s: every law through the voltage chain
def test_the_readme_says_what_its_example_prints(tmp_path):
    text = _fit_readme_example(tmp_path)
    readme = " ".join(README.read_text(encoding="utf-8").split())
    assert (
        "the best are two laws of 5 parameters, Rayleigh and constant width, tied; Preisach (8 "
        "parameters) fits closest and ranks last, and the cubic law (9) is not ranked" in readme
    )
    assert (
        "Best law: rayleigh (voltage chain), the lowest AICc (59.85); within AICc 2 of it (a "
        "tie): constant_width/voltage." in text
    )
    ranking = text.split("ordered by aicc: ")[1].split(" n_params:")[0]
    ranked = re.findall(r"\b\d+ (\w+) (\d+) ", ranking)
    assert ranked[-1] == ("preisach", "8") and len(ranked) == 7
    assert (
        "too few (AICc needs two numbers a row, at least the parameters plus two): cubic_hc (9"
        in text
    )
