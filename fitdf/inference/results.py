"""Fit results: immutable records with parameters, uncertainties, residuals and metrics.

:class:`FitResult` comes from least squares, :class:`PosteriorResult` (a subclass) from a
posterior sampler, emcee's MCMC (``method="mcmc"``) or nautilus's nested sampling
(``method="nested"``, :data:`METHOD_TITLES`); both answer the same questions (``values``,
``intervals``, ``metrics``, ``residuals``, ``predict``, ``summary``, ``to_dict``), so
reports and rankings treat them alike. A posterior also leaves in ArviZ's format,
:meth:`PosteriorResult.to_inference_data`.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from fitdf._json import clean
from fitdf.inference.metrics import phase_difference_deg, residual_metrics
from fitdf.inference.posterior_data import inference_data
from fitdf.inference.presentation import fit_text
from fitdf.params import DIMENSIONLESS

__all__ = ["FitResult", "PosteriorResult", "PointwiseLikelihood", "residual_table", "METHOD_TITLES"]

#: What each ``method`` of a result is, in words.
METHOD_TITLES = {
    "lsq": "least squares",
    "mcmc": "emcee MCMC",
    "nested": "nautilus nested sampling",
}


def residual_table(problem, predicted) -> pd.DataFrame:
    """Per-row measured vs predicted values and residuals."""
    d = problem.data
    keep = [c for c in ("table", "core", "row_in_block") if c in d.rows.columns]
    out = d.rows[keep].copy() if keep else pd.DataFrame(index=d.rows.index)
    out["source_impedance_ohm"] = d.source_impedance
    out["frequency_hz"] = d.frequency
    out["input_v"] = d.amplitude
    out["df_measured"] = np.abs(d.measured)
    out["phase_lead_measured_deg"] = d.rows["phase_lead_deg"].to_numpy(float)
    out["df_predicted"] = np.abs(predicted)
    out["phase_lead_predicted_deg"] = np.angle(predicted, deg=True)
    out["magnitude_residual"] = out["df_predicted"] - out["df_measured"]
    out["phase_residual_deg"] = np.where(
        np.abs(d.measured) > 0, phase_difference_deg(predicted, d.measured), np.nan
    )
    out["complex_residual"] = np.abs(predicted - d.measured)
    return out.reset_index(drop=True)


@dataclass(frozen=True)
class FitResult:
    """The outcome of one fit (least squares).

    Attributes
    ----------
    model, chain, method, label : str
    values : dict
        Best-fit natural parameter values (fixed ones included).
    stderr : dict
        Standard errors (natural units, delta method for log-scaled parameters); NaN
        where the covariance does not exist.
    intervals : dict
        name -> ``{"p2.5", "p16", "p50", "p84", "p97.5"}`` (least squares: Gaussian in
        the internal coordinate, so asymmetric for log-scaled parameters).
    correlations : pandas.DataFrame
    metrics : dict
        See :mod:`fitdf.inference.metrics`.
    residuals : pandas.DataFrame
        One row per data row used.
    warnings : list of str
    info : dict
        Optimiser details: starts, which start won, how many agreed, seed, settings.
    """

    model: str
    chain: str
    method: str
    label: str
    values: dict
    stderr: dict
    intervals: dict
    correlations: pd.DataFrame
    metrics: dict
    residuals: pd.DataFrame
    warnings: list
    info: dict
    problem: Any = field(repr=False, compare=False)
    internal: np.ndarray = field(repr=False, compare=False)
    #: Material constants and the Appendix A check (:func:`fitdf.inference.material.material_record`),
    #: None without a core geometry.
    material: dict | None = field(default=None, kw_only=True, compare=False)

    @property
    def n_params(self) -> int:
        return self.problem.ndim

    @property
    def method_title(self) -> str:
        """The method in words (:data:`METHOD_TITLES`): "least squares", "emcee MCMC" or
        "nautilus nested sampling"."""
        return METHOD_TITLES.get(self.method, self.method)

    def predict(self, amplitude, frequency, source_impedance=0.0, table=None):
        """Predicted measured DF (complex) at arbitrary points, with the best-fit values.

        ``table`` picks the calibration gain of that table in a joint fit (default: the first).
        """
        amplitude, frequency, source_impedance = np.broadcast_arrays(
            np.asarray(amplitude, float),
            np.asarray(frequency, float),
            np.asarray(source_impedance, float),
        )
        group = np.full(
            amplitude.shape, table if table is not None else self.problem.data.groups[0]
        )
        values = {k: np.asarray(v) for k, v in self.values.items()}
        return self.problem.predict_natural(
            values, amplitude.ravel(), frequency.ravel(), source_impedance.ravel(), group.ravel()
        ).reshape(amplitude.shape)

    def describing_function(self, amplitude, frequency=0.0):
        """The fitted core's own ``N`` (model only, no chain) at model-input amplitudes."""
        theta = np.array([self.values[p.name] for p in self.problem.model.params])
        return self.problem.model.evaluate(
            np.atleast_1d(amplitude), np.atleast_1d(frequency), theta
        )

    def parameter_table(self) -> pd.DataFrame:
        specs = {s.name: s for s in self.problem.all_specs}
        rows = []
        for name, value in self.values.items():
            s = specs[name]
            iv = self.intervals.get(name, {})
            rows.append(
                {
                    "parameter": name,
                    "value": value,
                    "stderr": self.stderr.get(name, np.nan),
                    "p2.5": iv.get("p2.5", np.nan),
                    "p16": iv.get("p16", np.nan),
                    "p84": iv.get("p84", np.nan),
                    "p97.5": iv.get("p97.5", np.nan),
                    "unit": s.unit,
                    "fixed": name in self.problem.fixed,
                    "lower": s.bounds[0],
                    "upper": s.bounds[1],
                }
            )
        return pd.DataFrame(rows)

    def metrics_by_frequency(self) -> pd.DataFrame:
        r = self.residuals
        rows = []
        for (rs, f), g in r.groupby(["source_impedance_ohm", "frequency_hz"]):
            pred = g["df_predicted"] * np.exp(1j * np.deg2rad(g["phase_lead_predicted_deg"]))
            meas = g["df_measured"] * np.exp(1j * np.deg2rad(g["phase_lead_measured_deg"]))
            rows.append(
                {
                    "source_impedance_ohm": rs,
                    "frequency_hz": f,
                    "n": len(g),
                    **residual_metrics(pred.to_numpy(), meas.to_numpy()),
                }
            )
        return pd.DataFrame(rows)

    def summary(self, width: int = 100) -> str:
        """The fit as text, no line longer than ``width``: metrics, then each parameter.

        Each parameter is a line of value, unit (``-``: dimensionless), 68% interval
        (least squares: Gaussian in the optimiser's coordinate; a posterior: its 16th to
        84th percentile) and whether it was held fixed, followed by an indented line
        saying what it means (wrapped at ``width``).
        """

        def _number(value) -> str:
            return f"{value:.4g}" if np.isfinite(value) else "n/a"

        m = self.metrics
        head = (
            f"{self.model} + {self.chain} chain ({self.method}) on {self.label}: "
            f"{m['n_points']} rows, {m['n_params']} parameters"
        )
        lines = [
            *textwrap.wrap(head, width, subsequent_indent="  ", break_on_hyphens=False),
            f"  RMS complex {m['rms_complex']:.4f}  magnitude {m['rms_magnitude']:.4f}  "
            f"phase {m['rms_phase_deg']:.2f} deg  redchi {m['redchi']:.3g}  AICc {m['aicc']:.1f}",
        ]
        specs = {s.name: s for s in self.problem.all_specs}
        rows = []
        for _, row in self.parameter_table().iterrows():
            spec = specs[row["parameter"]]
            interval = (
                "fixed" if row["fixed"] else f"{_number(row['p16'])} .. {_number(row['p84'])}"
            )
            rows.append((row["parameter"], _number(row["value"]), spec.unit_label, interval, spec))
        head = ("parameter", "value", "unit", "68% interval")
        w = [max(len(head[i]), *(len(r[i]) for r in rows)) for i in range(3)] if rows else []
        if rows:
            lines.append(f"  {head[0]:<{w[0]}}  {head[1]:>{w[1]}}  {head[2]:<{w[2]}}  {head[3]}")
        for name, value, unit, interval, spec in rows:
            lines.append(f"  {name:<{w[0]}}  {value:>{w[1]}}  {unit:<{w[2]}}  {interval}")
            meaning = spec.description or "(no description)"
            lines += textwrap.wrap(
                meaning, width, initial_indent=" " * 6, subsequent_indent=" " * 6
            )
        if any(r[2] == DIMENSIONLESS for r in rows):
            lines.append(f"  (unit {DIMENSIONLESS}: dimensionless)")
        noise = self.info.get("noise_law")
        if noise and noise.get("sampled"):  # nested sampling: the point estimate's, 68 %
            iv = noise["intervals"]
            fitted = "  ".join(
                f"{k} {v:.3g} ({iv[k]['p16']:.3g} .. {iv[k]['p84']:.3g})"
                for k, v in noise["values"].items()
            )
            lines += textwrap.wrap(
                f"noise law {noise['name']} (sampled; at the point estimate, log-likelihood "
                f"{m['log_likelihood']:.2f}; 68% intervals): {fitted}",
                width,
                initial_indent="  ",
                subsequent_indent="    ",
            )
        elif noise:
            fitted = "  ".join(f"{k} {v:.3g}" for k, v in noise["values"].items())
            lines += textwrap.wrap(
                f"noise law {noise['name']} (fitted; log-likelihood "
                f"{m['log_likelihood']:.2f}): {fitted}",
                width,
                initial_indent="  ",
                subsequent_indent="    ",
            )
        for w_ in self.warnings:
            lines += textwrap.wrap(
                f"warning: {w_}", width, initial_indent="  ", subsequent_indent="    "
            )
        return "\n".join(lines)

    def text(self, width: int = 100) -> str:
        """:meth:`summary`, the material constants and, for a posterior, its convergence
        check (:func:`fitdf.inference.presentation.fit_text`)."""
        return fit_text(self, width)

    def table(self) -> pd.DataFrame:
        """The parameters: :meth:`parameter_table`."""
        return self.parameter_table()

    def __str__(self):
        return self.text()

    def to_dict(self) -> dict:
        """Plain-Python (JSON-ready) record of the result."""
        return clean(
            {
                "model": self.model,
                "chain": self.chain,
                "method": self.method,
                "label": self.label,
                "parameters": self.parameter_table().to_dict(orient="records"),
                "correlations": self.correlations.to_dict(),
                "metrics": self.metrics,
                "warnings": list(self.warnings),
                "info": self.info,
                "rows_used": self.residuals.to_dict(orient="records"),
                **self._material_fields(),
            }
        )

    def _material_fields(self) -> dict:
        if self.material is None:
            return {}
        out = {"material": self.material["constants"]}
        if self.material.get("appendix_a_check") is not None:
            out["appendix_a_check"] = self.material["appendix_a_check"]
        if self.material.get("caveat"):
            out["material_caveat"] = self.material["caveat"]
        return out


