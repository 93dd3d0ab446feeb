"""The report's summary figure (fitdf.plots.summary) from a fabricated results record:
the cells hold the record's residuals, the best law of each block is framed, missing fits
are hatched, and the constants panel shows every Appendix A check."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.colors import LogNorm, Normalize
from matplotlib.figure import Figure

from fitdf.plots.summary import CAPTION, NOTE, constant_rows, plot_summary, residual_grid

_BEST_FRAME = "#d62728"


def _check(quantity, fitted, low, high, unit):
    inside = bool(np.isfinite(fitted) and low <= fitted and (high is None or fitted <= high))
    return {
        "quantity": quantity,
        "fitted": fitted,
        "low": low,
        "high": high,
        "unit": unit,
        "inside": inside,
    }


def _block(key, title, core, ohms, tables, rms: dict, checks=None, aicc=None) -> dict:
    """A block record as fitdf.report.sections.block_record writes it (only what the figure
    reads); ``aicc`` of each law, by default in the order of ``rms``; ``checks`` on the best
    law (the lowest AICc)."""
    order = sorted(rms, key=rms.get)
    aicc = aicc or {m: 1000 * v for m, v in rms.items()}
    fits = {m: {"model": m} for m in order}
    if checks is not None:
        fits[min(aicc, key=aicc.get)]["appendix_a_check"] = checks
    return {
        "key": key,
        "title": title,
        "core": core,
        "tables": tables,
        "source_impedance_ohm": ohms,
        "ranking_lsq": [
            {"rank": i + 1, "model": m, "rms_complex": rms[m], "aicc": aicc[m]}
            for i, m in enumerate(order)
        ],
        "order_lsq": order,
        "fits_lsq": fits,
    }


@pytest.fixture
def record() -> dict:
    """Three laws on three blocks; ``rayleigh`` has no fit on B.3; residuals span two decades."""
    perm = [
        _check("initial_permeability", 2.0e3, 1.0e4, 4.0e4, "gauss/oersted"),
        _check("coercive_force_Hc", 0.17, 0.02, 0.25, "oersted"),
        _check("squareness_Br_over_Bp", 0.93, 0.92, None, ""),
    ]
    joint = [
        _check("initial_permeability", 0.0, 1.0e4, 4.0e4, "gauss/oersted"),
        _check("coercive_force_Hc", 0.01, 0.02, 0.25, "oersted"),
        _check("squareness_Br_over_Bp", float("nan"), 0.92, None, ""),
    ]
    return {
        "settings": {"models": ["constant_width", "rayleigh", "cubic_hc"]},
        "blocks": {
            "B.1": _block(
                "B.1",
                "Permalloy at 0 ohm (Table B.1)",
                "permalloy",
                [0.0],
                ["B.1"],
                {"constant_width": 0.061, "rayleigh": 0.0049, "cubic_hc": 0.06},
                perm,
            ),
            "B.3": _block(
                "B.3",
                "Permalloy at 600 ohm (Table B.3)",
                "permalloy",
                [600.0],
                ["B.3"],
                {"constant_width": 0.122, "cubic_hc": 0.169},
            ),
            "permalloy-joint": _block(
                "permalloy-joint",
                "Permalloy jointly",
                "permalloy",
                [0.0, 600.0],
                ["B.1", "B.3"],
                {"constant_width": 0.102, "rayleigh": 0.49, "cubic_hc": 0.0893},
                joint,
                # the lowest residual, cubic_hc, is not the best: AICc charges its parameters
                aicc={"constant_width": 40.0, "rayleigh": 300.0, "cubic_hc": 41.0},
            ),
        },
    }


def test_grid_holds_the_records_residuals_and_best(record):
    grid = residual_grid(record)
    assert grid.blocks == ["B.1", "B.3", "permalloy-joint"]
    assert sorted(grid.laws) == ["constant_width", "cubic_hc", "rayleigh"]
    for j, key in enumerate(grid.blocks):
        rows = record["blocks"][key]["ranking_lsq"]
        for row in rows:
            assert grid.rms[grid.laws.index(row["model"]), j] == row["rms_complex"]
        assert grid.laws[grid.best[j]] == min(rows, key=lambda r: r["aicc"])["model"]
        missing = set(grid.laws) - {row["model"] for row in rows}
        for law in missing:
            assert np.isnan(grid.rms[grid.laws.index(law), j])
    assert "rayleigh" in grid.laws and np.isnan(grid.rms[grid.laws.index("rayleigh"), 1])
    assert grid.laws[grid.best[2]] == "constant_width"  # the lowest AICc, not the lowest RMS


def test_figure_draws_the_grid_it_reports(record):
    grid = residual_grid(record)
    fig = plot_summary(record)
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    image = ax.images[0]
    drawn = np.ma.masked_invalid(image.get_array())
    np.testing.assert_array_equal(drawn.mask, np.isnan(grid.rms))
    np.testing.assert_allclose(drawn.filled(np.nan), grid.rms, equal_nan=True)
    assert isinstance(image.norm, LogNorm)  # 0.0049 .. 0.49: two decades
    # every value is written in its cell; the best of each block in bold
    texts = {(round(t.get_position()[0]), round(t.get_position()[1])): t for t in ax.texts}
    for (i, j), v in np.ndenumerate(grid.rms):
        if np.isfinite(v):
            assert texts[(j, i)].get_text() == f"{v:.3g}"
            assert (texts[(j, i)].get_fontweight() == "bold") == (grid.best[j] == i)
    # one red frame per block, around its best law; missing cells hatched
    frames = [p for p in ax.patches if not p.get_fill() and p.get_linewidth() > 2]
    centres = sorted((round(p.get_x() + 0.46), round(p.get_y() + 0.46)) for p in frames)
    assert centres == sorted((j, i) for j, i in enumerate(grid.best))
    assert all(np.allclose(p.get_edgecolor()[:3], _hex_rgb(_BEST_FRAME)) for p in frames)
    hatched = [p for p in ax.patches if p.get_hatch()]
    assert [(round(p.get_x() + 0.5), round(p.get_y() + 0.5)) for p in hatched] == [
        (1, grid.laws.index("rayleigh"))
    ]
    assert ax.get_xticklabels()[2].get_text() == "B.1+B.3\nPermalloy\n0+600 ohm"


def _hex_rgb(colour):
    return [int(colour[i : i + 2], 16) / 255 for i in (1, 3, 5)]


def test_constants_panel_one_row_per_core_and_quantity(record):
    rows = constant_rows(record)
    assert [(r["core"], r["quantity"]) for r in rows] == [
        ("permalloy", "initial_permeability"),
        ("permalloy", "coercive_force_Hc"),
        ("permalloy", "squareness_Br_over_Bp"),
    ]
    assert [f["block"] for f in rows[0]["fits"]] == ["B.1", "permalloy-joint"]
    assert [f["kind"] for f in rows[0]["fits"]] == ["0 ohm table", "joint fit"]
    assert rows[1]["fits"][0]["inside"] and not rows[1]["fits"][1]["inside"]
    fig = plot_summary(record)
    panels = fig.axes[2:]  # grid, colour bar, then one panel per quantity
    assert len(panels) == 3
    assert [a.get_xscale() for a in panels] == ["log", "log", "linear"]
    # (*): the constants a single source impedance leaves to the winding resistance (the note)
    assert panels[0].get_title(loc="left") == "initial permeability (gauss/oersted) (*, **)"
    assert panels[2].get_title(loc="left") == "squareness $B_r/B_p$"
    # the zero initial permeability (joint fit) is drawn at the left edge, its value written
    assert any(t.get_text() == "0" for t in panels[0].texts)
    # filled markers inside the range, open ones outside
    markers = [ln for ln in panels[1].get_lines() if ln.get_marker() in ("o", "s", "D")]
    faces = [ln.get_markerfacecolor() for ln in markers]
    assert faces.count("white") == 1 and len(faces) == 2
    assert any(t.get_text() == "n/a" for t in panels[2].texts)  # NaN squareness


def test_without_appendix_a_checks_only_the_grid(record, tmp_path):
    for rec in record["blocks"].values():
        for fit in rec["fits_lsq"].values():
            fit.pop("appendix_a_check", None)
        for row in rec["ranking_lsq"]:
            row["rms_complex"] = 0.1 + 0.01 * row["rank"]
    fig = plot_summary(record)
    assert len(fig.axes) == 2  # the grid and its colour bar
    assert type(fig.axes[0].images[0].norm) is Normalize  # less than a decade: linear
    fig.savefig(tmp_path / "summary.png")
    assert (tmp_path / "summary.png").stat().st_size > 10_000


def test_empty_record_is_refused():
    with pytest.raises(ValueError, match="no ranked block"):
        plot_summary({"blocks": {}})


def test_caption_is_one_sentence_about_the_colours():
    assert CAPTION.count(". ") == 0 and CAPTION.endswith(".")
    assert "colour" in CAPTION and "Appendix A" in CAPTION
    assert (
        "outside it (the fitted constant, at the nominal stacking factor 0.85, lies outside"
        in CAPTION
    )


def test_the_figure_says_what_outside_means_and_what_the_data_leave_open(record):
    """The note under the constants panels defines "outside" and names what one source
    impedance leaves open; a constant the fit does not determine is grey, not red."""
    perm = record["blocks"]["B.1"]["fits_lsq"]["rayleigh"]
    perm["material"] = {"initial_converged": False, "maximum_at_edge": False}
    rows = constant_rows(record)
    mu_i = next(r for r in rows if r["quantity"] == "initial_permeability")
    assert [f["determined"] for f in mu_i["fits"]] == [False, True]  # B.1's, the joint fit's
    fig = plot_summary(record)
    legend = fig.subfigs[1].legends[0]
    note = " ".join(legend.get_title().get_text().split())
    assert note == " ".join(NOTE.split())
    assert note.startswith(
        "Outside: the fitted constant, at the nominal stacking factor 0.85, lies outside the "
        "Appendix A catalogue range of the core's material"
    )
    assert "trade against the series resistance" in note and "iron fraction" in note
    labels = [t.get_text() for t in legend.get_texts()]
    assert {"inside the range", "outside it", "not determined", "Appendix A range"} <= set(labels)
    assert "stacking factor 0.50-0.90" in labels
    # B.1's undetermined initial permeability (2000, below the range): an open grey marker
    panel = fig.axes[2]
    marks = [ln for ln in panel.get_lines() if ln.get_marker() in ("o", "s", "D")]
    b1 = next(ln for ln in marks if ln.get_xdata()[0] == 2.0e3)
    assert b1.get_markerfacecolor() == "white" and b1.get_markeredgecolor() == "0.45"


def test_laws_are_named_beside_their_code_names(record):
    record["models"] = [
        {"name": "rayleigh", "title": "Rayleigh parabolic loop with Frohlich-Kennelly saturation"}
    ]
    fig = plot_summary(record)
    ticks = [t.get_text() for t in fig.axes[0].get_yticklabels()]
    grid = residual_grid(record)
    i = grid.laws.index("rayleigh")
    assert ticks[i] == "Rayleigh parabolic loop\nwith Frohlich-Kennelly\nsaturation\n[rayleigh]"
    assert ticks[grid.laws.index("cubic_hc")] == "cubic_hc"  # a law the record does not describe


def test_an_induction_is_drawn_over_the_stacking_factors_range(record):
    """A constant that carries the iron fraction is a marker at the nominal stacking factor with a
    whisker over its range (``fitted_low``..``fitted_high`` of the check); the squareness has none."""
    fit = record["blocks"]["B.1"]["fits_lsq"]["rayleigh"]
    for c in fit["appendix_a_check"]:
        iron = c["quantity"] in ("peak_flux_density_Bp", "initial_permeability")
        c["fitted_low"], c["fitted_high"] = (
            (c["fitted"] * 0.85 / 0.9, c["fitted"] * 0.85 / 0.5) if iron else (c["fitted"],) * 2
        )
    fig = plot_summary(record)
    whiskers = [
        ln for ax in fig.axes for ln in ax.get_lines() if ln.get_marker() in ("None", "", None)
    ]
    spans = sorted(
        tuple(np.round(ln.get_xdata(), 6)) for ln in whiskers if len(ln.get_xdata()) == 2
    )
    mu = next(c for c in fit["appendix_a_check"] if c["quantity"] == "initial_permeability")
    assert tuple(np.round([mu["fitted_low"], mu["fitted_high"]], 6)) in spans
    assert len(spans) == 1  # neither the coercive force nor the squareness has one
