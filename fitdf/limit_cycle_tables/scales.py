"""The analog computer's unprinted scalings, estimated from Tables 5.1/5.2 (thesis V.6).

The loop of Fig 5.12 was run on an analog computer whose time scale and whose gain per
unit of the printed "system gain" the thesis does not state. If the computer ran the plant
``alpha`` times faster than written, ``G(s / alpha)``, and the loop gain is ``beta`` times
the system gain, a measured cycle ``(K, A, omega)`` satisfies harmonic balance
``beta K G0(j omega / alpha) N(A, omega) = -1``. :func:`estimate_thesis_scales` solves that
for one ``(alpha, beta)`` over a set of rows; :func:`held_out_scales` fits them on three
blocks of the tables and leaves the fourth to be predicted, :func:`per_block_scales` on each
block alone (in-sample: the scales that block would need, a measure of how far one pair is
from fitting all blocks).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar

from fitdf.errors import OptionError
from fitdf.loop.plant import as_loop_plant

__all__ = [
    "THESIS_PLANT",
    "THESIS_BLOCKS",
    "block_tables",
    "estimate_thesis_scales",
    "held_out_scales",
    "per_block_scales",
]

#: The plant of the analog-computer study (thesis V.6): amplidyne + generator.
THESIS_PLANT = "K/((1+s)(1+0.25s)(1+1.1s))"
#: Appendix B table fitted for each (core, source impedance) block of Tables 5.1/5.2.
THESIS_BLOCKS = {
    ("permalloy", 0.0): "B.1",
    ("permalloy", 600.0): "B.3",
    ("deltamax", 0.0): "B.2",
    ("deltamax", 600.0): "B.5",
}


def block_tables(rows):
    """The Appendix B table of each row of Tables 5.1/5.2 (its block's name), as an array."""
    return np.array(
        [
            THESIS_BLOCKS[(c, float(r))]
            for c, r in zip(rows["core"], rows["source_impedance_ohm"], strict=True)
        ],
        dtype=object,
    )


def _balance_terms(rows, fits):
    """``K N(A, omega)`` at the measured cycles (independent of the scalings) and ``omega``."""
    KN, omega = [], []
    keep = np.isfinite(rows[["system_gain", "amplitude_v", "omega_rad_s"]].to_numpy(float)).all(
        axis=1
    )
    if not keep.any():
        raise OptionError("no measured cycle with a finite gain, amplitude and frequency")
    for key, block in rows[keep].groupby(
        ["core", "source_impedance_ohm"]
    ):  # per block, vectorised in rows
        w = block["omega_rad_s"].to_numpy(float)
        N = fits[key].predict(block["amplitude_v"].to_numpy(float), w / (2 * np.pi), key[1])
        KN.append(block["system_gain"].to_numpy(float) * N)
        omega.append(w)
    return np.concatenate(KN), np.concatenate(omega)


def estimate_thesis_scales(rows, fits) -> dict:
    """Time scale ``alpha`` and gain scale ``beta`` from harmonic balance at the measured cycles.

    At a measured cycle ``(K, A, omega)`` harmonic balance requires
    ``beta K G0(j omega / alpha) N(A, omega) = -1``. Its phase involves ``alpha`` only:
    ``alpha`` minimises the squared phase residuals (grid in ``ln alpha`` over
    ``[0.1, 100]``, then a bounded 1-D polish); ``ln beta`` is then the mean of
    ``-ln |K G0 N|``.

    Parameters
    ----------
    rows : pandas.DataFrame
        Measured cycles: ``core``, ``source_impedance_ohm``, ``system_gain``,
        ``amplitude_v``, ``omega_rad_s`` (rows with a non-finite value are left out).
    fits : dict
        ``(core, source_impedance_ohm)`` -> the fitted core (anything with
        ``predict(amplitude, frequency_hz, source_impedance)``).

    Returns
    -------
    dict
        ``alpha``, ``beta``, the RMS residuals left on these rows (``rms_phase_deg``,
        ``rms_magnitude_factor``: in-sample, the fit of the two scales, not a prediction)
        and ``n_rows``.
    """
    lp = as_loop_plant(THESIS_PLANT)
    KN, omega = _balance_terms(rows, fits)

    def residuals(la):
        H = KN * lp.response(omega / np.exp(la), [1.0])[0]
        return np.angle(-H), np.log(np.abs(H))

    def cost(la):
        return float(np.mean(residuals(la)[0] ** 2))

    grid = np.linspace(np.log(0.1), np.log(100.0), 121)
    k = int(np.argmin([cost(la) for la in grid]))  # the phase cost may be multimodal
    res = minimize_scalar(
        cost,
        bounds=(grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]),
        method="bounded",
        options={"xatol": 1e-9},
    )
    ph, lm = residuals(res.x)
    log_beta = -float(np.mean(lm))
    return {
        "alpha": float(np.exp(res.x)),
        "beta": float(np.exp(log_beta)),
        "rms_phase_deg": float(np.degrees(np.sqrt(np.mean(ph**2)))),
        "rms_magnitude_factor": float(np.exp(np.sqrt(np.mean((lm + log_beta) ** 2)))),
        "n_rows": int(ph.size),
    }


def per_block_scales(rows, fits) -> dict:
    """:func:`estimate_thesis_scales` on each block's own rows (in-sample), by table name."""
    names = block_tables(rows)
    return {t: estimate_thesis_scales(rows[names == t], fits) for t in dict.fromkeys(names)}


def held_out_scales(rows, fits) -> dict:
    """Leave one block out: for each block (table name) the scales fitted on the *other*
    blocks' rows, with ``fitted_on`` (their table names), to predict the block left out."""
    names = block_tables(rows)
    out = {}
    for t in dict.fromkeys(names):
        others = [n for n in dict.fromkeys(names) if n != t]
        if not others:
            raise OptionError("leaving one block out needs rows of at least two blocks")
        out[t] = {**estimate_thesis_scales(rows[names != t], fits), "fitted_on": others}
    return out
