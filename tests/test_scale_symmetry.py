"""The current-scale symmetry every law has, which the cross-impedance prediction relies on.

A law whose flux at the current ``i`` is the original's at ``s i`` (``fitdf.params
.current_scaled``), in a circuit whose series resistance is ``s`` times larger, gives the same
measured describing function at every point: the currents are ``1/s`` as large and ``R i`` and
the flux are unchanged. Checked through the winding chain (its solver to 1e-11) and the exact
voltage chain (its own tolerance), for every law and the dynamic chain's loss terms: a
parameter declared with the wrong physical quantity breaks it.
"""

from __future__ import annotations

import numpy as np
import pytest

from fitdf.chains import get_chain
from fitdf.models import MODELS, get_model
from fitdf.params import current_scaled

V = np.array([0.02, 0.2, 0.6, 2.0, 5.0])
F = np.array([3.0, 20.0, 6.0, 10.0, 50.0])
R_SOURCE = 0.0  # all of R is the series resistance, so that all of it scales
SCALE = 1.7

#: Parameter sets of each law inside its box (Permalloy-like, currents of order 1 mA).
THETA = {
    "constant_width": {"k": 20.0, "b": 3e-5, "c": 0.035},
    "proportional_width": {"k": 20.0, "c": 0.035, "m": 0.3},
    "proportional_width_fig42": {"k": 20.0, "c": 0.035, "m": 0.4},
    "rayleigh": {"mu0": 5.0, "gamma": 2e4, "c_sat": 0.035},
    "preisach": {
        "lambda_s": 0.037,
        "i_c": 3.5e-4,
        "sigma_c": 0.34,
        "i_i": 1e-4,
        "l_rev": 5.8,
        "f_rev": 0.11,
    },
    "jiles_atherton": {"lambda_s": 0.044, "a": 3.6e-4, "k": 8.7e-4, "c": 0.16, "zeta": 0.9},
}


def _theta(name):
    model = get_model(name)
    values = THETA.get(name) or model.defaults()
    return model, values


def _df(chain, model, values, chain_values):
    c = get_chain(chain)
    m_theta = np.array([values[p.name] for p in model.params])
    c_theta = np.array([chain_values[p.name] for p in c.params])
    return c.predict(model, V, F, R_SOURCE, m_theta, c_theta)


@pytest.mark.parametrize("name", list(MODELS))
def test_every_law_is_closed_under_a_current_scale(name):
    model, values = _theta(name)
    scaled = current_scaled(model.params, values, SCALE)
    assert scaled != values or not any(p.quantity for p in model.params)
    for chain, tol in (("winding", 1e-8), ("voltage", 6e-4)):
        base = _df(chain, model, values, {"r_series": 50.0, "gain": 1.0})
        moved = _df(chain, model, scaled, {"r_series": 50.0 * SCALE, "gain": 1.0})
        assert np.abs(moved - base).max() <= tol * max(1.0, np.abs(base).max()), (name, chain)
        # and the scale is not a no-op: the unscaled law in the scaled circuit differs
        other = _df(chain, model, values, {"r_series": 50.0 * SCALE, "gain": 1.0})
        assert np.abs(other - base).max() > 10 * tol, (name, chain)


def test_the_dynamic_chains_loss_terms_scale_with_the_current():
    model, values = _theta("rayleigh")
    chain = get_chain("dynamic")
    losses = {"r_series": 50.0, "gain": 1.0, "c_cl": 1e-4, "c_ex": 3e-5}
    scaled_chain = current_scaled(chain.params, {**losses, "r_series": 50.0 * SCALE}, SCALE)
    assert scaled_chain["c_cl"] == pytest.approx(1e-4 / SCALE, rel=1e-15)
    base = _df("dynamic", model, values, losses)
    moved = _df("dynamic", model, current_scaled(model.params, values, SCALE), scaled_chain)
    assert np.abs(moved - base).max() <= 6e-4