@dataclass(frozen=True)
class PointwiseLikelihood:
    """The draws PSIS-LOO and WAIC were computed on, with their pointwise log-likelihood.

    Arrays are in the layout of :attr:`PosteriorResult.samples`, ``(draw, chain, ...)``
    (nested sampling: one chain of equal-weight draws).

    Attributes
    ----------
    draws : numpy.ndarray
        Internal parameter vectors ``(draw, chain, P)``.
    noise : numpy.ndarray
        The two noise scales of each draw, ``(draw, chain, 2)``: ``sigma_magnitude`` and
        ``sigma_phase_deg`` (sampled with it, or drawn given it where they were integrated
        out); under a fitted noise law sampled by nested sampling, its ``k`` parameters
        (:attr:`~fitdf.inference.noise_models.NoiseLaw.names`, natural units).
    log_likelihood : numpy.ndarray
        The Gaussian log-likelihood of each data row, ``(draw, chain, n_rows)``
        (:meth:`fitdf.inference.problem.FitProblem.pointwise_loglike`), or the noise law's
        (:meth:`~fitdf.inference.noise_models.NoiseLaw.pointwise`).
    reff : float
        The relative efficiency of the draws PSIS used (ArviZ's: 1 for one chain, else the
        mean ESS of the sampler's coordinates over the number of draws,
        :func:`fitdf.inference.posterior.relative_efficiency`).
    description : str
        Which draws of the posterior these are.
    """

    draws: np.ndarray = field(repr=False)
    noise: np.ndarray = field(repr=False)
    log_likelihood: np.ndarray = field(repr=False)
    reff: float = 1.0
    description: str = ""


