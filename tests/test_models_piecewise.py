"""Piecewise-linear laws: closed forms against the numerical referee and the thesis.

The referee (:func:`fitdf.numerical_df.numerical_describing_function`, 2**17 points per
period) integrates the loop drawn by ``ascending_branch``; its error on these
piecewise-linear loops is ~2e-10 of the slope, so 1e-9 * k is a meaningful bound.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fitdf.models.constant_width import ConstantWidth
from fitdf.models.cubic_hc import (
    KS_MAGNET_STEEL,
    KS_MAGNET_STEEL_SHAPE,
    CubicHc,
    cubic_from_kennelly,
    cubic_law,
    cubic_shape,
    cubic_width,
    ks_magnet_steel_hc,
)
from fitdf.models.proportional_width import (
    ProportionalWidth,
    ProportionalWidthFig42,
    saturation_amplitude,
)

TOL = 1e-9  # absolute, in units of k


def cubic(k, c, **law):
    """CubicHc's keyword arguments for eq 4.8's constants ``alpha, beta, h0, h1, tail_slope``."""
    return dict(k=k, c=c, **{n: float(v) for n, v in cubic_shape(**law).items()})


FAST = settings(max_examples=8, deadline=None)
PROPORTIONAL = (ProportionalWidth, ProportionalWidthFig42)


def assert_matches_referee(model, A, **theta):
    closed = model.describing_function(A, **theta)
    numeric = model.numerical_describing_function(A, **theta)
    k = np.asarray(theta["k"], float)
    err = np.abs(closed - numeric) / k
    assert np.all(np.isfinite(closed))
    assert err.max() <= TOL, f"max error {err.max():.3g} at A={np.ravel(A)[np.argmax(err)]}"


def around(x, rel=(1e-9, 1e-6, 1e-3, 0.05)):
    """Points straddling a regime boundary ``x``."""
    rel = np.asarray(rel)
    return np.concatenate([x * (1 - rel), [x], x * (1 + rel)])


def saturation_df(A, k, c):
    """Textbook DF of a saturation of slope k and level c (written independently)."""
    a = c / k
    s = np.minimum(a / A, 1.0)
    return np.where(A <= a, k, (2 * k / np.pi) * (np.arcsin(s) + s * np.sqrt(1 - s * s)))


def loop_area(model, A, n=200_001, **theta):
    """Shoelace area of the loop polygon drawn from ``ascending_branch``."""
    A = np.asarray(A, float)[:, None]
    x = A * np.linspace(-1.0, 1.0, n)
    up = model.ascending_branch(x, A, 0.0, **theta)
    down = -model.ascending_branch(-x, A, 0.0, **theta)
    X = np.concatenate([x, x[:, ::-1]], axis=1)
    Y = np.concatenate([up, down[:, ::-1]], axis=1)
    return 0.5 * np.sum(X * np.roll(Y, -1, axis=1) - np.roll(X, -1, axis=1) * Y, axis=1)


# ---------------------------------------------------------------- closed form == referee


@pytest.mark.parametrize(
    "k, b, c",
    [
        (1.0, 1.0, 5.0),  # thesis graph scale
        (2.0, 3.0, 1.0),  # c/k < b: b1 < 0, the rising side lies at x > 0
        (1.0, 1.0, np.inf),  # Fig 2.4, never saturates
        (100.0, 0.0, 5.0),  # no width: plain saturation
        (300.0, 2e-5, 0.02),  # winding-chain units
    ],
)
def test_constant_width_edge_grid(k, b, c):
    b2 = c / k + b
    pts = [np.geomspace(1e-3, 40, 25) * max(b, c / k if np.isfinite(c) else 1.0)]
    if b > 0:
        pts.append(around(b))
    if np.isfinite(b2):
        pts.append(around(b2))
    assert_matches_referee(ConstantWidth, np.concatenate(pts), k=k, b=b, c=c)


@FAST
@given(
    k=st.floats(0.1, 1e3), b=st.floats(0.0, 2.0), c_over_k=st.floats(0.05, 5.0), inf_c=st.booleans()
)
def test_constant_width_property(k, b, c_over_k, inf_c):
    c = np.inf if inf_c else c_over_k * k
    A = np.concatenate([np.linspace(0.01, 12.0, 36), around(b + c_over_k, (1e-6, 1e-2))])
    assert_matches_referee(ConstantWidth, A, k=k, b=b, c=c)


M_EDGES = [0.0, 1e-9, 0.25, 0.5 - 1e-9, 0.5, 0.5 + 1e-9, 0.7, 0.999]


@pytest.mark.parametrize("model", PROPORTIONAL)
@pytest.mark.parametrize("m", M_EDGES)
def test_proportional_edge_grid(model, m):
    k, c = 2.0, 5.0
    a_sat = saturation_amplitude(k, c, m)
    pts = [np.geomspace(0.05, 5e3, 20), around(a_sat, (1e-9, 1e-3))]
    if m > 0:
        pts.append(around(c / (k * m), (1e-9, 1e-3)))  # k b = c: lens -> clipped
    assert_matches_referee(model, np.concatenate(pts), k=k, c=c, m=m)


@FAST
@given(
    k=st.floats(0.1, 1e3),
    c_over_k=st.floats(0.01, 10.0),
    m=st.floats(0.0, 0.999),
    fig42=st.booleans(),
)
def test_proportional_property(k, c_over_k, m, fig42):
    model = ProportionalWidthFig42 if fig42 else ProportionalWidth
    a_sat = c_over_k / (1 - m)
    A = a_sat * np.concatenate([np.geomspace(0.1, 30.0, 36), [1 - 1e-9, 1 + 1e-9]])
    assert_matches_referee(model, A, k=k, c=c_over_k * k, m=m)


@pytest.mark.parametrize("c", [np.inf, 3.2375, 1.0, 0.2])
def test_cubic_ks_grid(c):
    A = np.concatenate([np.linspace(0.05, 60.0, 40), around(0.5), around(0.50156), around(5.0)])
    assert_matches_referee(CubicHc, A, k=1.0, c=c, **KS_MAGNET_STEEL_SHAPE)


@FAST
@given(
    m1=st.floats(0.01, 3.0),
    bend=st.floats(0.0, 0.95),
    h0_ratio=st.floats(0.0, 0.95),
    h1=st.floats(0.5, 4.0),
    tail=st.floats(0.0, 0.5),
    c=st.floats(0.1, 5.0),
)
def test_cubic_property(m1, bend, h0_ratio, h1, tail, c):
    A = np.concatenate([np.geomspace(0.02, 30.0, 34), around(h1, (1e-9,))])
    theta = dict(h1=h1, m1=m1, tail_slope=tail, h0_ratio=h0_ratio, bend=bend)
    assert_matches_referee(CubicHc, A, k=1.5, c=c, **theta)


def test_cubic_reaches_cut_quadrilateral_regime():
    # alpha = 0.9 gives m > 0.5 with k b > c below saturation (the "cut" regime)
    theta = cubic(k=1.0, c=1.0, alpha=0.9, beta=0.0, h0=0.0, h1=100.0, tail_slope=0.0)
    A = np.linspace(1.2, 9.0, 30)  # c/(k m) = 1.11 < A < A_sat = 10
    assert_matches_referee(CubicHc, A, **theta)


@pytest.mark.parametrize(
    "model", [ConstantWidth, ProportionalWidth, ProportionalWidthFig42, CubicHc]
)
def test_defaults_in_winding_units_match_referee(model):
    A = np.geomspace(1e-6, 1e-2, 40)
    assert_matches_referee(model, A, **model.defaults())


# ---------------------------------------------------------------- special cases of the thesis


@pytest.mark.parametrize("model", PROPORTIONAL)
def test_m0_is_plain_saturation(model):
    A = np.geomspace(0.1, 100.0, 50)
    np.testing.assert_allclose(
        model.describing_function(A, k=2.0, c=5.0, m=0.0),
        saturation_df(A, 2.0, 5.0),
        rtol=0,
        atol=1e-14,
    )
    np.testing.assert_allclose(
        ConstantWidth.describing_function(A, k=2.0, b=0.0, c=5.0),
        saturation_df(A, 2.0, 5.0),
        rtol=0,
        atol=1e-14,
    )
    dead = CubicHc.describing_function(
        A, **cubic(k=2.0, c=5.0, alpha=0.5, beta=0.0, h0=1e3, h1=1e4, tail_slope=0.1)
    )
    np.testing.assert_allclose(dead, saturation_df(A, 2.0, 5.0), rtol=0, atol=1e-14)


@pytest.mark.parametrize("model", PROPORTIONAL)
def test_graph_4_1_m0_is_one_at_zero_degrees(model):
    N = model.describing_function(np.array([0.0, 1e-3, 1.0, 1e6]), k=1.0, c=np.inf, m=0.0)
    np.testing.assert_allclose(N, 1.0, rtol=0, atol=1e-15)


def test_b0_is_linear_gain_below_saturation():
    A = np.linspace(0.0, 2.5, 11)  # c/k = 2.5
    np.testing.assert_allclose(
        ConstantWidth.describing_function(A, k=2.0, b=0.0, c=5.0), 2.0, rtol=0, atol=1e-14
    )


def test_printed_eqs_4_4_4_5_below_saturation():
    m = np.linspace(0.0, 1.0, 21)
    u1 = np.arcsin(1 - 2 * m)
    G = (3.0 / np.pi) * (u1 + np.pi / 2 + 0.5 * np.sin(2 * u1))
    B = -4 * 3.0 * m * (1 - m) / np.pi
    N = ProportionalWidth.describing_function(0.7, k=3.0, c=np.inf, m=m)
    np.testing.assert_allclose(N, G + 1j * B, rtol=0, atol=1e-14)


def test_fig42_below_saturation_is_printed_point():
    m = np.linspace(0.0, 1.0, 21)[:, None]
    N = ProportionalWidthFig42.describing_function(np.array([0.1, 1.0, 9.0]), k=3.0, c=np.inf, m=m)
    np.testing.assert_allclose(
        N, np.broadcast_to(3.0 * ((1 - m) - 2j * m / np.pi), N.shape), rtol=0, atol=1e-14
    )


@pytest.mark.parametrize("model", PROPORTIONAL)
@pytest.mark.parametrize("m", [0.0, 0.2, 0.5, 0.8])
def test_saturation_amplitude(model, m):
    k, c = 2.0, 5.0
    a_sat = saturation_amplitude(k, c, m)
    assert a_sat == pytest.approx(2.5 / (1 - m), rel=1e-15)
    if model is ProportionalWidthFig42 and m > 0.5:
        # the lower vertex (0, -k m A) reaches -c before the tips do
        a_sat = c / (k * m)
    below = model.describing_function(a_sat * np.linspace(1e-3, 1.0, 30), k=k, c=c, m=m)
    np.testing.assert_allclose(below, below[0], rtol=0, atol=1e-13)
    above = model.describing_function(a_sat * np.array([1.01, 1.1, 2.0]), k=k, c=c, m=m)
    drop = np.diff(np.abs(np.concatenate([below[-1:], above])))
    assert np.all(drop < -1e-6) and drop.sum() < -0.05 * k


def test_fig42_equals_first_model_at_m_half():
    # at m = 0.5 the segment O-S is flat, and saturation starts exactly where k b = c,
    # so the two loops are the same at every amplitude
    A = np.geomspace(0.1, 200.0, 60)
    np.testing.assert_allclose(
        ProportionalWidthFig42.describing_function(A, k=1.0, c=5.0, m=0.5),
        ProportionalWidth.describing_function(A, k=1.0, c=5.0, m=0.5),
        rtol=0,
        atol=1e-14,
    )
    assert not np.allclose(
        ProportionalWidthFig42.describing_function(A, k=1.0, c=5.0, m=0.3),
        ProportionalWidth.describing_function(A, k=1.0, c=5.0, m=0.3),
    )


def test_fig42_eqs_4_6_4_7_valid_only_while_kb_le_c():
    k, c, m = 2.0, 5.0, 0.3
    A = np.linspace(3.6, 12.0, 40)  # A_sat = 3.57, c/(k m) = 8.33
    su = c / (k * A) + m
    u = np.arcsin(np.minimum(su, 1))
    G = (2 * k / np.pi) * ((1 - m / su) * u + (su - m) * np.cos(u))
    B = -(2 * k / np.pi) * m * su
    N = ProportionalWidthFig42.describing_function(A, k=k, c=c, m=m)
    lens = A <= c / (k * m)
    np.testing.assert_allclose(N[lens], (G + 1j * B)[lens], rtol=0, atol=1e-14)
    assert np.all(np.abs(N - (G + 1j * B))[A > 1.1 * c / (k * m)] > 1e-3)


def test_constant_width_accepts_array_b():
    A = np.geomspace(0.1, 50.0, 30)
    m = np.array([[0.1], [0.4], [0.8]])
    np.testing.assert_allclose(
        ConstantWidth.describing_function(A, k=1.5, b=m * A, c=5.0),
        ProportionalWidth.describing_function(A, k=1.5, c=5.0, m=m),
        rtol=0,
        atol=1e-14,
    )


def test_cubic_with_linear_law_is_proportional_fig42():
    A = np.geomspace(0.1, 100.0, 40)
    N = CubicHc.describing_function(
        A, **cubic(k=1.0, c=5.0, alpha=0.3, beta=0.0, h0=0.0, h1=1e6, tail_slope=0.0)
    )
    np.testing.assert_allclose(
        N, ProportionalWidthFig42.describing_function(A, k=1.0, c=5.0, m=0.3), rtol=0, atol=1e-14
    )


# ---------------------------------------------------------------- shapes and batches

CASES = [
    (ConstantWidth, dict(k=2.0, b=0.5, c=3.0)),
    (ProportionalWidth, dict(k=2.0, c=3.0, m=0.3)),
    (ProportionalWidthFig42, dict(k=2.0, c=3.0, m=0.7)),
    (CubicHc, dict(k=2.0, c=3.0, **KS_MAGNET_STEEL_SHAPE)),
]


@pytest.mark.parametrize("model, theta", CASES)
def test_batch_equals_loop(model, theta):
    rng = np.random.default_rng(1)
    base = np.array([theta[n] for n in model.param_names()])
    batch = base * rng.uniform(0.5, 1.5, size=(7, base.size))
    A = np.geomspace(0.05, 40.0, 25)
    N = model.evaluate(A, np.zeros_like(A), batch)
    assert N.shape == (7, 25)
    looped = np.array(
        [model.describing_function(A, 0.0, **dict(zip(model.param_names(), row))) for row in batch]
    )
    np.testing.assert_allclose(N, looped, rtol=1e-14, atol=0)
    # a nested batch (walkers x chains) broadcasts the same way
    assert model.evaluate(A, np.zeros_like(A), batch.reshape(7, 1, -1)).shape == (7, 1, 25)
    # scalar parameters with an array frequency still give one value per point
    assert model.describing_function(3.0, np.zeros(4), **theta).shape == (4,)


# ---------------------------------------------------------------- continuity, lag, loop area

BOUNDARIES = [
    (ConstantWidth, dict(k=2.0, b=0.5, c=3.0), [0.5, 2.0]),  # A = b, A = b2
    (ConstantWidth, dict(k=2.0, b=3.0, c=1.0), [3.0, 3.5]),  # b1 < 0
    (ProportionalWidth, dict(k=2.0, c=3.0, m=0.3), [1.5 / 0.7]),  # A_sat
    (ProportionalWidthFig42, dict(k=2.0, c=3.0, m=0.3), [1.5 / 0.7, 1.5 / 0.3]),  # lens, clipped
    (ProportionalWidthFig42, dict(k=2.0, c=3.0, m=0.7), [1.5 / 0.7, 1.5 / 0.3]),  # cut, clipped
    (CubicHc, dict(k=1.0, c=3.2375, **KS_MAGNET_STEEL_SHAPE), [0.5, 0.501563, 5.0]),
    (
        CubicHc,
        cubic(k=1.0, c=1.0, alpha=0.9, beta=0.0, h0=0.0, h1=100.0, tail_slope=0.0),
        [1.0 / 0.9, 10.0],
    ),
]


@pytest.mark.parametrize("model, theta, edges", BOUNDARIES)
def test_continuous_at_regime_boundaries(model, theta, edges):
    edges = np.asarray(edges)
    lo = model.describing_function(edges * (1 - 1e-10), **theta)
    hi = model.describing_function(edges * (1 + 1e-10), **theta)
    assert np.abs(hi - lo).max() <= 1e-6 * theta["k"]
    # and no jump anywhere on a fine scan: steps shrink with the grid spacing
    A = np.linspace(0.01, 3 * edges.max(), 20001)
    N = model.describing_function(A, **theta)
    assert np.abs(np.diff(N)).max() <= 0.01 * theta["k"]


@pytest.mark.parametrize(
    "model, theta",
    CASES
    + [
        (ConstantWidth, dict(k=2.0, b=3.0, c=1.0)),
        (CubicHc, cubic(k=1.0, c=1.0, alpha=0.9, beta=0.0, h0=0.0, h1=100.0, tail_slope=0.0)),
    ],
)
def test_lag_and_loop_area(model, theta):
    A = np.array([0.3, 1.0, 1.7, 2.5, 4.0, 6.0, 11.0, 30.0])
    N = model.describing_function(A, **theta)
    assert np.all(N.imag <= 0.0)
    area = loop_area(model, A, **theta)
    assert area.max() > 0.1 * theta["k"]  # the loops here have a real width
    err = np.abs(-np.pi * A**2 * N.imag - area) / (theta["k"] * A**2)
    assert err.max() <= 1e-8


# ---------------------------------------------------------------- width laws of section IV.2


def test_printed_eq_4_11_values_and_continuous_version():
    assert ks_magnet_steel_hc(5.0) == pytest.approx(1.7625, abs=1e-15)
    assert ks_magnet_steel_hc(5.0 + 1e-12) == pytest.approx(1.8, abs=1e-12)
    assert ks_magnet_steel_hc(0.5 + 1e-6) < 0  # printed cubic dips below zero
    w = cubic_width(np.array([0.4, 0.5, 0.5 + 1e-6, 5.0, 5.0 + 1e-9, 10.0]), **KS_MAGNET_STEEL)
    np.testing.assert_allclose(w, [0, 0, 0, 1.7625, 1.7625, 1.9625], rtol=0, atol=1e-9)
    hm = np.linspace(0.6, 4.9, 50)
    np.testing.assert_allclose(
        cubic_width(hm, **KS_MAGNET_STEEL), ks_magnet_steel_hc(hm), atol=1e-15
    )


@pytest.mark.parametrize("a, inv_b", [(0.3, 0.037), (0.25, 0.73), (0.26, 4.1), (0.4, 220.0)])
def test_cubic_from_kennelly(a, inv_b):
    """Table 3.1 constants: eq 4.10 matches the Kennelly law at hm_max, eq 4.9 needs H^2."""
    b = 1.0 / inv_b
    hm_max = 19 * a * inv_b  # H_c = 0.95 H_c,inf there
    alpha, beta = cubic_from_kennelly(a, b, hm_max)
    kennelly = lambda h: h / (a + b * h)  # noqa: E731  (eq 3.12 solved for H_c)
    assert alpha * hm_max - beta * hm_max**3 == pytest.approx(kennelly(hm_max), rel=1e-12)
    h = 1e-9 * hm_max
    assert alpha == 1.0 / a
    assert (alpha * h - beta * h**3) / h == pytest.approx(kennelly(h) / h, rel=1e-7)
    H = np.linspace(0.1, 2.0, 20) * hm_max
    corrected = H / a - b * H**2 / (a * (a + b * H))
    printed = H / a - b * H**3 / (a * (a + b * H))
    np.testing.assert_allclose(corrected, kennelly(H), rtol=1e-12)
    assert np.abs(printed - kennelly(H)).max() > 0.1 * kennelly(H).max()


def test_cubic_limit_warning_names_the_rows_on_the_widest_loop():
    """Rows named as on the widest loop are those whose DF no longer depends on alpha (the
    clip ``m = 1`` sets them), checked on the numerical referee of the loop itself."""
    law = dict(alpha=1.5, beta=0.5, h0=1e-9, h1=10.0, tail_slope=0.01)
    theta = cubic(k=1.0, c=np.inf, **law)
    A = np.array([0.2, 0.5, 0.9, 0.99, 1.1, 1.5])  # m = 1.5 - 0.5 A^2: 1.48 ... 0.375
    (warning,) = CubicHc.limit_warnings(A, **theta)
    assert "widest loop" in warning and "at 4 of 6 rows" in warning
    assert "peak currents 0.2..0.99 A" in warning
    wider = cubic(k=1.0, c=np.inf, **{**law, "alpha": 1.1 * law["alpha"]})
    before, after = (
        CubicHc.numerical_describing_function(A, n_points=2**12, **t) for t in (theta, wider)
    )
    clipped = 1.5 - 0.5 * A**2 >= 1.0  # the first four (0.99: m = 1.01)
    np.testing.assert_allclose(after[clipped], before[clipped], rtol=1e-12, atol=1e-12)
    assert np.all(np.abs(after[~clipped] - before[~clipped]) > 1e-2)
    # within the margin but not on the clip: still named (m = 0.995 at A = 1)
    near = cubic(k=1.0, c=np.inf, **{**law, "beta": 0.505})
    assert "at 1 of 1 rows" in CubicHc.limit_warnings([1.0], **near)[0]
    assert CubicHc.limit_warnings(A, **cubic(k=1.0, c=np.inf, **{**law, "alpha": 0.9})) == []


def test_cubic_coordinates_are_eq_4_8_law_and_back():
    """``cubic_law`` and ``cubic_shape`` are inverse; beyond ``h1`` the width is
    ``m1 h1 + tail_slope (A - h1)``; the coordinates the data leave free there
    (``h0_ratio``, ``bend``) do not move the law at or above ``h1``."""
    law = cubic_law(**KS_MAGNET_STEEL_SHAPE)
    for name, value in KS_MAGNET_STEEL.items():
        assert float(law[name]) == pytest.approx(value, rel=1e-13)
    assert KS_MAGNET_STEEL_SHAPE["m1"] == pytest.approx(1.7625 / 5.0, rel=1e-13)
    rng = np.random.default_rng(3)
    shapes = dict(
        h1=rng.uniform(1e-4, 1e-3, 50),
        m1=10 ** rng.uniform(-3, 0.5, 50),
        tail_slope=10 ** rng.uniform(-5, -1, 50),
        h0_ratio=rng.uniform(0, 0.95, 50),
        bend=rng.uniform(0, 0.95, 50),
    )
    back = cubic_shape(**cubic_law(**shapes))
    for name, value in shapes.items():
        np.testing.assert_allclose(back[name], value, rtol=1e-10, atol=1e-15)
    A = np.outer(shapes["h1"], [1.0, 1.5, 4.0, 30.0])
    h1, m1, s = (shapes[n][:, None] for n in ("h1", "m1", "tail_slope"))
    tail = m1 * h1 + s * (A - h1)
    law = {n: v[:, None] for n, v in cubic_law(**shapes).items()}
    np.testing.assert_allclose(cubic_width(A, **law), tail, rtol=1e-12)
    free = {"h0_ratio": shapes["h0_ratio"][::-1], "bend": shapes["bend"][::-1]}
    other = {**shapes, **free}
    np.testing.assert_allclose(
        cubic_width(A, **{n: v[:, None] for n, v in cubic_law(**shapes).items()}),
        cubic_width(A, **{n: v[:, None] for n, v in cubic_law(**other).items()}),
        rtol=1e-12,
    )
