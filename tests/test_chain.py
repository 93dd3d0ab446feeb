"""Measurement chains (section V.5, Fig 5.10): self-consistent winding current, lead, batching."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fitdf.chains import CHAINS, DirectChain, WindingChain, chain_names, get_chain, solve_current
from fitdf.errors import ModelError
from fitdf.models import get_model, model_names

MODELS = model_names()
# every combination of V (V), f (Hz) and R_source (ohm) of the grid
_V, _F, _RS = (
    a.ravel()
    for a in np.meshgrid(np.logspace(-3, 1.3, 40), [3.0, 10.0, 50.0], [0.0, 600.0], indexing="ij")
)
NESTED = [
    "constant_width",
    "proportional_width",
    "proportional_width_fig42",
    "rayleigh",
    "frequency_hc",
]


def defaults(spec_owner):
    return np.array([p.default for p in spec_owner.params])


def random_theta(spec_owner, rng, size=None):
    lo, hi = np.array([p.internal_bounds for p in spec_owner.params]).T
    internal = rng.uniform(lo, hi, size=(size or 1, len(lo)))
    nat = np.column_stack(
        [p.from_internal(internal[:, i]) for i, p in enumerate(spec_owner.params)]
    )
    return nat if size else nat[0]


def relative_residual(op, V, f, Rs, r_series):
    R = Rs + r_series
    return np.abs(op.current * np.abs(R + 2j * np.pi * f * op.inductance) / V - 1)


@pytest.mark.parametrize("name", MODELS)
def test_self_consistent_current_at_defaults(name):
    model = get_model(name)
    ct = defaults(WindingChain)
    op = WindingChain.operating_point(model, _V, _F, _RS, defaults(model), ct)
    assert op.current.shape == _V.shape and np.all(np.isfinite(op.current))
    assert relative_residual(op, _V, _F, _RS, ct[0]).max() <= 1e-9
    np.testing.assert_array_equal(
        op.current, WindingChain.core_current(model, _V, _F, _RS, defaults(model), ct)
    )
    np.testing.assert_array_equal(
        op.df, WindingChain.predict(model, _V, _F, _RS, defaults(model), ct)
    )


@pytest.mark.parametrize("name", MODELS)
def test_self_consistent_current_random_parameters(name):
    # proof of convergence of the solver over the whole prior box (one batched call)
    model, rng = get_model(name), np.random.default_rng(MODELS.index(name))
    mt, ct = random_theta(model, rng, 24), random_theta(WindingChain, rng, 24)
    op = WindingChain.operating_point(model, _V, _F, _RS, mt, ct)
    assert op.current.shape == (24, _V.size)
    res = np.abs(op.current * np.abs(_RS + ct[:, :1] + 2j * np.pi * _F * op.inductance) / _V - 1)
    assert res.max() <= 1e-9


@pytest.mark.parametrize("name", MODELS)
def test_winding_turns_a_lag_into_a_lead(name):
    model = get_model(name)
    op = WindingChain.operating_point(model, _V, _F, _RS, defaults(model), defaults(WindingChain))
    lagging = op.inductance.imag < -1e-12 * np.abs(op.inductance)
    assert lagging.sum() > _V.size // 2
    assert np.all(np.angle(op.df[lagging]) > 0)
    assert np.all(
        np.angle(op.df[lagging]) < np.pi / 2
    )  # between the in-phase and the pure-inductor case
    # the direct chain shows the core's own lag: it never leads
    direct = DirectChain.predict(model, _V, _F, _RS, defaults(model), defaults(DirectChain))
    assert np.all(np.angle(direct) <= 1e-12)


@pytest.mark.parametrize("name", MODELS)
def test_direct_chain_is_the_scaled_model(name):
    model = get_model(name)
    scale = 2e3
    got = DirectChain.predict(model, _V, _F, _RS, defaults(model), [scale])
    np.testing.assert_array_equal(
        got, model.describing_function(_V / scale, _F, **model.defaults())
    )
    np.testing.assert_allclose(
        DirectChain.core_current(model, _V, _F, _RS, defaults(model), [scale]),
        _V / scale,
        rtol=1e-15,
    )


@pytest.mark.parametrize(
    "name", ["constant_width", "proportional_width", "rayleigh", "frequency_hc"]
)
def test_vanishing_resistance_gives_the_calibration_gain(name):
    # below the saturation voltage the ideal source's voltage is all across the winding
    model = get_model(name)
    c = model.defaults().get("c", model.defaults().get("c_sat"))
    f = np.full(30, 10.0)
    V = np.logspace(-4, np.log10(0.2 * 2 * np.pi * 10.0 * c), 30)
    df = WindingChain.predict(model, V, f, np.zeros(30), defaults(model), [1e-7, 0.93])
    np.testing.assert_allclose(df, 0.93, rtol=1e-4)
    assert (
        np.abs(
            WindingChain.predict(model, V, f, np.zeros(30), defaults(model), [1e-3, 0.93]) - 0.93
        ).max()
        > np.abs(df - 0.93).max()
    )  # and the approach is monotone in R


def test_dead_zone_gives_zero_output_and_ohmic_current():
    model = get_model("constant_width")
    theta = np.array([100.0, 1e-3, 0.03])  # k, b, c: no output below 1 mA
    V = np.array([1e-3, 0.1, 1.0])
    R = 70.0 + 600.0
    op = WindingChain.operating_point(
        model, V, np.full(3, 10.0), np.full(3, 600.0), theta, [70.0, 1.0]
    )
    np.testing.assert_allclose(op.current[:2], V[:2] / R, rtol=1e-15)  # I = V / R <= b
    np.testing.assert_array_equal(op.df[:2], 0.0)
    assert op.current[2] > 1e-3 and abs(op.df[2]) > 0


@pytest.mark.parametrize("name", ["constant_width", "proportional_width"])
@pytest.mark.parametrize("source", [0.0, 600.0])
def test_saturation_voltage_grows_linearly_with_frequency(name, source):
    # Graph 5.3: the input voltage at which |DF| leaves its maximum is proportional to f
    model = get_model(name)
    V = np.logspace(-3, 2, 1200)
    freqs = np.array([3.0, 6.0, 10.0, 20.0, 30.0, 50.0])
    knee = []
    for f in freqs:
        mag = np.abs(
            WindingChain.predict(
                model,
                V,
                np.full(V.size, f),
                np.full(V.size, source),
                defaults(model),
                defaults(WindingChain),
            )
        )
        knee.append(V[np.flatnonzero(mag >= 0.99 * mag.max()).max()])
    per_hz = np.array(knee) / freqs
    assert per_hz.max() / per_hz.min() < 1.15
    # the core then carries the flux of its saturated loop, ~(4/pi) c, at V = 2 pi f Phi
    c = model.defaults()["c"]
    assert 1.0 < per_hz.mean() / (2 * np.pi * c) < 4 / np.pi * 1.05


@pytest.mark.parametrize("name", MODELS)
def test_source_impedance_attenuates_small_signals(name):
    model = get_model(name)
    V = np.logspace(-2, -1, 8)
    f = np.full(8, 10.0)
    mag0 = np.abs(
        WindingChain.predict(model, V, f, np.zeros(8), defaults(model), defaults(WindingChain))
    )
    mag600 = np.abs(
        WindingChain.predict(
            model, V, f, np.full(8, 600.0), defaults(model), defaults(WindingChain)
        )
    )
    assert np.all(mag600 < mag0)


@pytest.mark.parametrize("name", MODELS)
@pytest.mark.parametrize("chain", list(CHAINS))
def test_batch_equals_loop(name, chain):
    model, ch = get_model(name), get_chain(chain)
    rng = np.random.default_rng(7)
    mt, ct = random_theta(model, rng, 5), random_theta(ch, rng, 5)
    V, f, Rs = _V[::7], _F[::7], _RS[::7]
    batch = ch.predict(model, V, f, Rs, mt, ct)
    assert batch.shape == (5, V.size)
    for i in range(5):
        np.testing.assert_allclose(
            batch[i], ch.predict(model, V, f, Rs, mt[i], ct[i]), rtol=1e-9, atol=1e-12
        )
    # one chain parameter set shared by all walkers broadcasts too
    shared = ch.predict(model, V, f, Rs, mt, ct[0])
    np.testing.assert_allclose(
        shared[3], ch.predict(model, V, f, Rs, mt[3], ct[0]), rtol=1e-9, atol=1e-12
    )


@pytest.mark.parametrize("name", NESTED)
def test_voltage_is_monotone_in_current_for_nested_loops(name):
    # h(I) = I |R + Z(I)| increases strictly when loop area and |I N| do not decrease: unique root
    model, rng = get_model(name), np.random.default_rng(11)
    current = np.logspace(-8, 1, 3000)
    for theta in [defaults(model), *random_theta(model, rng, 10)]:
        kw = dict(zip(model.param_names(), theta))
        for f in (3.0, 50.0):
            N = model.describing_function(current, f, **kw)
            for R in (1.0, 670.0):
                h = current * np.abs(R + 2j * np.pi * f * N)
                assert np.all(np.diff(h) > 0)


def test_cubic_law_can_make_the_voltage_non_monotone():
    # a width shrinking with amplitude (eq 4.8 past its maximum) breaks the sufficient condition;
    # the solver still returns a self-consistent current (one of the roots)
    model = get_model("cubic_hc")
    rng = np.random.default_rng(3)
    current = np.logspace(-8, 1, 3000)
    found = None
    for theta in random_theta(model, rng, 60):
        N = model.describing_function(current, 3.0, **dict(zip(model.param_names(), theta)))
        h = current * np.abs(1.0 + 2j * np.pi * 3.0 * N)
        drop = np.flatnonzero(np.diff(h) < 0)
        if drop.size:
            found = theta, h[drop[0]]
            break
    assert found is not None
    theta, V = found
    op = WindingChain.operating_point(
        model, np.array([V]), np.array([3.0]), np.array([0.0]), theta, [1.0, 1.0]
    )
    assert relative_residual(op, V, 3.0, 0.0, 1.0).max() <= 1e-9


# --- the solver on its own -------------------------------------------------------------------


@settings(max_examples=40, deadline=None)
@given(
    V=st.floats(1e-4, 1e2),
    R=st.floats(1e-9, 1e4),
    L=st.floats(0.0, 1e4),
    loss=st.floats(-0.4, 1.0),
    f=st.floats(0.0, 100.0),
)
def test_solver_on_a_linear_inductor(V, R, L, loss, f):
    # Z = omega L (loss + j): I = V / |R + Z| exactly; loss < 0 (an active Z) needs the upward search
    Z = 2 * np.pi * f * L * (loss * min(1.0, R / max(2 * np.pi * f * L, 1e-300)) + 1j)
    current, z = solve_current(lambda i, idx: np.full(i.shape, Z), np.array([V]), np.array([R]))
    assert current[0] == pytest.approx(V / abs(max(R, 1e-12) + Z), rel=1e-11)
    assert z[0] == Z


def test_solver_edge_cases():
    imp = lambda i, idx: 2j * np.pi * 10.0 * 100.0 * np.ones_like(i)  # noqa: E731
    current, _ = solve_current(imp, np.array([0.0, -1.0, 1.0]), np.array([50.0, 50.0, 0.0]))
    assert (
        current[0] == 0
        and current[1] == 0
        and current[2] == pytest.approx(1 / (2 * np.pi * 1000.0))
    )
    nan, _ = solve_current(
        lambda i, idx: np.full(i.shape, np.nan + 0j), np.array([1.0]), np.array([10.0])
    )
    assert np.isnan(nan[0])
    two_d, _ = solve_current(imp, np.ones((3, 4)), np.full((1, 4), 10.0))
    assert two_d.shape == (3, 4)


@pytest.mark.parametrize("name", ["constant_width", "rayleigh"])
def test_warm_start_gives_the_same_current_in_fewer_calls(name):
    model = get_model(name)
    kw = model.defaults()
    R, omega = _RS + 70.0, 2 * np.pi * _F
    calls = []

    def impedance(i, idx):
        calls.append(idx.size)
        return (
            1j
            * omega[idx]
            * model.describing_function(i, _F[idx], **{k: v * (1 + 1e-6) for k, v in kw.items()})
        )

    cold, _ = solve_current(impedance, _V, R)
    n_cold, calls[:] = len(calls), []
    warm, z = solve_current(
        impedance, _V, R, initial=cold * (1 + 1e-5 * np.sin(np.arange(_V.size)))
    )
    assert np.abs(warm * np.abs(R + z) / _V - 1).max() <= 1e-10
    # where h(I) is nearly flat (saturated core, small R) a 1e-11 residual fixes I to ~1e-8 only
    np.testing.assert_allclose(warm, cold, rtol=1e-7)
    assert len(calls) <= n_cold // 2
    calls[:] = []
    junk, _ = solve_current(
        impedance, _V, R, initial=np.where(np.arange(_V.size) % 2, np.nan, -1.0)
    )
    np.testing.assert_allclose(junk, cold, rtol=1e-7)  # unusable guesses fall back to V / R


def test_winding_chain_accepts_zero_resistance():
    model = get_model("proportional_width")
    df = WindingChain.predict(model, _V, _F, np.zeros(_V.size), defaults(model), [0.0, 1.0])
    assert np.all(np.isfinite(df)) and np.all(np.abs(df) <= 1.0 + 1e-12)


def test_negative_source_impedance_is_rejected():
    with pytest.raises(ModelError, match="source_impedance"):
        WindingChain.predict(
            "constant_width",
            [1.0],
            [10.0],
            [-5.0],
            defaults(get_model("constant_width")),
            defaults(WindingChain),
        )


def test_registry():
    assert chain_names() == ["direct", "winding", "voltage", "dynamic"]
    assert get_chain("winding") is WindingChain and get_chain(DirectChain) is DirectChain
    with pytest.raises(ModelError, match="known chains: direct, winding"):
        get_chain("transformer")
    for ch in CHAINS.values():
        assert ch.describe()["name"] == ch.name
        for p in ch.params:
            assert p.bounds[0] <= p.default <= p.bounds[1]
    assert WindingChain.defaults() == {"r_series": 70.0, "gain": 1.0}
