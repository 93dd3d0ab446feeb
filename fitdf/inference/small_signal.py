"""The small-signal rows: can a remanent or DC-biased core explain them? (a hypothesis test)

At about the same current (0.25 mA) the smallest inputs of Table B.3 imply 18 H / 52 deg,
15 H / 19 deg and 24 H / 35 deg at 3, 6 and 10 c/s: large loss angles with no frequency
trend. The thesis mentions bias turns added to cancel a DC voltage in the analyser
(Photo 2, "D.C. bias effect"), so the core may not sit in the demagnetised state the
laws assume. Two versions of that hypothesis are tested on a fitted Preisach law, the
one law here with an exact input history (:func:`fitdf.models._preisach_history.preisach_output`):

* **Remanence** (zero mean current, core left magnetised by earlier large signals): in
  the Preisach model the steady minor loops between the same input extremes are
  congruent whatever the history (Mayergoyz, *Mathematical Models of Hysteresis*, 1991,
  sec. 1.3), so the DF cannot depend on it. :func:`biased_describing_function` with
  ``initial="positive"`` checks this numerically (the loop is only shifted in flux).
* **A DC bias current** ``I0``: the steady loop between ``I0 - A`` and ``I0 + A``. Its DF
  is computed from the exact history for a sinusoidal current (valid at small signal:
  the core is nearly linear there, and :func:`small_signal_scan` measures this
  approximation's error against the exact ``voltage`` chain at ``I0 = 0``), mapped to the
  reading with the fitted winding (``DF = gain Z/(R + Z)``, ``Z = j w N``), and the bias
  that fits each small-signal row best is searched over a grid.

Any rate-independent loop tends to a Rayleigh loop (eq 3.7) as the amplitude vanishes,
so its loss angle tends to 0 whatever the bias: a large loss angle at the smallest
inputs needs rate dependence or a measurement effect. The scan reports the largest loss
angle any bias gives at each row's current beside the one the reading implies.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitdf.chains.winding import reading
from fitdf.errors import ModelError
from fitdf.models._preisach_history import preisach_output
from fitdf.params import PER_TABLE, calibration_gain, parameter_base

__all__ = [
    "biased_describing_function",
    "small_signal_rows",
    "small_signal_scan",
    "verdict",
    "series_permeability",
    "small_signal_permeability",
    "passive_distance",
]

#: Samples per period of the biased-loop DF (the history is exact between samples; the
#: first harmonic by the trapezoidal rule is spectrally accurate on a periodic signal).
SAMPLES = 512

#: Bias grid of :func:`small_signal_scan`, in units of the law's switching field ``i_c``.
BIAS_GRID = np.concatenate([[0.0], np.geomspace(0.02, 20.0, 40)])


def biased_describing_function(values, amplitude, bias, initial="demagnetized", samples=SAMPLES):
    """``N`` (H) of the steady Preisach loop under the current ``bias + amplitude sin(wt)``.

    From the state ``initial`` the current ramps to ``bias``, then runs two periods; the
    first harmonic of the second (steady: the wiping-out rule makes the loop closed after
    one period) over ``amplitude``, ``N = (1/(pi A)) Int lambda (sin t + j cos t) dt`` (the
    sign convention of :func:`fitdf.numerical_df.numerical_describing_function`: lag ``Im N < 0``).
    ``values`` are the law's parameters; ``amplitude`` and ``bias`` broadcast.
    """
    A, I0 = np.broadcast_arrays(np.asarray(amplitude, float), np.asarray(bias, float))
    if np.any(A <= 0):
        raise ModelError("amplitude must be > 0 A")
    t = 2.0 * np.pi * np.arange(2 * samples + 1) / samples
    current = np.concatenate(
        [np.zeros(A.shape + (1,)), I0[..., None] + A[..., None] * np.sin(t)], axis=-1
    )
    theta = {k: np.asarray(values[k], float) for k in ("lambda_s", "i_c", "sigma_c", "i_i")}
    theta.update(l_rev=np.asarray(values["l_rev"], float), f_rev=np.asarray(values["f_rev"], float))
    lam = preisach_output(current, initial=initial, **{k: v[..., None] for k, v in theta.items()})
    steady = lam[..., 1 + samples : 1 + 2 * samples]  # the second period, without its end
    ts = t[samples : 2 * samples]
    first = np.mean(steady * (np.sin(ts) + 1j * np.cos(ts)), axis=-1) * 2.0
    return first / A


def small_signal_rows(data) -> np.ndarray:
    """Indices of the smallest-input row of each (table, source impedance, frequency) block."""
    frame = pd.DataFrame(
        {
            "table": np.asarray(data.group),
            "r": np.asarray(data.source_impedance, float),
            "f": np.asarray(data.frequency, float),
            "v": np.asarray(data.amplitude, float),
        }
    )
    return np.sort(frame.groupby(["table", "r", "f"], sort=True)["v"].idxmin().to_numpy())


def small_signal_scan(result, biases=None) -> pd.DataFrame:
    """Fit a DC bias to each small-signal row of a Preisach ``result``; one row per data row.

    For each row of :func:`small_signal_rows`: the reading measured, the fit's own
    prediction (its chain), the sinusoidal-current prediction at ``I0 = 0`` (the
    approximation used for the bias), the loss angle of the core the reading implies
    (``-arg N`` with ``N = Z/(j w)``, ``Z = R DF/(gain - DF)``) and the largest any bias
    gives at the row's peak current, and the best bias (in A and in units of ``i_c``)
    with its prediction. ``biases``: in units of ``i_c`` (default :data:`BIAS_GRID`).
    """
    problem = result.problem
    if problem.model.name != "preisach":
        raise ModelError(f"the small-signal scan needs a Preisach fit, got {problem.model.name!r}")
    data = problem.data
    rows = small_signal_rows(data)
    values = result.values
    law = {s.name: values[s.name] for s in problem.model.params}
    grid = np.asarray(BIAS_GRID if biases is None else biases, float) * law["i_c"]
    gains = {
        k: v for k, v in values.items() if parameter_base(k) in PER_TABLE and k != parameter_base(k)
    }
    current = problem.core_currents(result.internal)[rows]
    fitted = problem.predict(result.internal)[rows]
    f = np.asarray(data.frequency, float)[rows]
    R = np.asarray(data.source_impedance, float)[rows] + values.get("r_series", 0.0)
    table = np.asarray(data.group)[rows]
    gain = np.array([gains.get(f"gain[{t}]", values.get("gain", 1.0)) for t in table])
    measured = np.asarray(data.measured)[rows]
    N = biased_describing_function(law, current[:, None], grid[None, :])  # (rows, biases)
    pred = reading(2j * np.pi * f[:, None] * N, R[:, None], gain[:, None])
    err = np.abs(pred - measured[:, None])
    best = np.argmin(err, axis=1)
    pick = np.arange(rows.size)
    # one bias for every row of a table (bias turns are fixed): the physical version
    common = np.empty(rows.size, int)
    for t in np.unique(table):
        mine = table == t
        common[mine] = np.argmin(np.sum(err[mine] ** 2, axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        z_meas = R * measured / (gain - measured)
    implied = -np.angle(z_meas / (2j * np.pi * f), deg=True)
    return pd.DataFrame(
        {
            "row": rows,
            "table": table,
            "source_impedance_ohm": np.asarray(data.source_impedance, float)[rows],
            "frequency_hz": f,
            "input_v": np.asarray(data.amplitude, float)[rows],
            "peak_current_a": current,
            "measured": measured,
            "fitted": fitted,
            "sinusoidal_unbiased": pred[:, 0],
            "approximation_error": np.abs(pred[:, 0] - fitted),
            "implied_loss_angle_deg": implied,
            "max_loss_angle_any_bias_deg": np.max(-np.angle(N, deg=True), axis=1),
            "unbiased_error": err[:, 0],
            "best_bias_a": grid[best],
            "best_bias_over_i_c": grid[best] / law["i_c"],
            "best_bias_error": err[pick, best],
            "common_bias_a": grid[common],
            "common_bias_error": err[pick, common],
        }
    )


def verdict(scan: pd.DataFrame) -> str:
    """One sentence on what the scan says.

    Supported only if one bias per table (the physical version) at least halves the
    small-signal RMS error and no row implies a loss angle (by more than 1 deg) that no
    bias can give; the per-row best bias (a generous version) is quoted beside it.
    """

    def rms(col):
        return float(np.sqrt(np.mean(scan[col] ** 2)))

    before, common, per_row = (
        rms("unbiased_error"),
        rms("common_bias_error"),
        rms("best_bias_error"),
    )
    short = scan["implied_loss_angle_deg"] > scan["max_loss_angle_any_bias_deg"] + 1.0
    word = "supported" if common < 0.5 * before and not short.any() else "not supported"
    return (
        f"DC-bias hypothesis {word}: one bias per table takes the small-signal RMS error from "
        f"{before:.3f} to {common:.3f} (a free bias per row: {per_row:.3f}); "
        f"at {int(short.sum())} of {len(scan)} rows the reading "
        "implies a larger loss angle than any bias gives the fitted law "
        f"(largest implied {scan['implied_loss_angle_deg'].max():.0f} deg, largest reachable "
        f"{scan['max_loss_angle_any_bias_deg'].max():.0f} deg)"
    )


def series_permeability(df, frequency, resistance, gain, geometry):
    """Complex relative permeability ``mu' - j mu''`` of the winding read through Fig 5.10.

    The reading of a winding of impedance ``Z`` behind ``R`` is ``DF = gain Z / (R + Z)``
    (section V.5, :func:`fitdf.chains.winding.reading`), so ``Z = R DF / (gain - DF)``; its
    series inductance ``L = Z / (j w)`` as relative permeability,
    ``mu = L l_e / (mu_0 N^2 A_e)`` (:meth:`fitdf.data.cores.CoreGeometry.relative_permeability`).
    The quality factor is ``Q = Im Z / Re Z = mu' / mu''``. Exact for a linear winding; at
    the small-signal rows the core is nearly linear and the first harmonics carry the rest.

    Parameters
    ----------
    df : array_like of complex
        Readings (measured or predicted), ``angle > 0`` a lead.
    frequency, resistance, gain : array_like
        Hz; total series resistance ``R_source + r_series`` (ohm); the reading's gain.
    geometry : CoreGeometry

    Returns
    -------
    numpy.ndarray of complex
        ``mu' - j mu''`` (``mu'' > 0`` for a lossy core).
    """
    df = np.asarray(df, complex)
    with np.errstate(divide="ignore", invalid="ignore"):
        Z = np.asarray(resistance, float) * df / (np.asarray(gain, float) - df)
    L = Z / (2j * np.pi * np.asarray(frequency, float))
    return L / geometry.inductance_per_permeability


def small_signal_permeability(result, geometry=None) -> pd.DataFrame:
    """Series permeability and Q at the smallest-input row of each block, measured and fitted.

    Both readings, the measured one and the fit's prediction (its chain: for the
    ``dynamic`` chain the rate-dependent losses included), are inverted through the circuit
    of Fig 5.10 with the fit's own ``R = R_source + r_series`` and gain
    (:func:`series_permeability`), so the two columns differ only by what the fit does not
    reproduce. ``geometry``: the fit's (default) or another :class:`CoreGeometry`.
    """
    problem = result.problem
    geometry = geometry or problem.geometry
    if geometry is None:
        raise ModelError("the small-signal permeability needs the core's geometry")
    data = problem.data
    rows = small_signal_rows(data)
    values = result.values
    table = np.asarray(data.group)[rows]
    gain = np.array([values.get(f"gain[{t}]", calibration_gain(values)) for t in table])
    f = np.asarray(data.frequency, float)[rows]
    Rs = np.asarray(data.source_impedance, float)[rows]
    R = Rs + values.get("r_series", 0.0)
    measured = np.asarray(data.measured)[rows]
    fitted = problem.predict(result.internal)[rows]
    mu_m = series_permeability(measured, f, R, gain, geometry)
    mu_f = series_permeability(fitted, f, R, gain, geometry)
    with np.errstate(divide="ignore", invalid="ignore"):
        q_m, q_f = mu_m.real / -mu_m.imag, mu_f.real / -mu_f.imag
    return pd.DataFrame(
        {
            "row": rows,
            "table": table,
            "source_impedance_ohm": Rs,
            "frequency_hz": f,
            "input_v": np.asarray(data.amplitude, float)[rows],
            "measured": measured,
            "fitted": fitted,
            "mu_measured": mu_m.real,
            "q_measured": q_m,
            "mu_fitted": mu_f.real,
            "q_fitted": q_f,
        }
    )


def passive_distance(magnitude, lead_deg, gain):
    """Distance of a reading ``magnitude * exp(j lead)`` outside the disc
    ``|w - g/2| <= g/2`` (0 inside), ``g`` the reading's gain.

    Behind a series resistance ``R`` a core of impedance ``Z`` gives ``w = g Z/(R + Z)``, and
    ``Re Z >= 0`` (a passive element) maps to that disc. For a hysteretic core in the exact
    circuit the same holds of the fundamental: the power the source delivers at the
    fundamental is at least the resistor's share, ``1 - Re(w/g) >= |1 - w/g|^2``, whatever the
    loop. A reading outside the disc is one no passive core gives: its distance bounds how
    close any law can come to it. Broadcasts.
    """
    w = np.asarray(magnitude, float) * np.exp(1j * np.radians(np.asarray(lead_deg, float)))
    g = np.asarray(gain, float)
    return np.maximum(np.abs(w - g / 2) - g / 2, 0.0)
