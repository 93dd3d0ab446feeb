"""Fit figures (fitdf.plots.fits): each returns a Figure with the expected, labelled, non-empty axes."""

from __future__ import annotations

import io

import numpy as np
import pytest
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure

import fitdf
from fitdf.inference.api import resolve_data
from fitdf.inference.mcmc import fit_mcmc
from fitdf.plots import (
    plot_corner,
    plot_critical_loci,
    plot_cross_impedance,
    plot_fit,
    plot_residuals,
)
from fitdf.plots._panels import law_label

#: The figures draw a fit whatever chain it went through: the cheap one (the fixtures took
#: ~15 s through the exact voltage chain on 2 cores).
CHAIN = "winding"


@pytest.fixture(scope="module")
def b1():
    """Two quick least-squares fits of Table B.1 (0 ohm; 3, 6, 10, 20 c/s), best first."""
    fits = [
        fitdf.fit("B.1", m, chain=CHAIN, seed=0, n_starts=2)
        for m in ("proportional_width", "constant_width")
    ]
    return sorted(fits, key=lambda r: r.metrics["rms_complex"])


@pytest.fixture(scope="module")
def joint():
    """A joint Permalloy fit (B.1 at 0 ohm + B.3 at 600 ohm; 20 c/s only at 0 ohm)."""
    return fitdf.fit("permalloy", "proportional_width", chain=CHAIN, seed=0, n_starts=2)


@pytest.fixture(scope="module")
def posterior(b1):
    # a short pilot: the figures read the draws, not how well they mix
    return fit_mcmc(b1[0].problem, b1[0], seed=0, n_steps=60, n_walkers=16, max_pilot_rounds=1)


def _data_lines(ax):
    return [ln for ln in ax.get_lines() if np.isfinite(np.asarray(ln.get_ydata(), float)).sum() > 0]


def _png(fig):
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


def test_plot_fit_panels_labels_and_curves(b1):
    fig = plot_fit(b1)
    assert isinstance(fig, Figure)
    assert len(fig.axes) == 2 * 4  # magnitude + phase rows, four frequencies
    mag_row, phase_row = fig.axes[:4], fig.axes[4:]
    assert (
        mag_row[0].get_ylabel() == "|DF| (V/V)" and phase_row[0].get_ylabel() == "phase lead (deg)"
    )
    assert all(ax.get_xlabel() == "input amplitude (V)" for ax in phase_row)
    assert [ax.get_title() for ax in mag_row] == [
        "f = 3 c/s",
        "f = 6 c/s",
        "f = 10 c/s",
        "f = 20 c/s",
    ]
    for ax in fig.axes:
        lines = _data_lines(ax)
        assert len(lines) == 3  # two model curves + measured points
        assert max(len(ln.get_xdata()) for ln in lines) > 50  # smooth curves, not just the rows
    assert "Permalloy" in fig.get_suptitle() and "B.1" in fig.get_suptitle()
    # every law named by its title beside its code name (the lines wrapped to the figure)
    labels = [" ".join(t.get_text().split()) for t in fig.legends[0].get_texts()]
    for law in ("proportional_width", "constant_width"):
        assert law_label(law) in labels
    assert law_label("constant_width") == (
        "Piecewise-linear loop of constant width (backlash with saturation) [constant_width]"
    )
    assert _png(fig)[:4] == b"\x89PNG"


def test_plot_fit_band_and_frequency_subset(b1, posterior):
    fig = plot_fit(b1, frequencies=[3.0, 10.0], band=posterior)
    assert len(fig.axes) == 4
    assert all(any(isinstance(c, PolyCollection) for c in ax.collections) for ax in fig.axes)
    assert any("posterior band" in t.get_text() for t in fig.legends[0].get_texts())
    no_band = plot_fit(posterior, band=False)
    assert not any(isinstance(c, PolyCollection) for ax in no_band.axes for c in ax.collections)


def test_plot_fit_joint_fit_has_a_row_pair_per_impedance(joint):
    fig = plot_fit(joint)
    assert len(fig.axes) == 4 * 4  # 2 impedances x (magnitude, phase), 4 frequencies
    blank = [ax for ax in fig.axes if not ax.axison]
    assert len(blank) == 2  # 20 c/s was not measured at 600 ohm
    assert "600 ohm" in fig.axes[8].get_ylabel() and "0 ohm" in fig.axes[0].get_ylabel()
    assert "0 and 600 ohm" in fig.get_suptitle()


def test_plot_fit_draws_excluded_rows(b1):
    import pandas as pd

    excluded = pd.DataFrame(
        {
            "input_v": [0.3],
            "frequency_hz": [3.0],
            "source_impedance_ohm": [0.0],
            "df_reported": [0.5],
            "phase_lead_deg": [30.0],
        }
    )
    fig = plot_fit(b1[0], excluded=excluded)
    assert any(ln.get_marker() == "x" for ln in fig.axes[0].get_lines())
    assert any("excluded" in t.get_text() for t in fig.legends[0].get_texts())


def test_plot_fit_of_one_result_and_frequency(b1):
    assert isinstance(plot_fit(b1[0], frequencies=[6.0]), Figure)


