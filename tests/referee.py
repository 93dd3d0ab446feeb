"""Measured describing functions made by a code path independent of the fitter (a helper).

The fitter predicts with the laws' closed-form (or fast) describing functions and the
chain's vectorised solver. :func:`referee_winding_df` computes the same measurement from the
law's definition alone: the numerical referee
(:func:`fitdf.numerical_df.numerical_describing_function`, a Fourier integral of the loop traced
by the law's ascending branch) and a scalar root finder written here
(:func:`scipy.optimize.brentq` on ``I |R + Z(I)| = V``, the ``winding`` chain's circuit).
:func:`reference_backward_euler` integrates the ``voltage`` chain's circuit in time instead
(backward Euler on a dense table of the law's branch, Richardson over two step counts), the
reference of the exact chain for any law.
"""

from __future__ import annotations

import numba
import numpy as np
from scipy.optimize import brentq

from fitdf.models import get_model
from fitdf.numerical_df import numerical_describing_function

#: Samples per period of the referee's Fourier integral: within 4e-5 of the DF and 0.007
#: degree of 2**16 samples on every row of tests/test_recovery_independent.py (the worst:
#: Rayleigh near saturation at 60 ohm), far below the noise (0.005, 0.5 degree) and the
#: printed precision (0.001, 0.1 degree). (2**14 was as good for the test and 30 times
#: slower with multithreaded BLAS.)
REFEREE_POINTS = 2**13


def referee_winding_df(model, theta, V, f, R, gain, n_points=REFEREE_POINTS):
    """``gain Z / (R + Z)`` at the current solving ``I |R + Z(I)| = V``, point by point."""
    law = get_model(model)

    def Z(current):
        N = numerical_describing_function(
            law.ascending_branch, current, f, n_points=n_points, **theta
        )
        return 2j * np.pi * f * complex(N)

    def residual(log_i):
        i = np.exp(log_i)
        return np.log(i * abs(R + Z(i))) - np.log(V)

    upper = np.log(V / R)  # a passive winding only adds impedance: I <= V / R
    lower = upper - 40.0
    log_i = brentq(residual, lower, upper, xtol=1e-13)
    z = Z(np.exp(log_i))
    return gain * z / (R + z)


def referee_row(model, theta, chain, V, f, rs, rng, sigma=(0.005, 0.5), decimals=(3, 1)):
    """One row in the Appendix B schema: the referee's DF at ``V`` volts, ``f`` Hz and ``rs``
    ohm of source impedance (``chain``: ``r_series`` and ``gain``), with Gaussian noise of
    ``sigma`` (magnitude, phase in degrees) and rounded to ``decimals`` (magnitude, phase)."""
    d = referee_winding_df(model, theta, V, f, rs + chain["r_series"], chain["gain"])
    mag = abs(d) + sigma[0] * rng.standard_normal()
    phase = np.angle(d, deg=True) + sigma[1] * rng.standard_normal()
    return {
        "table": "referee",
        "source_impedance_ohm": rs,
        "frequency_hz": f,
        "input_v": V,
        "df_reported": round(max(mag, 0.0), decimals[0]),
        "phase_lead_deg": round(phase, decimals[1]),
    }


@numba.njit
def _backward_euler_half(x, B, V, R, w, t0, n):
    """Rising half period by backward Euler, ``n`` equal steps: ``(i_max, int e sin, int e cos)``."""
    h = np.pi / n
    c = h * R / w
    i, lam, j, Es, Ec = x[0], B[0], 0, 0.0, 0.0
    for k in range(1, n + 1):
        t = t0 + k * h
        rhs = lam + (h / w) * V * np.sin(t)
        if lam + c * i >= rhs:  # the current would fall: its maximum is reached
            break
        while j < x.shape[0] - 2 and B[j + 1] + c * x[j + 1] < rhs:
            j += 1
        f0, f1 = B[j] + c * x[j], B[j + 1] + c * x[j + 1]
        u = (rhs - f0) / (f1 - f0)
        i_new, lam_new = x[j] + u * (x[j + 1] - x[j]), B[j] + u * (B[j + 1] - B[j])
        e = w * (lam_new - lam) / h
        Es += e * np.sin(t) * h
        Ec += e * np.cos(t) * h
        i, lam = i_new, lam_new
    return i, Es, Ec


def reference_backward_euler(model, theta, V, f, R, I_guess, span=0.03):
    """(DF, I_p) of any law: backward Euler on a dense table, Richardson over two step counts."""
    kw = dict(zip(model.param_names(), theta))
    w = 2 * np.pi * f
    out = []
    for n in (1 << 20, 1 << 21):

        def run(I, n=n):
            x = np.linspace(-I, I, 200001)
            B = np.maximum.accumulate(
                np.broadcast_to(model.ascending_branch(x, I, f, **kw), x.shape)
            )
            return _backward_euler_half(x, B, V, R, w, -np.arcsin(min(R * I / V, 1.0)), n)

        lo, hi = I_guess * (1 - span), min(I_guess * (1 + span), V / R)
        I = brentq(lambda I: run(I)[0] - I, lo, hi, xtol=1e-15, rtol=1e-12)
        _, Es, Ec = run(I)
        out.append((2 / np.pi * (Es + 1j * Ec) / V, I))
    (d1, I1), (d2, I2) = out
    return 2 * d2 - d1, 2 * I2 - I1
