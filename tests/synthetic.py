"""Synthetic measured describing functions from known parameters (for recovery tests)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitdf.chains import get_chain
from fitdf.inference.api import DEFAULT_CHAIN, resolve_data
from fitdf.inference.problem import FitProblem
from fitdf.models import get_model

#: Permalloy-like amplitudes and frequencies, the size of one Appendix B table.
AMPLITUDES = np.array([0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0])
FREQUENCIES = (3.0, 6.0, 10.0)


def synthetic_frame(
    model,
    values: dict,
    chain=DEFAULT_CHAIN,
    source_impedances=(600.0,),
    frequencies=FREQUENCIES,
    amplitudes=AMPLITUDES,
    sigma_magnitude=0.005,
    sigma_phase_deg=0.5,
    seed=0,
    table="synthetic",
) -> pd.DataFrame:
    """Rows in the Appendix B schema, generated through ``chain`` with Gaussian noise.

    The noise is that of the tables' printed precision (about half a unit in the last
    printed digit), then the values are rounded as the thesis prints them.
    """
    model, chain = get_model(model), get_chain(chain)
    rng = np.random.default_rng(seed)
    V, F, R = (
        a.ravel() for a in np.meshgrid(amplitudes, frequencies, source_impedances, indexing="ij")
    )
    m_theta = np.array([values[p.name] for p in model.params])
    c_theta = np.array([values[p.name] for p in chain.params])
    df = chain.predict(model, V, F, R, m_theta, c_theta)
    mag = np.abs(df) + sigma_magnitude * rng.standard_normal(df.size)
    phase = np.angle(df, deg=True) + sigma_phase_deg * rng.standard_normal(df.size)
    return pd.DataFrame(
        {
            "table": table,
            "core": "synthetic",
            "source_impedance_ohm": R,
            "frequency_hz": F,
            "input_v": V,
            "df_reported": np.round(np.clip(mag, 0, None), 3),
            "phase_lead_deg": np.round(phase, 1),
        }
    )


#: The truth of :func:`mcmc_problem`: a proportional-width core and its winding chain.
MCMC_TRUTH = {"k": 60.0, "c": 0.035, "m": 0.3, "r_series": 100.0, "gain": 0.95}


def mcmc_problem() -> FitProblem:
    """The problem the MCMC tests share: proportional_width on synthetic rows at 0 and 600
    ohm, generated and fitted through the (fast) winding chain."""
    frame = synthetic_frame(
        "proportional_width", MCMC_TRUTH, chain="winding", source_impedances=(0.0, 600.0), seed=11
    )
    return FitProblem(resolve_data(frame, policy="all"), "proportional_width", "winding")