def test_critical_loci_in_the_second_quadrant(joint, b1):
    fig = plot_critical_loci(joint)
    assert len(fig.axes) == 2  # one Nyquist plane per source impedance
    for ax in fig.axes:
        assert ax.get_xlabel() == "Re(-1/DF)" and ax.get_ylabel() == "Im(-1/DF)"
        points = [
            ln for ln in ax.get_lines() if ln.get_marker() == "o" and ln.get_linestyle() == "None"
        ]
        assert points
        x = np.concatenate([ln.get_xdata() for ln in points])
        y = np.concatenate([ln.get_ydata() for ln in points])
        assert np.all(x < 0) and np.mean(y >= 0) > 0.9  # the measured DF leads
        curves = [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 50]
        assert curves
    single = plot_critical_loci(b1, top=2)
    assert len(single.axes) == 1
    styles = {ln.get_linestyle() for ln in single.axes[0].get_lines() if len(ln.get_xdata()) > 50}
    assert styles == {"-", "--"}


def test_critical_loci_into_given_axes(b1, joint):
    fig = Figure()
    ax = fig.add_subplot()
    assert plot_critical_loci(b1, ax=ax) is fig
    with pytest.raises(ValueError, match="single source impedance"):
        plot_critical_loci(joint, ax=ax)


def test_plot_residuals(b1):
    fig = plot_residuals(b1, top=3)
    assert len(fig.axes) == 2 * 2  # two models given
    assert fig.axes[0].get_ylabel().startswith("|DF| residual")
    assert fig.axes[2].get_ylabel().startswith("phase-lead residual")
    for ax in fig.axes:
        assert _data_lines(ax)
    assert "proportional_width" in fig.axes[0].get_title() + fig.axes[1].get_title()
    assert len(plot_residuals(b1, top=1).axes) == 2


def test_plot_corner(posterior, b1):
    fig = plot_corner(posterior, truths=b1[0])
    P = posterior.problem.ndim
    assert len(fig.axes) == P * P
    labels = [ax.get_xlabel() for ax in fig.axes if ax.get_xlabel()]
    assert any(lbl.startswith("log10 ") for lbl in labels)  # log-scaled parameters shown as log10
    assert "converged" in fig.get_suptitle()
    assert _png(fig)[:4] == b"\x89PNG"
    with pytest.raises(TypeError, match="PosteriorResult"):
        plot_corner(b1[0])


def _text_boxes_overlapping(fig):
    """Pairs of the corner plot's texts (histogram titles, axis labels, suptitle, key) and
    panels whose boxes overlap, and the texts that leave the figure."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    P = round(np.sqrt(len(fig.axes)))
    axes = np.asarray(fig.axes).reshape(P, P)
    shown = [axes[i, j] for i in range(P) for j in range(i + 1)]  # the lower triangle
    texts = [fig._suptitle, fig.texts[-1]]
    texts += [axes[i, i]._left_title for i in range(P)]
    texts += [a.xaxis.label for a in axes[-1]] + [a.yaxis.label for a in axes[1:, 0]]
    boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in texts if t.get_text()]
    panels = [(f"panel {a.get_subplotspec().get_geometry()}", a.get_window_extent()) for a in shown]
    clash = [
        (n1, n2)
        for k, (n1, b1) in enumerate(boxes)
        for n2, b2 in boxes[k + 1 :] + panels
        if b1.overlaps(b2)
    ]
    outside = [n for n, b in boxes if not fig.bbox.contains(b.x0, b.y0) or b.x1 > fig.bbox.x1]
    return clash, outside


def test_corner_texts_do_not_overlap(posterior, b1):
    """A 5-parameter posterior (the law's 3, the winding resistance, the gain): the titles
    (parameter, then median and spread), the axis labels, the suptitle and the key below the
    panels overlap nothing, and stay in the figure."""
    fig = plot_corner(posterior, truths=b1[0])
    P = posterior.problem.ndim
    assert 4 <= P <= 6
    assert fig.get_figwidth() == pytest.approx(1.05 + 1.5 * P + 0.2)
    clash, outside = _text_boxes_overlapping(fig)
    assert clash == [] and outside == []
    titles = [fig.axes[i * P + i].get_title(loc="left") for i in range(P)]
    assert titles[0].splitlines()[0] == fig.axes[(P - 1) * P].get_xlabel()
    lo, mid, hi = np.percentile(
        posterior.problem.specs[0].from_internal(posterior.flat_internal(4000, seed=0)[:, 0])
        if not posterior.problem.specs[0].log
        else posterior.flat_internal(4000, seed=0)[:, 0],
        [16, 50, 84],
    )
    assert titles[0].splitlines()[1].split()[0] == f"{mid:.3g}"
    key = fig.texts[-1].get_text()
    assert "16th, 50th and 84th percentiles" in key and "least-squares optimum" in key
    assert law_label(posterior.model) in fig.get_suptitle()


def test_plot_cross_impedance(b1):
    fig = plot_cross_impedance(
        b1, resolve_data("B.3"), calibration_gains={"proportional_width": 1.0}
    )
    assert len(fig.axes) == 4 * 4
    bottom_mag = fig.axes[8]
    assert "600 ohm" in bottom_mag.get_ylabel()
    dashed = [ln for ln in bottom_mag.get_lines() if ln.get_linestyle() == "--"]
    assert len(dashed) == 2  # one prediction per model
    assert "predicting 600 ohm" in fig.get_suptitle()


def test_no_results_is_an_error():
    with pytest.raises(ValueError, match="no results"):
        plot_fit([])
