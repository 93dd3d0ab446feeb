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
restricted to a sub-box ``B'`` has the evidence ``Z' = Z P(B' | data) pi'(x) / pi(x)`` (any
``x`` in ``B'``; the two densities differ there by a constant), where ``P(B' | data)`` is
the share of the posterior's draws inside ``B'``. It is exact but for that share's sampling
error, so the halved box is sampled afresh only where few draws fall inside it. A box wider
than the prior's holds likelihood the posterior's draws never saw, and is sampled; its
evidence is stratified (:func:`widened_log_evidence`): the part inside the prior's box is
exact from ``Z`` (``Z pi''(x) / pi(x)``), which is also a lower bound on the whole, and only
the part outside comes from the wider run's draws. A wider run whose own evidence falls below
that bound (by more than :data:`MISSED_BY_ERRORS` errors) has missed the posterior the prior's
box holds, and is not converged. :func:`sensitivity_violations` checks a record against these
rules: no wider box's evidence below the part inside, none converged that missed it.
"""

from __future__ import annotations

import numpy as np

from fitdf.inference.nested import MAX_LOG_EVIDENCE_ERROR, PriorTransform, fit_nested

__all__ = [
    "prior_sensitivity",
    "restricted_log_evidence",
    "widened_log_evidence",
    "sensitivity_violations",
    "MISSED_BY_ERRORS",
    "SENSITIVITY_FACTORS",
    "SAMPLED_FACTORS",
]

#: The box widths, relative to the prior's, at which the evidence is estimated again.
SENSITIVITY_FACTORS = (0.5, 2.0)
#: Of those, the boxes sampled anew: the wider ones (a narrower box is restricted from the
#: posterior's draws, unless too few fall inside it).
SAMPLED_FACTORS = tuple(f for f in SENSITIVITY_FACTORS if f > 1)
#: A wider run whose own ``ln Z''`` is more than this many errors (the two runs' in
#: quadrature) below the exact part inside the prior's box has missed the posterior there.
#: Not zero: where the posterior lies well inside the prior's box ``Z''`` is that part alone,
#: and a run estimating it falls below it half the time by its error.
MISSED_BY_ERRORS = 3.0


def restricted_log_evidence(log_evidence, draws, n_effective, prior, sub_prior):
    """``ln Z`` of a prior restricted to a box inside its own, from the posterior's draws.

    ``Z' = int_B' L pi' = (pi'(x) / pi(x)) int_B' L pi = Z P(B' | data) pi'(x) / pi(x)``:
    the restricted prior ``pi'`` is ``pi`` renormalised to ``B'``, a constant factor of at
    least 1 there.

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


def _log_density_ratio(prior, other, x) -> float:
    """``ln other(x) - ln prior(x)`` at one internal vector ``x`` inside both boxes."""
    x = np.asarray(x, float)[None]
    return float(other.log_density(x)[0] - prior.log_density(x)[0])


def widened_log_evidence(
    log_evidence,
    log_evidence_error,
    prior,
    wide_prior,
    wide_log_evidence,
    wide_log_evidence_error,
    wide_draws,
    wide_n_effective,
) -> dict:
    """``ln Z''`` of a prior widened to a box that holds its own, stratified by the two boxes.

    ``Z'' = Z_in + Z_out``: the part inside the prior's box is exact from its evidence,
    ``Z_in = Z pi''(x) / pi(x)`` (any ``x`` there; a constant ratio, the restriction of
    :func:`restricted_log_evidence` read backwards), and it bounds ``Z''`` from below; the
    part outside is the wider run's evidence times its draws' share outside the prior's box.

    Parameters
    ----------
    log_evidence, log_evidence_error : float
        ``ln Z`` under ``prior`` and its error.
    prior, wide_prior : PriorTransform
        The prior, and the same prior on a box holding its box.
    wide_log_evidence, wide_log_evidence_error : float
        The wider run's own ``ln Z''`` and its error.
    wide_draws : array ``(n, P)``
        Equal-weight draws of the wider run's posterior (internal coordinates).
    wide_n_effective : float
        Their effective number.

    Returns
    -------
    dict
        ``log_evidence`` and ``log_evidence_error`` (stratified), ``shift_error`` (of
        ``ln Z'' - ln Z``, in which the part inside cancels), ``lower_bound``
        (``ln Z_in``), ``share_outside`` (the wider posterior's share outside the prior's box),
        and ``consistent``: False when the wider run's own ``ln Z''`` is more than three
        errors (:data:`MISSED_BY_ERRORS`) below ``lower_bound`` (it missed the posterior the
        prior's box holds, and its draws outside cannot be trusted either).
    """
    lo, hi = prior.lo, prior.lo + prior.width
    slack = 1e-9 * prior.width
    if np.any(wide_prior.lo > lo + slack) or np.any(wide_prior.lo + wide_prior.width < hi - slack):
        raise ValueError("the wider box does not hold the prior's box")
    draws = np.asarray(wide_draws, float).reshape(-1, prior.ndim)
    inside = np.all((draws >= lo) & (draws <= hi), axis=1)
    share_out = float(1.0 - np.mean(inside))
    log_in = float(log_evidence + _log_density_ratio(prior, wide_prior, lo + 0.5 * prior.width))
    if share_out > 0.0:
        log_out = float(wide_log_evidence + np.log(share_out))
        binomial = (1.0 - share_out) / (share_out * wide_n_effective)
        var_out = wide_log_evidence_error**2 + binomial
    else:
        log_out, var_out = -np.inf, 0.0
    log_z = float(np.logaddexp(log_in, log_out))
    w_in, w_out = np.exp(log_in - log_z), np.exp(log_out - log_z)
    error = float(np.sqrt(w_in**2 * log_evidence_error**2 + w_out**2 * var_out))
    gap = np.hypot(log_evidence_error, wide_log_evidence_error)
    return {
        "log_evidence": log_z,
        "log_evidence_error": error,
        # ln(Z''/Z) = ln(pi''/pi + Z_out/Z): only the part outside carries error
        "shift_error": float(w_out * np.sqrt(var_out + log_evidence_error**2)),
        "lower_bound": log_in,
        "share_outside": share_out,
        "consistent": bool(wide_log_evidence >= log_in - MISSED_BY_ERRORS * gap),
    }


