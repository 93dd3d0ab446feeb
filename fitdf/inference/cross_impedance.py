"""Prediction across source impedance: fit a core at one, predict its data at the other.

Provides :func:`cross_impedance` and the quadrature it averages over the series
resistance's prior, :data:`PRIOR_NODES` and :data:`PRIOR_WEIGHTS`. Data at one source
impedance determine a core only up to a current scale that trades against the series
resistance ``r_series`` (:mod:`fitdf.data.cores`); the other impedance depends on it, so
the prediction is averaged over its prior
(:func:`fitdf.chains.series_resistance.series_resistance_prior`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitdf.chains import get_chain, series_resistance_prior
from fitdf.errors import OptionError
from fitdf.inference.api import DEFAULT_CHAIN, fit, resolve_data, resolve_geometry
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.metrics import residual_metrics
from fitdf.inference.problem import FitProblem
from fitdf.models import model_names
from fitdf.params import PER_TABLE, current_scaled, parameter_base

__all__ = ["cross_impedance", "PRIOR_NODES", "PRIOR_WEIGHTS"]

#: Where a cross-impedance prediction evaluates the series resistance's prior: the
#: probabilists' Gauss-Hermite nodes (in standard deviations of its logarithm) and weights of
#: three points, exact for a response quadratic in ``ln r_series`` over a log-normal prior.
PRIOR_NODES = (-np.sqrt(3.0), 0.0, np.sqrt(3.0))
PRIOR_WEIGHTS = (1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0)


def cross_impedance(
    core,
    models=None,
    chain=DEFAULT_CHAIN,
    train_ohm=0.0,
    test_ohm=600.0,
    seed=0,
    policy="default",
    n_starts=6,
    r_series=None,
) -> pd.DataFrame:
    """Fit a core at one source impedance and predict its data at the other.

    Everything that describes the core (the law's parameters and the series resistance)
    comes from the training fit; the tables define their DF with different calibration
    factors (see the audit), so the target table's calibration ``gain`` -- and only that --
    is fitted on the target rows. Data at one source impedance fix the core only up to a
    current scale that trades against the series resistance ``r_series`` (the winding, the
    source's output impedance and the leads; :mod:`fitdf.data.cores`), and the prediction at
    the other impedance depends on it. So the prediction is averaged over its prior
    (:func:`~fitdf.chains.series_resistance.series_resistance_prior`) at the three
    :data:`PRIOR_NODES`: at each, the training fit with ``r_series`` held there (the core at
    the prior's median rescaled by the current-scale symmetry, which reproduces the training
    rows exactly, then polished to the chain's tolerance) predicts the target, and the rows give
    the RMS of the weighted mean prediction (``predict_*``) and its spread over the nodes
    (``predict_rms_complex_nodes``, ``_min``, ``_max``). ``r_series`` (ohm) holds it at one
    value instead (a core without an Appendix A geometry needs it).
    """
    train = resolve_data(core, policy, train_ohm)
    test = resolve_data(core, policy, test_ohm)
    has_r = any(p.name == "r_series" for p in get_chain(chain).params)
    rows = []
    for model in list(models or model_names()):
        nodes, weights = _series_nodes(train, r_series) if has_r else ([], [1.0])
        fixed0 = {"r_series": nodes[len(nodes) // 2]} if has_r else {}
        first = fit(train, model, chain=chain, seed=seed, n_starts=n_starts, fixed=fixed0)
        trained, preds, gains = [], [], []
        for r in nodes or [None]:
            fitted = first if r is None or r == fixed0["r_series"] else _rescaled(first, r, seed)
            pred, gain = _predicted(fitted, test, model, chain, seed)
            trained.append(fitted.metrics["rms_complex"])
            preds.append(pred)
            gains.append(gain)
        mean = np.tensordot(np.asarray(weights), np.asarray(preds), axes=1)
        per_node = [residual_metrics(p, test.measured)["rms_complex"] for p in preds]
        middle = len(preds) // 2
        rows.append(
            {
                "core": str(core) if not isinstance(core, pd.DataFrame) else "data",
                "model": model,
                "chain": chain,
                "train_ohm": train_ohm,
                "test_ohm": test_ohm,
                "r_series_nodes": list(map(float, nodes)),
                "r_series_weights": list(map(float, weights)),
                "train_rms_complex": trained[middle],
                "train_rms_complex_nodes": trained,
                **{f"predict_{k}": v for k, v in residual_metrics(mean, test.measured).items()},
                "predict_rms_complex_nodes": per_node,
                "predict_rms_complex_min": float(min(per_node)),
                "predict_rms_complex_max": float(max(per_node)),
                "n_test": test.n,
                "calibration_gain": gains[middle],
            }
        )
    return (
        pd.DataFrame(rows).sort_values("predict_rms_complex", kind="stable").reset_index(drop=True)
    )


def _series_nodes(train, r_series):
    """``(r_series values, weights)``: the prior's :data:`PRIOR_NODES`, or ``r_series`` alone."""
    if r_series is not None:
        return [float(r_series)], [1.0]
    geometry = resolve_geometry("auto", train)
    if geometry is None or not geometry.r_winding_estimate:
        raise OptionError(
            "cross-impedance prediction: no winding-resistance estimate for this core (no "
            "Appendix A geometry); give r_series, or a geometry with r_winding"
        )
    median, sigma = series_resistance_prior(geometry.r_winding_estimate)
    return [median * float(np.exp(sigma * z)) for z in PRIOR_NODES], list(PRIOR_WEIGHTS)


def _rescaled(fitted, r_series, seed):
    """``fitted`` (a fit with ``r_series`` held fixed) refitted with it held at ``r_series``:
    started from the core rescaled by the ratio of the total series resistances
    ``(R_source + r_series) / (R_source + r0)`` (:func:`fitdf.params.current_scaled`: the
    law's parameters and the chain's loss terms), which reproduces every training reading
    where the rows share one source impedance (the current-scale symmetry,
    :mod:`fitdf.data.cores`), so the polish only absorbs the chain's numerical tolerance."""
    p = fitted.problem
    r0 = float(p.fixed["r_series"])
    source = float(np.mean(p.data.source_impedance))
    scale = (source + r_series) / (source + r0)
    values = current_scaled((*p.model.params, *p.chain.params), fitted.values, scale)
    problem = FitProblem(
        p.data, p.model, p.chain, p.noise, {**p.fixed, "r_series": r_series}, p.geometry
    )
    start = problem.to_internal(values)
    return fit_lsq(problem, starts=start, seed=seed, uncertainties=False)


def _predicted(fitted, test, model, chain, seed):
    """The prediction of ``fitted``'s core at the rows ``test``, with only the target table's
    calibration gain fitted there; ``(prediction, gain)``."""
    fixed = {k: v for k, v in fitted.values.items() if parameter_base(k) not in PER_TABLE}
    target = FitProblem(test, model, chain, fitted.problem.noise, fixed, fitted.problem.geometry)
    if not target.ndim:
        return target.predict(np.zeros(0)), float("nan")
    calibrated = fit_lsq(target, seed=seed, n_starts=2, uncertainties=False)
    gain = {k: v for k, v in calibrated.values.items() if parameter_base(k) in PER_TABLE}
    return target.predict(calibrated.internal), float(next(iter(gain.values()), np.nan))
