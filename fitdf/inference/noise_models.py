"""Measurement-noise laws of the printed tables, chosen by name (``noise=`` of the fitters).

Appendix B prints, per row, the input amplitude ``V_in``, the analyser's first-harmonic
output ``V_out`` and its phase lead; the DF is ``g V_out / V_in`` (``g`` the table's
factor: the turns ratio of Tables B.1, B.2, which the data follow as 3.30 and 4.20, and 1
for B.3-B.5; Chapter V.2, Appendix B footnotes). A reading error ``e`` on the output is a DF
error ``g e / V_in``: it grows as the input falls. A phase read off a small output is
coarser: a noise voltage ``e_p`` beside an output phasor ``V_out`` turns it by
``e_p / V_out`` rad. The laws here (``docs/method/noise.rst``):

``printed`` (the default)
    The fixed scales (:class:`fitdf.data.fitdata.NoiseModel`: 0.01 in magnitude, 1
    degree in phase, a floor of 0.01 on the arc): least squares weighs every row alike and
    profiles one common scale out of AICc (:mod:`fitdf.inference.metrics`).
``constant``
    The two scales fitted (maximum likelihood), the same for every row: magnitude ``s_m``,
    phase ``s_p`` (the arc's scale ``|D_i| s_p``). The samplers' likelihood
    (:mod:`fitdf.inference.noise`) without its arc floor of 0.01, which is not needed where
    the rows without a phase are left out: so it is the ``reading`` law without its reading
    terms, and the two compare as nested laws.
``reading``
    The reading law::

        sigma_mag,i   = sqrt(s_m^2 + (g_i r_m / V_in,i)^2)
        sigma_phase,i = sqrt(s_p^2 + (r_p / V_out,i)^2)        (rad)

    with ``V_out,i = |D_i| V_in,i / g_i``, so the arc's scale ``|D_i| sigma_phase,i`` is
    ``sqrt((|D_i| s_p)^2 + (g_i r_p / V_in,i)^2)``. Four parameters: a magnitude floor
    ``s_m`` (the printed decimals and the calibration), a phase floor ``s_p`` (the dial's
    resolution), and two reading resolutions in volts of output, ``r_m`` of the magnitude
    reading and ``r_p`` of the phase reading.
``student``, ``reading-student``
    The ``constant`` or ``reading`` scales with Student-t errors of ``nu`` degrees of
    freedom instead of Gaussian ones: the robust alternative, in which a few rows far off
    cost little, whatever their input.

Every parameter has a log-uniform prior on the box :attr:`NoiseLaw.bounds`
(:data:`PARAMETER_BOUNDS`). A row whose measured DF is 0 has no phase: only its magnitude
enters the likelihood (no arc term, whose scale would otherwise be pulled to 0).

Least squares under a fitted law (:func:`fitdf.inference.lsq.fit_lsq`) alternates a
weighted least-squares step of the law's parameters at fixed row scales with a
maximum-likelihood step of the noise parameters at fixed residuals; for Student-t the row
weights are those of its expectation-maximisation (``(nu + 1) / (nu + z^2)``), each step an
ascent of the likelihood.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize
from scipy.special import gammaln

from fitdf.errors import OptionError

__all__ = [
    "NOISE_LAWS",
    "DEFAULT_NOISE",
    "PARAMETER_BOUNDS",
    "PARAMETER_UNITS",
    "NoiseLaw",
    "get_noise_law",
    "output_gain",
    "student_logpdf",
]

#: The law of every fit unless another is asked for: the fixed printed-precision scales.
DEFAULT_NOISE = "printed"

#: Box of each noise parameter: ``(lower, upper)`` in its unit, the support of its
#: log-uniform prior. ``s_m``: from a tenth of the finest printed DF digit (0.001) to 0.3,
#: twice the largest magnitude RMS of any law (as the samplers' box,
#: :data:`fitdf.inference.noise.NOISE_BOUNDS`); ``s_p``: 0.1 degree (a fifth of the
#: half-degrees printed) to 50; ``r_m``, ``r_p``: 10 uV (a tenth of the finest printed output
#: digit, 1e-4 V) to 0.1 V (the whole output of a 0.1 V input); ``nu``: 1 (Cauchy) to 100
#: (Gaussian within 1 % in the body).
PARAMETER_BOUNDS = {
    "s_m": (1e-3, 0.3),
    "s_p_deg": (0.1, 50.0),
    "r_m": (1e-5, 0.1),
    "r_p": (1e-5, 0.1),
    "nu": (1.0, 100.0),
}
PARAMETER_UNITS = {"s_m": "-", "s_p_deg": "deg", "r_m": "V", "r_p": "V", "nu": "-"}

#: name -> (reading scales, Student-t errors)
NOISE_LAWS = {
    "printed": (False, False),
    "constant": (False, False),
    "reading": (True, False),
    "student": (False, True),
    "reading-student": (True, True),
}


def student_logpdf(z, nu):
    """``log`` of the standard Student-t density of ``nu`` degrees of freedom at ``z``."""
    z = np.asarray(z, float)
    return (
        gammaln(0.5 * (nu + 1.0))
        - gammaln(0.5 * nu)
        - 0.5 * np.log(nu * np.pi)
        - 0.5 * (nu + 1.0) * np.log1p(z * z / nu)
    )


def _gaussian_logpdf(z):
    return -0.5 * z * z - 0.5 * np.log(2.0 * np.pi)


def output_gain(data) -> np.ndarray:
    """``g_i`` of each row, the factor from output volts to DF (module docstring): per table,
    the median of ``|D| V_in / V_out`` over its rows that print an output (the factor the
    data follow, as :func:`fitdf.data.audit.block_factors` finds it); 1 where no row
    of the table prints one (a user's file without ``h1_output_v``)."""
    g = np.ones(data.n)
    if "h1_output_v" not in data.rows:
        return g
    out = data.rows["h1_output_v"].to_numpy(float)
    ratio = np.abs(data.measured) * data.amplitude / np.where(out > 0, out, np.nan)
    for table in data.groups:
        rows = data.group == table
        known = ratio[rows][np.isfinite(ratio[rows]) & (ratio[rows] > 0)]
        if known.size:
            g[rows] = float(np.median(known))
    return g


@dataclass(frozen=True)
class NoiseLaw:
    """One noise law of the module docstring, by :data:`NOISE_LAWS` name."""

    name: str

    @property
    def reading(self) -> bool:
        return NOISE_LAWS[self.name][0]

    @property
    def student(self) -> bool:
        return NOISE_LAWS[self.name][1]

    @property
    def fitted(self) -> bool:
        """Whether the law has parameters to fit (all but ``printed``)."""
        return self.name != "printed"

    @property
    def names(self) -> tuple[str, ...]:
        if not self.fitted:
            return ()
        out = ("s_m", "s_p_deg") + (("r_m", "r_p") if self.reading else ())
        return out + (("nu",) if self.student else ())

    @property
    def bounds(self) -> np.ndarray:
        """``(k, 2)`` log10 bounds of the parameters (:data:`PARAMETER_BOUNDS`)."""
        return np.log10(np.array([PARAMETER_BOUNDS[n] for n in self.names], float).reshape(-1, 2))

    def start(self) -> np.ndarray:
        """log10 start of the noise fit: the printed precision, reading resolutions of 1 mV,
        ``nu = 5``."""
        typical = {"s_m": 0.01, "s_p_deg": 1.0, "r_m": 1e-3, "r_p": 1e-3, "nu": 5.0}
        return np.log10([typical[n] for n in self.names])

    # ------------------------------------------------------------------ per-row scales
    @staticmethod
    def context(data) -> dict:
        """The row quantities the scales need, computed once per data set."""
        absD = np.abs(data.measured)
        return {
            "abs_d": absD,
            "input_v": np.asarray(data.amplitude, float),
            "gain": output_gain(data),
            "has_phase": absD > 0,
        }

    def _values(self, log_theta) -> dict:
        """Name -> natural value of ``log10`` parameters ``(..., k)``, each ``(..., 1)`` so
        that it broadcasts against rows (a batch of parameter vectors, a batch of rows)."""
        x = np.asarray(log_theta, float)
        return {n: 10.0 ** x[..., j][..., None] for j, n in enumerate(self.names)}

    def scales(self, log_theta, ctx):
        """Magnitude and arc scales per row (DF units) at ``log10`` parameters ``(k,)`` or a
        batch ``(..., k)``: ``(n,)`` or ``(..., n)`` each."""
        p = self._values(log_theta)
        absD = ctx["abs_d"]
        s_p = np.deg2rad(p["s_p_deg"])
        if self.reading:
            lever = ctx["gain"] / ctx["input_v"]  # DF per volt of output
            sm = np.hypot(p["s_m"], lever * p["r_m"])
            st = np.hypot(absD * s_p, lever * p["r_p"])
        else:
            sm = p["s_m"] * np.ones(absD.shape)
            st = absD * s_p
        return sm, st

    def pointwise(self, log_theta, radial, tang, ctx):
        """Log-likelihood per row of residuals ``(..., n)`` (magnitude, arc): ``(..., n)``;
        ``log_theta`` one vector ``(k,)`` or one per residual vector ``(..., k)``."""
        sm, st = self.scales(log_theta, ctx)
        zm, zt = radial / sm, tang / st
        if self.student:
            nu = self._values(log_theta)["nu"]
            lm, lt = student_logpdf(zm, nu), student_logpdf(zt, nu)
        else:
            lm, lt = _gaussian_logpdf(zm), _gaussian_logpdf(zt)
        return lm - np.log(sm) + np.where(ctx["has_phase"], lt - np.log(st), 0.0)

    def n_terms(self, ctx) -> int:
        """Numbers the likelihood counts: every magnitude and every defined phase."""
        return int(ctx["abs_d"].size + np.sum(ctx["has_phase"]))

    def weights_scales(self, log_theta, radial, tang, ctx):
        """Row scales of the next weighted least-squares step: the law's scales, divided by
        ``sqrt(w)``, ``w = (nu + 1) / (nu + z^2)`` for Student-t (its EM weights)."""
        sm, st = self.scales(log_theta, ctx)
        if self.student:
            nu = self._values(log_theta)["nu"]
            sm = sm / np.sqrt((nu + 1.0) / (nu + (radial / sm) ** 2))
            st = st / np.sqrt((nu + 1.0) / (nu + (tang / st) ** 2))
        return sm, st

    def fit(self, radial, tang, ctx, start=None) -> tuple[np.ndarray, float]:
        """Maximum-likelihood ``log10`` parameters for fixed residuals, within the box:
        ``(log_theta, log_likelihood)``. Bounded quasi-Newton from ``start`` and from
        :meth:`start`, the better kept."""
        lo, hi = self.bounds.T

        def cost(u):
            value = -float(np.sum(self.pointwise(u, radial, tang, ctx)))
            return value if np.isfinite(value) else 1e300

        best = None
        starts = [self.start()] if start is None else [np.asarray(start, float), self.start()]
        for s in starts:
            out = minimize(cost, np.clip(s, lo, hi), method="L-BFGS-B", bounds=list(zip(lo, hi)))
            if best is None or out.fun < best.fun:
                best = out
        return np.asarray(best.x, float), -float(best.fun)

    def criteria(self, log_likelihood: float, n_params: int, ctx) -> dict:
        """AIC, AICc and BIC of a maximised (or point-estimate) ``log_likelihood`` under this
        law, counting the law's ``n_params`` and the noise parameters (``k``) over the
        :meth:`n_terms` numbers (``N``): ``AICc = -2 lnL + 2k + 2k(k + 1) / (N - k - 1)``
        (infinite for ``N <= k + 1``), ``BIC = -2 lnL + k ln N``."""
        k, n = n_params + len(self.names), self.n_terms(ctx)
        aic = -2.0 * log_likelihood + 2.0 * k
        return {
            "log_likelihood": float(log_likelihood),
            "n_noise_params": len(self.names),
            "aic": float(aic),
            "aicc": float(aic + (2.0 * k * (k + 1) / (n - k - 1) if n - k - 1 > 0 else np.inf)),
            "bic": float(-2.0 * log_likelihood + k * np.log(n)),
        }

    def natural(self, log_theta) -> dict:
        """Name -> value in its unit (:data:`PARAMETER_UNITS`)."""
        return {n: float(10.0**v) for n, v in zip(self.names, np.asarray(log_theta, float))}

    def on_bound(self, log_theta, tol: float = 1e-3) -> list[str]:
        """Names of the parameters within ``tol`` decades of a bound of their box."""
        lo, hi = self.bounds.T
        x = np.asarray(log_theta, float)
        return [n for n, v, a, b in zip(self.names, x, lo, hi) if v - a < tol or b - v < tol]


def get_noise_law(name) -> NoiseLaw:
    """The :class:`NoiseLaw` of a name in :data:`NOISE_LAWS` (a NoiseLaw passes through)."""
    if isinstance(name, NoiseLaw):
        return name
    if name not in NOISE_LAWS:
        raise OptionError(f"unknown noise law {name!r}; choose one of {', '.join(NOISE_LAWS)}")
    return NoiseLaw(str(name))
