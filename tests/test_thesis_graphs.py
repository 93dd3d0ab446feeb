"""Graphs 4.1-4.7 of the thesis: figures are built, carry data, and are written."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.figure import Figure

from fitdf.plots import thesis_graphs
from fitdf.plots.thesis_graphs import KS_SATURATION_C, THESIS_GRAPHS, save_thesis_graphs

EXPECTED_AXES = {"4.1": 2, "4.2": 2, "4.3": 1, "4.4": 2, "4.5": 3, "4.6": 1, "4.7": 2}


@pytest.mark.parametrize("number", sorted(EXPECTED_AXES))
def test_graph_has_axes_and_data(number):
    fig = THESIS_GRAPHS[number]()
    assert isinstance(fig, Figure)
    assert len(fig.axes) == EXPECTED_AXES[number]
    assert f"Graph {number}" in (fig.get_suptitle() + "".join(ax.get_title() for ax in fig.axes))
    for ax in fig.axes:
        lines = [ln for ln in ax.get_lines() if np.size(ln.get_xdata()) > 1]
        assert lines, f"Graph {number}: an axis without data"
        assert any(np.isfinite(np.asarray(ln.get_ydata(), float)).sum() > 10 for ln in lines)
        assert ax.get_ylabel()
    assert all(ax.get_xlabel() for ax in fig.axes if ax.get_subplotspec().is_last_row())


def test_graph_4_1_endpoints():
    (top, _) = thesis_graphs.graph_4_1().axes
    magnitude = top.get_lines()[0]
    # m = 0: 1 at 0 degrees; m = 1: the loop has no height, N = 0
    assert magnitude.get_ydata()[0] == pytest.approx(1.0, abs=1e-12)
    assert magnitude.get_ydata()[-1] == pytest.approx(0.0, abs=1e-12)


def test_graph_4_3_loci_start_at_minus_one_over_n_below_saturation():
    (ax,) = thesis_graphs.graph_4_3().axes
    marks = [ln for ln in ax.get_lines() if np.size(ln.get_xdata()) == 1]
    first = marks[0]  # m = 0: -1/N = -1/k
    assert first.get_xdata()[0] == pytest.approx(-1.0, abs=1e-12)
    assert first.get_ydata()[0] == pytest.approx(0.0, abs=1e-12)
    assert len(ax.texts) >= 2 * len(thesis_graphs.M_CURVES) - 1  # direction arrows


def test_graph_4_7_saturation_starts_at_a_5():
    assert KS_SATURATION_C == pytest.approx(5.0 - 1.7625, abs=1e-12)


def test_save_thesis_graphs(tmp_path):
    paths = save_thesis_graphs(tmp_path / "graphs")
    assert [p.name for p in paths] == [f"graph_4_{i}.png" for i in range(1, 8)]
    for p in paths:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert p.stat().st_size > 10_000
