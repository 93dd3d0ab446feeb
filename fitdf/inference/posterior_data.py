"""A posterior in ArviZ's format: InferenceData, and netCDF files of it.

:func:`inference_data` gives a :class:`~fitdf.inference.results.PosteriorResult` as ArviZ's
``InferenceData`` (what :meth:`~fitdf.inference.results.PosteriorResult.to_inference_data`
returns); :func:`write_posteriors` writes one netCDF file per law (``fitdf fit
--posterior-out``), named by :func:`posterior_filename`. ArviZ writes netCDF through
h5netcdf, one of its own dependencies.

Notes
-----
**The groups.**

``posterior``
    The draws PSIS-LOO and WAIC were computed on (the result's
    :attr:`~fitdf.inference.results.PosteriorResult.pointwise`), in physical units: each
    free parameter under the name the fit reports (its ``unit``, ``description`` and prior
    in the variable's attributes) and the two noise scales ``sigma_magnitude`` and
    ``sigma_phase_deg`` (nested sampling under a fitted noise law: that law's parameters,
    :mod:`fitdf.inference.noise_models`). emcee's independent chains are ArviZ's chains; nested sampling
    gives one chain of equal-weight draws (nautilus's weighted draws resampled
    systematically with the fit's seed, :func:`fitdf.inference.nested.systematic_resample`).
``log_likelihood``
    ``df``: the Gaussian log-likelihood of each data row (dimension ``row``) at each draw.
``observed_data``
    The measured DF per row: ``df_measured`` (V/V) and ``phase_lead_measured_deg``.
``constant_data``
    Where each row was measured: ``input_v`` (V peak), ``frequency_hz`` and
    ``source_impedance_ohm``.

**The attributes** (``idata.attrs``) name the fit (``model``, ``chain``, ``data``,
``method``, ``method_title``, ``seed``), give its PSIS-LOO and WAIC as fitdf reports them
(``looic = -2 elpd_loo``, the deviance scale; ``looic_se``, ``elpd_loo``, ``p_loo``,
``waic``, ...), the evidence ``log_evidence`` and ``log_evidence_error`` (nested sampling),
and the prior (``prior``, JSON: each parameter's distribution and box in natural units, and
the noise scales'), the parameters held fixed (``fixed``, JSON) and which draws these are
(``draws``).

**Reproducing the LOO-IC.** ``arviz.loo(idata, scale="deviance").elpd_loo`` is
``idata.attrs["looic"]``, fitdf's LOO-IC. PSIS smooths the importance weights over a tail
whose length depends on the relative efficiency of the draws: 1 for one chain (nested
sampling); for several chains (emcee) ArviZ estimates it from the ESS of the posterior
group, here in physical units, where fitdf estimated it in the sampler's internal
coordinates (``log10`` of a log-scaled parameter), so pass ``reff=idata.attrs["loo_reff"]``
to reproduce fitdf's LOO to the last digit.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from fitdf import __version__
from fitdf._arviz import arviz, walkers_as_chains
from fitdf.errors import OptionError
from fitdf.inference.noise_models import get_noise_law
from fitdf.inference.priors import (
    noise_law_prior_description,
    noise_prior_description,
    prior_description,
)

__all__ = ["inference_data", "write_posteriors", "posterior_filename", "LOO_ATTRS"]

#: The LOO and WAIC figures of a result's metrics the file's attributes repeat.
LOO_ATTRS = ("looic", "looic_se", "elpd_loo", "elpd_loo_se", "p_loo", "waic", "waic_se")

#: Prior fields (:func:`fitdf.inference.priors.prior_description`) as variable attributes.
_PRIOR_ATTRS = {
    "median": "prior_median",
    "sigma_ln": "prior_sigma_ln",
    "mean": "prior_mean",
    "sigma": "prior_sigma",
}


def _variable_attrs(prior: dict, description: str) -> dict:
    lo, hi = prior["bounds"]
    out = {
        "unit": prior["unit"],
        "description": description,
        "prior": prior["distribution"],
        "prior_lower": lo,
        "prior_upper": hi,
    }
    out.update({name: prior[key] for key, name in _PRIOR_ATTRS.items() if key in prior})
    return out


def _chains_first(a) -> np.ndarray:
    """fitdf's ``(draw, chain, ...)`` as ArviZ's ``(chain, draw, ...)``."""
    return np.swapaxes(np.asarray(a, float), 0, 1)


def inference_data(result):
    """``result`` (a :class:`~fitdf.inference.results.PosteriorResult`) as ArviZ's
    ``InferenceData`` in physical units: the groups and attributes of the module docstring.
    """
    pointwise = getattr(result, "pointwise", None)
    if pointwise is None:
        raise OptionError(
            f"{result.model}/{result.chain} ({result.method}): no posterior draws with their "
            "pointwise log-likelihood to export"
        )
    problem = result.problem
    natural = problem.to_natural(_chains_first(pointwise.draws))
    noise = _chains_first(pointwise.noise)
    law = _sampled_law(result)
    noise_priors = noise_prior_description() if law is None else noise_law_prior_description(law)
    posterior = {s.name: natural[..., i] for i, s in enumerate(problem.specs)}
    posterior.update({name: noise[..., j] for j, name in enumerate(noise_priors)})
    rows = result.residuals
    n = len(rows)
    observed = {c: rows[c].to_numpy(float) for c in ("df_measured", "phase_lead_measured_deg")}
    constant = {
        c: rows[c].to_numpy(float) for c in ("input_v", "frequency_hz", "source_impedance_ohm")
    }
    row_dims = {name: ["row"] for name in ("df", *observed, *constant)}
    diag, info = result.diagnostics, result.info
    attrs = {
        "model": result.model,
        "chain": result.chain,
        "data": result.label,
        "method": result.method,
        "method_title": result.method_title,
        "seed": int(info.get("seed", 0)),
        "fitdf_version": __version__,
        "n_rows": n,
        **{k: float(result.metrics[k]) for k in LOO_ATTRS if k in result.metrics},
        "loo_scale": "looic = -2 elpd_loo (deviance): arviz.loo(idata, scale='deviance')",
        "loo_reff": float(pointwise.reff),
        "prior": json.dumps({**prior_description(problem.specs, problem.priors), **noise_priors}),
        "fixed": json.dumps({k: float(v) for k, v in problem.fixed.items()}),
        "draws": pointwise.description,
    }
    for key in ("log_evidence", "log_evidence_error"):
        if key in diag:
            attrs[key] = float(diag[key])
    az = arviz()
    with walkers_as_chains():
        idata = az.from_dict(
            posterior=posterior,
            log_likelihood={"df": _chains_first(pointwise.log_likelihood)},
            observed_data=observed,
            constant_data=constant,
            coords={"row": np.arange(n)},
            dims=row_dims,
            attrs=attrs,
        )
    priors = prior_description(problem.specs, problem.priors)
    for s in problem.specs:
        idata.posterior[s.name].attrs.update(_variable_attrs(priors[s.name], s.description))
    how = info.get("noise", "")
    for name, prior in noise_priors.items():
        idata.posterior[name].attrs.update(_variable_attrs(prior, f"noise scale; {how}"))
    return idata


def _sampled_law(result):
    """The noise law whose parameters the sampler drew (nested sampling under a fitted law,
    ``info["noise_law"]["sampled"]``), or None: the two noise scales."""
    record = result.info.get("noise_law") or {}
    return get_noise_law(record["name"]) if record.get("sampled") else None


def posterior_filename(result) -> str:
    """``<data>_<model>_<chain>_<method>.nc``: the data label (a ``.csv`` suffix dropped)
    and the law, with every character but letters, digits, ``.``, ``+`` and ``-`` as ``_``
    and no ``.`` or ``_`` at either end of a part."""
    label = re.sub(r"\.csv$", "", str(result.label), flags=re.IGNORECASE)
    parts = (label, result.model, result.chain, result.method)
    # (stripped of leading dots too: a name, never a hidden file)
    return "_".join(re.sub(r"[^A-Za-z0-9.+-]+", "_", p).strip("._") for p in parts) + ".nc"


def write_posteriors(results, folder) -> list[Path]:
    """Write each posterior of ``results`` (least-squares results are skipped) to ``folder``
    as a netCDF file (:func:`posterior_filename`; an existing file of that name is
    replaced); the folder is made if missing. Returns the paths written."""
    folder = Path(folder).expanduser()
    written = []
    for result in results:
        if getattr(result, "pointwise", None) is None:
            continue
        path = folder / posterior_filename(result)
        try:
            folder.mkdir(parents=True, exist_ok=True)
            result.to_inference_data().to_netcdf(str(path))
        except OSError as exc:
            reason = exc.strerror or exc
            raise OptionError(f"cannot write the posterior to {path}: {reason}") from None
        written.append(path)
    return written
