"""Harmonic balance against simulation: the same loop solved both ways (thesis V.6).

Disagreement between the two measures the describing-function approximation (the loop's
error signal is not a pure sinusoid), not an error of either computation; see
:mod:`fitdf.loop.simulate`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitdf.errors import OptionError
from fitdf.loop.harmonic import limit_cycles
from fitdf.loop.simulate import simulate_loop

__all__ = ["time_domain_check"]


def time_domain_check(
    plant,
    element,
    gains,
    *,
    nonlinearity=None,
    amplitude_range,
    omega_range=None,
    periods: float = 60.0,
    steps_per_period: int = 200,
    initial_output=0.1,
    time_scale: float = 1.0,
    settle_fraction: float = 0.6,
) -> pd.DataFrame:
    """Harmonic balance vs simulation, one row per gain.

    The DF used for harmonic balance is ``nonlinearity`` (default: the element's own
    ``describing_function``); the step and duration follow from the largest stable
    harmonic-balance frequency (``steps_per_period`` per period, ``periods`` periods).
    Columns: gain, ``hb_amplitude``, ``hb_omega``, simulated ``amplitude`` (half
    peak-to-peak at the element input), ``amplitude_h1``, ``omega``, ``plant_output_amplitude``,
    and the relative differences ``amplitude_error`` (peak) / ``amplitude_h1_error`` / ``omega_error``.
    """
    N = nonlinearity if nonlinearity is not None else element.describing_function
    hb = limit_cycles(
        plant,
        N,
        gains,
        amplitude_range=amplitude_range,
        omega_range=omega_range,
        time_scale=time_scale,
    ).stable_cycles()
    w = hb["omega_rad_s"].to_numpy(float)
    if not np.isfinite(w).any():
        raise OptionError("harmonic balance finds no stable limit cycle at these gains")
    wmax = np.nanmax(w)
    dt = 2 * np.pi / wmax / steps_per_period
    t_end = periods * 2 * np.pi / np.nanmin(w)
    sim = simulate_loop(
        plant,
        element,
        hb["gain"].to_numpy(float),
        t_end=t_end,
        dt=dt,
        initial_output=initial_output,
        time_scale=time_scale,
    ).measure(settle_fraction)
    out = pd.DataFrame(
        {"gain": hb["gain"], "hb_amplitude": hb["amplitude"], "hb_omega": hb["omega_rad_s"]}
    )
    out = pd.concat([out, sim.drop(columns="gain")], axis=1)
    out["amplitude_error"] = out["amplitude"] / out["hb_amplitude"] - 1
    out["amplitude_h1_error"] = out["amplitude_h1"] / out["hb_amplitude"] - 1
    out["omega_error"] = out["omega"] / out["hb_omega"] - 1
    return out
