"""How much the Bayesian evidence depends on the prior: the evidence again with the box halved
and doubled.

The evidence is the likelihood averaged over the prior, so it depends on the prior's width
where the likelihood does not: a box ``f`` times as wide in ``d`` parameters the data
determine moves ``ln Z`` by about ``-d ln f`` (an Occam factor), and a Bayes factor between
laws with different numbers of such parameters moves with it. :func:`prior_sensitivity`
measures that under the box halved (about the best fit, kept inside the box) and doubled
(about the box's centre) in internal coordinates
(:meth:`fitdf.inference.problem.FitProblem.with_box_scaled`; decades for log-scaled
parameters), the doubled box stopping at each parameter's physical limits.

A box inside the prior's needs no new sampling (:func:`restricted_log_evidence`): the prior
restricted to a sub-box ``B'`` has the evidence ``Z' = Z P(B' | data) pi(x) / pi'(x)`` (any
``x`` in ``B'``; the two densities differ there by a constant), where ``P(B' | data)`` is
the share of the posterior's draws inside ``B'``. It is exact but for that share's sampling
error, so the halved box is sampled afresh only where few draws fall inside it. A box wider
than the prior's holds likelihood the posterior's draws never saw, and is sampled.
"""

from __future__ import annotations

import numpy as np

from fitdf.inference.nested import MAX_LOG_EVIDENCE_ERROR, PriorTransform, fit_nested

__all__ = [
    "prior_sensitivity",
    "restricted_log_evidence",
    "SENSITIVITY_FACTORS",
    "SAMPLED_FACTORS",
]

#: The box widths, relative to the prior's, at which the evidence is estimated again.
SENSITIVITY_FACTORS = (0.5, 2.0)
#: Of those, the boxes sampled anew: the wider ones (a narrower box is restricted from the
#: posterior's draws, unless too few fall inside it).
SAMPLED_FACTORS = tuple(f for f in SENSITIVITY_FACTORS if f > 1)


def restricted_log_evidence(log_evidence, draws, n_effective, prior, sub_prior):
    """``ln Z`` of a prior restricted to a box inside its own, from the posterior's draws.

    Parameters
    ----------
    log_evidence : float
        ``ln Z`` under ``prior``.
    draws : array ``(n, P)``
        Equal-weight draws of the posterior under ``prior`` (internal coordinates).
    n_effective : float
        Their effective number (Kish's, of the weights they were resampled from): it sets
        the sampling error of the share inside the sub-box.
    prior, sub_prior : PriorTransform
        The prior and the same prior on a box inside its box.

    Returns
    -------
    log_z : float
        ``ln Z'``; ``-inf`` if no draw falls inside the sub-box.
    shift_error : float
        The standard error of ``ln Z' - ln Z``: the binomial error of the share ``s`` inside,
        ``sqrt((1 - s) / (s n_effective))`` (delta method).
    share : float
        The posterior's share inside the sub-box.
    """
    draws = np.asarray(draws, float).reshape(-1, prior.ndim)
    lo, hi = sub_prior.lo, sub_prior.lo + sub_prior.width
    # (a box scaled about a point at the prior's edge meets it to rounding: natural bounds
    # are internal ones through 10**x and back)
    slack = 1e-9 * prior.width
    if np.any(lo < prior.lo - slack) or np.any(hi > prior.lo + prior.width + slack):
        raise ValueError("the sub-box is not inside the prior's box")
    share = float(np.mean(np.all((draws >= lo) & (draws <= hi), axis=1)))
    if share == 0.0:
        return -np.inf, np.inf, 0.0
    centre = (lo + 0.5 * sub_prior.width)[None]
    log_ratio = float(sub_prior.log_density(centre)[0] - prior.log_density(centre)[0])
    error = float(np.sqrt((1.0 - share) / (share * n_effective)))
    return float(log_evidence + np.log(share) + log_ratio), error, share


def prior_sensitivity(result, lsq, seed=0, factors=SENSITIVITY_FACTORS, **nested) -> dict:
    """The evidence of ``result``'s problem with its prior box scaled by each of ``factors``.

    A box inside the prior's (``factor < 1``) is estimated from ``result``'s draws
    (:func:`restricted_log_evidence`) where that is as accurate as the convergence rule asks
    of a sampled evidence (its error at most
    :data:`~fitdf.inference.nested.MAX_LOG_EVIDENCE_ERROR`), and sampled otherwise; a wider
    box is sampled.

    Parameters
    ----------
    result : PosteriorResult
        A nested-sampling fit (its problem, its best point, its draws and its evidence).
    lsq : FitResult
        The problem's least-squares fit (it starts the chain's solver, as for ``result``).
    seed : int
        The seed of every run.
    factors : tuple of float
        Box widths relative to the prior's: below 1 the box is centred on ``result``'s best
        point (kept inside the original box), above 1 on the original box's centre.
    **nested
        Options of :func:`fitdf.inference.nested.fit_nested`.

    Returns
    -------
    dict
        ``{"log_evidence": ..., "log_evidence_error": ..., "boxes": [{"factor", "log_evidence",
        "log_evidence_error", "converged", "shift", "estimate"}]}``, ``shift`` the change of
        ``ln Z`` from the prior's, ``estimate`` ``"restricted"`` (from ``result``'s draws) or
        ``"sampled"``.
    """
    base = result.diagnostics
    prior = PriorTransform(result.problem)
    boxes = []
    for f in factors:
        problem = result.problem.with_box_scaled(f, about=result.internal if f < 1 else None)
        if f < 1:
            log_z, shift_error, share = restricted_log_evidence(
                base["log_evidence"],
                result.samples.reshape(-1, result.problem.ndim),
                base["n_effective"],
                prior,
                PriorTransform(problem),
            )
            if shift_error <= MAX_LOG_EVIDENCE_ERROR:
                error = float(np.hypot(base["log_evidence_error"], shift_error))
                boxes.append(
                    {
                        "factor": float(f),
                        "log_evidence": log_z,
                        "log_evidence_error": error,
                        "converged": bool(base["converged"]),
                        "shift": log_z - base["log_evidence"],
                        "shift_error": shift_error,
                        "posterior_share": share,
                        "estimate": "restricted",
                    }
                )
                continue
        again = fit_nested(problem, lsq, seed=seed, **nested).diagnostics
        boxes.append(
            {
                "factor": float(f),
                "log_evidence": again["log_evidence"],
                "log_evidence_error": again["log_evidence_error"],
                "converged": bool(again["converged"]),
                "shift": again["log_evidence"] - base["log_evidence"],
                "shift_error": float(
                    np.hypot(again["log_evidence_error"], base["log_evidence_error"])
                ),
                "estimate": "sampled",
            }
        )
    return {
        "log_evidence": base["log_evidence"],
        "log_evidence_error": base["log_evidence_error"],
        "boxes": boxes,
    }
