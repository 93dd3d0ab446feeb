"""Goodness-of-fit numbers, computed in one place and documented once.

With ``r`` the weighted residual vector (length ``N = 2 n`` for ``n`` rows: magnitude and
phase parts, see :mod:`fitdf.inference.problem`) and ``k`` fitted parameters:

* ``chi2 = sum(r**2)`` with the printed-precision noise scales, ``redchi = chi2 / (N - k)``;
* ``aic = N ln(chi2 / N) + 2 k`` (the noise scale profiled out, lmfit's convention),
  ``aicc = aic + 2 k (k + 1) / (N - k - 1)``, ``bic = N ln(chi2 / N) + k ln N``.
  Only differences between models fitted to the *same rows* mean anything.

The unweighted RMS residuals are reported alongside because they are what a user can
read off a plot: complex ``|M - D|``, magnitude ``|M| - |D|`` and phase ``arg M - arg D``
in degrees (rows with ``D = 0`` have no phase and are left out of the phase RMS).
"""

from __future__ import annotations

import numpy as np

__all__ = ["residual_metrics", "information_criteria", "phase_difference_deg"]


def phase_difference_deg(predicted, measured):
    """Wrapped ``arg(predicted) - arg(measured)`` in degrees, in (-180, 180]."""
    d = np.angle(predicted * np.conj(measured), deg=True)
    return np.where(d <= -180.0, d + 360.0, d)


def residual_metrics(predicted, measured) -> dict:
    """RMS complex, magnitude and phase residuals of one prediction."""
    predicted = np.asarray(predicted)
    measured = np.asarray(measured)
    has_phase = np.abs(measured) > 0
    phase = phase_difference_deg(predicted, measured)[has_phase]
    return {
        "rms_complex": float(np.sqrt(np.mean(np.abs(predicted - measured) ** 2))),
        "rms_magnitude": float(np.sqrt(np.mean((np.abs(predicted) - np.abs(measured)) ** 2))),
        "rms_phase_deg": float(np.sqrt(np.mean(phase**2))) if phase.size else float("nan"),
    }


def information_criteria(weighted_residuals, n_params: int) -> dict:
    """chi-square, reduced chi-square, AIC, AICc and BIC (formulas in the module docstring)."""
    r = np.asarray(weighted_residuals, float)
    N, k = r.size, int(n_params)
    chi2 = float(np.sum(r**2))
    base = N * np.log(max(chi2, 1e-300) / N)
    aic = base + 2 * k
    aicc = aic + (2 * k * (k + 1) / (N - k - 1) if N - k - 1 > 0 else np.inf)
    return {
        "n_residuals": N,
        "chi2": chi2,
        "redchi": chi2 / (N - k) if N > k else float("nan"),
        "aic": float(aic),
        "aicc": float(aicc),
        "bic": float(base + k * np.log(N)),
    }
