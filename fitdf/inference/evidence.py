"""How much the Bayesian evidence depends on the prior: the evidence again with the box halved
and doubled.

The evidence is the likelihood averaged over the prior, so it depends on the prior's width
where the likelihood does not: a box ``f`` times as wide in ``d`` parameters the data
determine moves ``ln Z`` by about ``-d ln f`` (an Occam factor), and a Bayes factor between
laws with different numbers of such parameters moves with it. :func:`prior_sensitivity`
measures that, by sampling the same posterior under the box halved (about the best fit, kept
inside the box) and doubled (about the box's centre) in internal coordinates
(:meth:`fitdf.inference.problem.FitProblem.with_box_scaled`; decades for log-scaled
parameters), the doubled box stopping at each parameter's physical limits.
"""

from __future__ import annotations

from fitdf.inference.nested import fit_nested

__all__ = ["prior_sensitivity", "SENSITIVITY_FACTORS"]

#: The box widths, relative to the prior's, at which the evidence is estimated again.
SENSITIVITY_FACTORS = (0.5, 2.0)


def prior_sensitivity(result, lsq, seed=0, factors=SENSITIVITY_FACTORS, **nested) -> dict:
    """The evidence of ``result``'s problem with its prior box scaled by each of ``factors``.

    Parameters
    ----------
    result : PosteriorResult
        A nested-sampling fit (its problem, its best point and its evidence).
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
        "log_evidence_error", "converged", "shift"}]}``, ``shift`` the change of ``ln Z`` from
        the prior's.
    """
    base = result.diagnostics
    boxes = []
    for f in factors:
        problem = result.problem.with_box_scaled(f, about=result.internal if f < 1 else None)
        again = fit_nested(problem, lsq, seed=seed, **nested).diagnostics
        boxes.append(
            {
                "factor": float(f),
                "log_evidence": again["log_evidence"],
                "log_evidence_error": again["log_evidence_error"],
                "converged": bool(again["converged"]),
                "shift": again["log_evidence"] - base["log_evidence"],
            }
        )
    return {
        "log_evidence": base["log_evidence"],
        "log_evidence_error": base["log_evidence_error"],
        "boxes": boxes,
    }
