"""The priors of a posterior, described in physical units.

Both samplers put the same prior on a fit (:mod:`fitdf.inference.mcmc`,
:mod:`fitdf.inference.nested`): each parameter uniform on its box in its internal coordinate
(log-uniform in natural units for a log-scaled parameter), or, for a parameter with a
Gaussian prior in ``problem.priors`` (the series resistance's log-normal,
:mod:`fitdf.chains.series_resistance`), that normal truncated to the box; and the two noise
scales log-uniform on :data:`fitdf.inference.noise.NOISE_BOUNDS`. This module states them:
:func:`prior_description` (the parameters), :func:`noise_prior_description` and
:func:`noise_priors_text` (the noise scales), as a result's ``info`` and its InferenceData
(:meth:`fitdf.inference.results.PosteriorResult.to_inference_data`) give them.
"""

from __future__ import annotations

import numpy as np

from fitdf.inference.noise import NOISE_BOUNDS, NOISE_NAMES
from fitdf.inference.noise_models import PARAMETER_UNITS

__all__ = [
    "prior_description",
    "noise_prior_description",
    "noise_priors_text",
    "noise_law_prior_description",
    "noise_law_priors_text",
    "NOISE_UNITS",
]

#: The noise scales' units (the magnitude's is that of the DF, V/V).
NOISE_UNITS = {"sigma_magnitude": "-", "sigma_phase_deg": "deg"}


def prior_description(specs, priors: dict) -> dict:
    """Each parameter's prior in its natural units: distribution, bounds, unit (and the
    median and width of a truncated log-normal or the mean and width of a normal).

    ``specs``: the free parameters' :class:`~fitdf.params.ParamSpec`; ``priors``: name ->
    ``(centre, sigma)`` of the Gaussian priors in internal coordinates
    (:attr:`fitdf.inference.problem.FitProblem.priors`).
    """
    out = {}
    for s in specs:
        rec = {"bounds": [float(s.bounds[0]), float(s.bounds[1])], "unit": s.unit_label}
        if s.name in priors:
            centre, sigma = (float(v) for v in priors[s.name])
            if s.log:
                rec["distribution"] = "log-normal truncated to the bounds"
                rec["median"] = float(10.0**centre)
                rec["sigma_ln"] = float(sigma * np.log(10.0))
            else:
                rec["distribution"] = "normal truncated to the bounds"
                rec["mean"] = centre
                rec["sigma"] = sigma
        else:
            rec["distribution"] = "log-uniform" if s.log else "uniform"
        out[s.name] = {"distribution": rec.pop("distribution"), **rec}
    return out


def noise_prior_description() -> dict:
    """The two noise scales' priors (integrated out of the likelihood), as
    :func:`prior_description` gives the parameters'."""
    return _log_uniform(NOISE_NAMES, NOISE_BOUNDS, NOISE_UNITS, integrated_out=True)


def _log_uniform(names, log10_bounds, units, integrated_out: bool) -> dict:
    """Log-uniform priors of ``names`` on their ``log10`` boxes, as :func:`prior_description`
    describes a parameter's."""
    return {
        name: {
            "distribution": "log-uniform",
            "bounds": [float(10.0**lo), float(10.0**hi)],
            "unit": units[name],
            "integrated_out": integrated_out,
        }
        for name, (lo, hi) in zip(names, log10_bounds)
    }


def noise_priors_text() -> str:
    """The noise scales' priors in one line, from :data:`~fitdf.inference.noise.NOISE_BOUNDS`:
    ``"log-uniform: sigma_magnitude 0.001..0.3, sigma_phase 0.1..50 deg"``."""
    (m_lo, m_hi), (p_lo, p_hi) = 10.0**NOISE_BOUNDS
    return f"log-uniform: sigma_magnitude {m_lo:g}..{m_hi:g}, sigma_phase {p_lo:g}..{p_hi:g} deg"


def noise_law_prior_description(law) -> dict:
    """The priors of a fitted noise law's parameters (sampled with the law's,
    :mod:`fitdf.inference.noise_models`): log-uniform on :attr:`NoiseLaw.bounds`."""
    return _log_uniform(law.names, law.bounds, PARAMETER_UNITS, integrated_out=False)


def noise_law_priors_text(law) -> str:
    """A fitted noise law's priors in one line: ``"noise law reading, log-uniform: s_m
    0.001..0.3, s_p_deg 0.1..50 deg, ..."``."""
    parts = []
    for name, (lo, hi) in zip(law.names, 10.0**law.bounds):
        unit = PARAMETER_UNITS[name]
        parts.append(f"{name} {lo:g}..{hi:g}" + ("" if unit == "-" else f" {unit}"))
    return f"noise law {law.name}, log-uniform: " + ", ".join(parts)
