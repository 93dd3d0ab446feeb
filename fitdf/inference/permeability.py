"""The series permeability of readings and of a fitted law, with the flux amplitude of each.

A reading inverted through the circuit of Fig 5.10 gives the winding's series permeability
``mu' - j mu''`` and quality factor ``Q = mu'/mu''``
(:func:`fitdf.inference.small_signal.series_permeability`), with the fit's own series
resistance ``R = R_source + r_series`` and calibration gain. The flux amplitude of a
reading is its EMF over ``w``: ``Lambda = |DF| V / (gain w)`` (the output is the winding's
EMF times the gain, section V.5). :func:`row_permeability` inverts the measured rows,
:func:`law_curves` the fit's own predictions on a fine grid of inputs, and
:func:`drawn_permeability` the rows drawn within their printed precision
(:func:`fitdf.data.precision.reading_resolution`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitdf.data.precision import reading_resolution
from fitdf.errors import ModelError
from fitdf.inference.small_signal import series_permeability
from fitdf.params import calibration_gain

__all__ = [
    "reading_flux",
    "fit_circuit",
    "row_permeability",
    "law_curves",
    "drawn_permeability",
    "core_geometry_of",
    "CURVE_POINTS",
]

#: Inputs per frequency of a law's curve, geometrically spaced from a quarter of the block's
#: smallest input to its largest.
CURVE_POINTS = 48


def reading_flux(df, amplitude, frequency, gain):
    """Peak flux linkage (V s) of a reading: its EMF ``|DF| V / gain`` over ``w = 2 pi f``."""
    return (
        np.abs(np.asarray(df))
        * np.asarray(amplitude, float)
        / (np.asarray(gain, float) * 2.0 * np.pi * np.asarray(frequency, float))
    )


def fit_circuit(result) -> tuple[float, float]:
    """``(gain, R)``: the fit's calibration gain and total series resistance
    ``R_source + r_series`` (ohm); the fit must be of one table at one source impedance."""
    data, values = result.problem.data, result.values
    groups, sources = np.unique(data.group), np.unique(data.source_impedance)
    if groups.size != 1 or sources.size != 1:
        raise ModelError(
            "the series permeability of a fit's rows needs one table at one source impedance, got "
            f"{groups.size} table(s) and {sources.size} source impedance(s)"
        )
    gain = float(values.get(f"gain[{groups[0]}]", calibration_gain(values)))
    return gain, float(sources[0]) + float(values.get("r_series", 0.0))


def _frame(df, amplitude, frequency, gain, R, geometry) -> pd.DataFrame:
    """One row per reading: frequency, input, flux amplitude, ``mu'``, ``mu''``, ``Q``."""
    mu = series_permeability(df, frequency, R, gain, geometry)
    with np.errstate(divide="ignore", invalid="ignore"):
        q = mu.real / -mu.imag
    return pd.DataFrame(
        {
            "frequency_hz": np.broadcast_to(frequency, np.shape(df)),
            "input_v": amplitude,
            "flux_vs": reading_flux(df, amplitude, frequency, gain),
            "mu": mu.real,
            "mu_loss": -mu.imag,
            "q": q,
        }
    )


def core_geometry_of(result, geometry=None):
    """``geometry``, else the fit's own core geometry; a one-line error when neither exists."""
    geometry = geometry or result.problem.geometry
    if geometry is None:
        raise ModelError("the series permeability needs the core's geometry")
    return geometry


def row_permeability(result, geometry=None) -> pd.DataFrame:
    """``mu'``, ``mu''`` (``mu_loss``), ``Q`` and the flux amplitude of every measured row,
    inverted with the fit's own series resistance and gain; the rows in the data's order."""
    geometry = core_geometry_of(result, geometry)
    d = result.problem.data
    gain, R = fit_circuit(result)
    return _frame(d.measured, d.amplitude, d.frequency, gain, R, geometry)


def law_curves(result, geometry=None, points=CURVE_POINTS) -> pd.DataFrame:
    """The fit's own ``mu'``, ``mu''``, ``Q`` and flux on a fine grid of inputs at each
    frequency of its rows (:data:`CURVE_POINTS` inputs from a quarter of the block's smallest
    input to its largest), from its predicted readings inverted with its own series
    resistance and gain."""
    geometry = core_geometry_of(result, geometry)
    d = result.problem.data
    gain, R = fit_circuit(result)
    parts = []
    for f in np.unique(d.frequency):
        v = d.amplitude[d.frequency == f]
        grid = np.geomspace(0.25 * v.min(), v.max(), points)
        df = result.predict(grid, f, d.source_impedance[0])
        parts.append(_frame(df, grid, np.full(grid.size, f), gain, R, geometry))
    return pd.concat(parts, ignore_index=True)


def drawn_permeability(result, geometry, draws, seed):
    """``(flux, mu)`` of every row for ``draws`` readings drawn uniformly within half a unit of
    their printed DF and phase (:func:`fitdf.data.precision.reading_resolution`), inverted
    like :func:`row_permeability`: arrays of shape ``(draws, rows)``, ``mu`` complex
    (``mu' - j mu''``); ``seed`` seeds the draws."""
    d = result.problem.data
    d_mag, d_phase = reading_resolution(d.rows)
    u = np.random.default_rng(seed).uniform(-1.0, 1.0, size=(2, draws, d.n))
    df = (np.abs(d.measured) + u[0] * d_mag) * np.exp(
        1j * (np.angle(d.measured) + np.deg2rad(u[1] * d_phase))
    )
    gain, R = fit_circuit(result)
    mu = series_permeability(df, d.frequency, R, gain, geometry)
    return reading_flux(df, d.amplitude, d.frequency, gain), mu
