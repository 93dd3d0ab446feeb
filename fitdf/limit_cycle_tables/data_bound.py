"""The critical gains the Appendix B rows themselves imply in the loop of Fig 5.12, no law fitted.

Harmonic balance closes the loop where ``1 + K N(A) G(j omega) = 0``: ``K`` real and positive
needs ``arg G(j omega) = -pi - arg N`` and then ``K = 1 / (|N| |G(j omega)|)``. Each measured
row ``D`` (its input ``A``, frequency ``f``) is such an ``N``: taken as the core's DF at the
frequency where it balances the printed plant, it sets the gain at which a cycle of amplitude
``A`` would close (:func:`row_balance_gains`). The smallest of these over a frequency's rows is
the critical gain that frequency's rows imply (:func:`data_implied_critical_gains`): any law
that reproduces those rows has a critical gain near it, whatever its form.

The rows are measured at 3 c/s and above; the balance lies near the plant's phase crossover
(about 3 rad/s, 0.5 c/s) -- below every row, so each row is used at a frequency it was not
measured at. Where a table's implied gains do not change with its rows' frequency (the 0-ohm
tables), the rows bound what any law can predict; where they rise as the frequency falls
(600 ohm: the source impedance divides more of a smaller winding impedance), the critical
gain at 0.5 c/s is the law's extrapolation and the rows only say which way it moves.
"""

from __future__ import annotations

import numpy as np

from fitdf.loop.plant import as_loop_plant

__all__ = ["row_balance_gains", "data_implied_critical_gains", "BALANCE_GRID"]

#: Angular frequencies (rad/s) on which the plant's unwrapped phase is tabulated and
#: interpolated for each row's balance frequency: 1e-3 to 1e3, 3e-4 apart in log10 (the
#: interpolated gain within 1e-6 of a root finder's, ``tests/test_thesis_limit_cycles.py``).
BALANCE_GRID = np.logspace(-3.0, 3.0, 20_001)


def row_balance_gains(measured, plant, time_scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Each row's balance frequency (rad/s) and the loop gain at which it closes the loop.

    Parameters
    ----------
    measured : array of complex
        Measured DFs (phase lead positive).
    plant : str or Plant
        The linear part, ``K`` its gain (:func:`fitdf.loop.plant.as_loop_plant`); its phase
        must fall monotonically through ``-pi - arg D`` (as the thesis's three lags do).
    time_scale : float
        Run the plant as ``G(s / alpha)``.

    Returns
    -------
    omega, gain : ndarray
        NaN for a row whose phase the plant never reaches.
    """
    lp = as_loop_plant(plant, time_scale)
    G = lp.response(BALANCE_GRID, [1.0])[0]
    phase = np.unwrap(np.angle(G))
    if np.any(np.diff(phase) > 0):
        raise ValueError("row_balance_gains: the plant's phase does not fall monotonically")
    target = -np.pi - np.angle(np.asarray(measured, complex))
    # np.interp needs rising abscissae: the phase falls, so interpolate on its negative
    log_w = np.interp(-target, -phase, np.log(BALANCE_GRID), left=np.nan, right=np.nan)
    omega = np.exp(log_w)
    G_at = np.interp(log_w, np.log(BALANCE_GRID), np.abs(G), left=np.nan, right=np.nan)
    return omega, 1.0 / (np.abs(measured) * G_at)


def data_implied_critical_gains(data, plant, time_scale: float = 1.0) -> dict:
    """The critical gain a table's rows imply, frequency by frequency (no law fitted).

    Parameters
    ----------
    data : FitData
        The table's rows (``measured``, ``amplitude``, ``frequency``).
    plant, time_scale
        As :func:`row_balance_gains`.

    Returns
    -------
    dict
        ``by_frequency``: for each measured frequency (c/s, rising) the smallest balance gain
        of its rows (``critical_gain``), that row's ``input_v``, ``df`` and
        ``phase_lead_deg``, and its balance frequency ``omega_rad_s``; ``lowest_frequency_hz``
        and ``critical_gain`` at it (the rows nearest the loop's frequency); ``rise``: that
        gain over the gain at the highest measured frequency.
    """
    omega, gain = row_balance_gains(data.measured, plant, time_scale)
    rows = []
    for f in np.unique(data.frequency):
        at = np.flatnonzero((data.frequency == f) & np.isfinite(gain))
        if at.size == 0:
            continue
        i = at[np.argmin(gain[at])]
        rows.append(
            {
                "frequency_hz": float(f),
                "critical_gain": float(gain[i]),
                "input_v": float(data.amplitude[i]),
                "df": float(abs(data.measured[i])),
                "phase_lead_deg": float(np.degrees(np.angle(data.measured[i]))),
                "omega_rad_s": float(omega[i]),
            }
        )
    gains = [r["critical_gain"] for r in rows]
    return {
        "by_frequency": rows,
        "lowest_frequency_hz": rows[0]["frequency_hz"] if rows else None,
        "critical_gain": gains[0] if rows else None,
        "rise": gains[0] / gains[-1] if rows else None,
    }