def prior_sensitivity(result, lsq, seed=0, factors=SENSITIVITY_FACTORS, **nested) -> dict:
    """The evidence of ``result``'s problem with its prior box scaled by each of ``factors``.

    A box inside the prior's (``factor < 1``) is estimated from ``result``'s draws
    (:func:`restricted_log_evidence`) where that is as accurate as the convergence rule asks
    of a sampled evidence (its error at most
    :data:`~fitdf.inference.nested.MAX_LOG_EVIDENCE_ERROR`), and sampled otherwise; a wider
    box is sampled and its evidence stratified (:func:`widened_log_evidence`): converged
    only if its run converged and did not miss the prior's posterior.

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
        "log_evidence_error", "converged", "shift", "shift_error", "estimate"}]}``, ``shift``
        the change of ``ln Z`` from the prior's, ``estimate`` ``"restricted"`` (from
        ``result``'s draws), ``"sampled"`` or ``"widened"`` (stratified; with the fields of
        :func:`widened_log_evidence` and the run's own ``sampled_log_evidence``).
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
        run = fit_nested(problem, lsq, seed=seed, **nested)
        again = run.diagnostics
        record = {
            "factor": float(f),
            "log_evidence": again["log_evidence"],
            "log_evidence_error": again["log_evidence_error"],
            "converged": bool(again["converged"]),
            "estimate": "sampled",
            # what the run cost, so that a report's cost table tells it from the posterior's
            "n_likelihood_evaluations": again.get("n_likelihood_evaluations"),
            "seconds": again.get("seconds"),
        }
        if f > 1:
            wide = widened_log_evidence(
                base["log_evidence"],
                base["log_evidence_error"],
                prior,
                PriorTransform(problem),
                again["log_evidence"],
                again["log_evidence_error"],
                run.samples.reshape(-1, problem.ndim),
                again["n_effective"],
            )
            record.update(
                {
                    "sampled_log_evidence": again["log_evidence"],
                    "sampled_log_evidence_error": again["log_evidence_error"],
                    **wide,
                    "converged": bool(again["converged"] and wide["consistent"]),
                    "estimate": "widened",
                }
            )
        record["shift"] = record["log_evidence"] - base["log_evidence"]
        record.setdefault(
            "shift_error",
            float(np.hypot(record["log_evidence_error"], base["log_evidence_error"])),
        )
        boxes.append(record)
    out = {
        "log_evidence": base["log_evidence"],
        "log_evidence_error": base["log_evidence_error"],
        "boxes": boxes,
    }
    wrong = sensitivity_violations(out)
    if wrong:  # the stratified estimate holds these by construction: a failure is a defect
        raise RuntimeError("prior_sensitivity: " + "; ".join(wrong))
    return out


def sensitivity_violations(sensitivity: dict, tolerance: float = 1e-9) -> list[str]:
    """What is wrong with a record of :func:`prior_sensitivity` (an empty list: nothing).

    Every box wider than the prior's must be stratified (``estimate`` ``"widened"``, with its
    ``lower_bound``): its evidence at or above the exact part inside the prior's box, its
    ``shift`` the change from the prior's ``ln Z``, and not converged where its own run
    missed that part (``consistent`` false). The shift is then never below
    ``lower_bound - ln Z``, the log ratio of the two priors' densities inside the prior's box:
    for ``P`` uniform parameters whose boxes all double, ``-P ln 2``, so no record claims a
    larger Occam factor than its parameters allow."""
    base = sensitivity["log_evidence"]
    out = []
    for box in sensitivity.get("boxes") or []:
        if box["factor"] <= 1:
            continue
        name = f"box x{box['factor']:g}"
        if box.get("estimate") != "widened" or box.get("lower_bound") is None:
            out.append(f"{name}: not stratified (estimate {box.get('estimate')!r}, no lower bound)")
            continue
        least = box["lower_bound"] - base
        if box["log_evidence"] < box["lower_bound"] - tolerance:
            out.append(
                f"{name}: ln Z {box['log_evidence']:.6g} below its bound {box['lower_bound']:.6g}"
            )
        if abs(box["shift"] - (box["log_evidence"] - base)) > tolerance:
            out.append(f"{name}: shift {box['shift']:.6g} is not ln Z - the prior's ln Z")
        if box["shift"] < least - tolerance:
            out.append(
                f"{name}: shift {box['shift']:.6g} below the least the box allows, {least:.6g}"
            )
        if box.get("converged") and not box.get("consistent"):
            out.append(f"{name}: converged although its run missed the posterior inside")
    return out