@dataclass(frozen=True)
class PosteriorResult(FitResult):
    """A posterior: the FitResult fields from the posterior's draws, plus the draws and the
    sampler's diagnostics. ``method`` says which sampler drew it (:data:`METHOD_TITLES`).

    ``values`` (and the residuals and metrics) are the highest-posterior draw; the
    intervals and ``stderr`` come from the posterior's draws (nested sampling: its
    weighted draws).

    ``samples`` are internal coordinates of shape ``(n_draws, n_chains, P)``: emcee's
    walkers after burn-in and thinning, or nested sampling's draws resampled to equal
    weights (one chain); ``noise_samples`` the noise scales of the draws that have them;
    ``pointwise`` the draws of PSIS-LOO and WAIC with their pointwise log-likelihood
    (:class:`PointwiseLikelihood`). :meth:`to_inference_data` gives them in physical
    units, as ArviZ's InferenceData.
    """

    samples: np.ndarray = field(default=None, repr=False, compare=False)
    noise_samples: np.ndarray = field(default=None, repr=False, compare=False)
    diagnostics: dict = field(default_factory=dict)
    pointwise: PointwiseLikelihood | None = field(default=None, repr=False, compare=False)

    def to_inference_data(self):
        """This posterior as ArviZ's ``InferenceData``, in physical units.

        The draws of PSIS-LOO and WAIC (:attr:`pointwise`) with their pointwise
        log-likelihood, the data rows, and the fit's evidence, LOO and prior in its
        attributes: :func:`fitdf.inference.posterior_data.inference_data` says what each
        group holds and how ``arviz.loo`` reproduces the LOO-IC reported here.
        """
        return inference_data(self)

    def flat_internal(self, max_draws: int | None = None, seed: int = 0):
        flat = self.samples.reshape(-1, self.samples.shape[-1])
        if max_draws is not None and flat.shape[0] > max_draws:
            idx = np.random.default_rng(seed).choice(flat.shape[0], max_draws, replace=False)
            flat = flat[np.sort(idx)]
        return flat

    def predictive_band(
        self,
        amplitude,
        frequency,
        source_impedance=0.0,
        table=None,
        quantiles=(2.5, 16, 50, 84, 97.5),
        max_draws=400,
        seed=0,
    ) -> dict:
        """Posterior predictive bands of ``|DF|`` and phase lead (deg) at the given points."""
        amplitude, frequency, source_impedance = np.broadcast_arrays(
            np.asarray(amplitude, float),
            np.asarray(frequency, float),
            np.asarray(source_impedance, float),
        )
        flat = self.flat_internal(max_draws, seed)
        group = np.full(amplitude.size, table if table is not None else self.problem.data.groups[0])
        pred = self.problem.predict_natural(
            self.problem.full_natural(flat),
            amplitude.ravel(),
            frequency.ravel(),
            source_impedance.ravel(),
            group,
        )
        mag = np.percentile(np.abs(pred), quantiles, axis=0)
        phase = np.percentile(np.angle(pred, deg=True), quantiles, axis=0)
        return {
            "quantiles": list(quantiles),
            "magnitude": mag.reshape((len(quantiles),) + amplitude.shape),
            "phase_deg": phase.reshape((len(quantiles),) + amplitude.shape),
        }

    def to_dict(self) -> dict:
        d = super().to_dict()
        d["diagnostics"] = clean(self.diagnostics)
        return d
