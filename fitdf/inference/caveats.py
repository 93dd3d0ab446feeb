"""What a fit's numbers do not say: parameters held by their box, or left open by the data.

Shared by least squares (at the optimum, with its covariance intervals) and MCMC (over the
posterior draws): a value on a bound is the box's, not the data's, and is reported as such.
"""

from __future__ import annotations

import numpy as np

from fitdf.data.cores import MATERIAL_LIMITS
from fitdf.inference.noise import NOISE_BOUNDS, NOISE_NAMES
from fitdf.inference.problem import FitProblem
from fitdf.params import DIMENSIONLESS

__all__ = [
    "bound_warnings",
    "identifiability_warnings",
    "undetermined_parameters",
    "posterior_bound_warnings",
    "noise_bound_warnings",
]


def _bound_side(spec, value, rel=1e-3) -> str | None:
    """The side ("lower" or "upper") whose bound the internal ``value`` is within ``rel`` of
    the box's width from, else None."""
    lo, hi = spec.internal_bounds
    tol = rel * (hi - lo)
    return "lower" if value - lo < tol else "upper" if hi - value < tol else None


def _too_wide(spec, interval: dict, decades: float) -> bool:
    """A 68 % interval over ``decades`` wide (log) or half its box (linear): undetermined."""
    lo, hi = interval.get("p16", np.nan), interval.get("p84", np.nan)
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return False
    return bool(
        (spec.log and lo > 0 and np.log10(hi / lo) > decades)
        or (not spec.log and hi - lo >= 0.5 * (spec.bounds[1] - spec.bounds[0]))
    )


def undetermined_parameters(problem: FitProblem, intervals: dict, x, decades=1.0) -> list[str]:
    """The fitted parameters the data do not determine: on a bound of the box at ``x``
    (internal, :func:`bound_warnings`) or with too wide an interval
    (:func:`identifiability_warnings`), in the problem's order."""
    return [
        s.name
        for i, s in enumerate(problem.specs)
        if _bound_side(s, x[i]) is not None or _too_wide(s, intervals.get(s.name, {}), decades)
    ]


def bound_warnings(problem: FitProblem, x, rel=1e-3) -> list[str]:
    """What a parameter on a bound means: the data push it past the box, so the box, not the
    data, sets its value (and the other parameters are conditional on it)."""
    out = []
    for i, s in enumerate(problem.specs):
        side = _bound_side(s, x[i], rel)
        if side is None:
            continue
        bound = s.bounds[0] if side == "lower" else s.bounds[1]
        why = _box_reason(problem, s, side)
        out.append(
            f"parameter {s.name} sits on its {side} bound {bound:.4g}{_unit(s)}{why}: the data "
            f"want a {'smaller' if side == 'lower' else 'larger'} value and do not determine it"
        )
    return out


def _unit(spec) -> str:
    """`` unit`` to follow a value, or nothing for a pure number."""
    return "" if spec.unit_label == DIMENSIONLESS else f" {spec.unit}"


def _box_reason(problem: FitProblem, spec, side) -> str:
    if problem.geometry is None or spec.quantity not in MATERIAL_LIMITS:
        return ""
    what, lo, _, hi, _ = MATERIAL_LIMITS[spec.quantity]
    return f" (the physical limit {what} = {lo if side == 'lower' else hi:g})"


def identifiability_warnings(
    problem: FitProblem, intervals: dict, decades: float = 1.0
) -> list[str]:
    """Parameters whose 68 % interval spans more than ``decades`` (log) or its whole box: the
    data do not determine them (a prior, where there is one, does)."""
    out = []
    for s in problem.specs:
        iv = intervals.get(s.name, {})
        lo, hi = iv.get("p16", np.nan), iv.get("p84", np.nan)
        if _too_wide(s, iv, decades):
            held = " (held by its prior)" if s.name in problem.priors else ""
            out.append(
                f"the data do not determine {s.name}: 68% interval {lo:.3g}..{hi:.3g}"
                f"{_unit(s)}{held}"
            )
    return out


def posterior_bound_warnings(problem: FitProblem, draws, rel=0.01, mass=0.025) -> list[str]:
    """Parameters whose posterior runs into a bound of the box: at least ``mass`` of the
    internal ``draws`` ``(n, P)`` lie within ``rel`` of the box's width from it. The
    posterior is then cut off by the box, not by the data (constant_width on B.2: ``k``
    climbs to the relay limit), and its intervals and any chain along it say so much less
    than they seem to."""
    draws = np.asarray(draws, float).reshape(-1, problem.ndim)
    out = []
    for i, s in enumerate(problem.specs):
        side, share = _bound_share(draws[:, i], *s.internal_bounds, rel)
        if share < mass:
            continue
        bound = s.bounds[0] if side == "lower" else s.bounds[1]
        out.append(
            f"the posterior of {s.name} runs into its {side} bound {bound:.4g}{_unit(s)}"
            f"{_box_reason(problem, s, side)}: {100 * share:.0f} % of the draws lie within "
            f"{100 * rel:g} % of the box from it; the box, not the data, ends it there"
        )
    return out


def _bound_share(x, lo, hi, rel):
    """``(side, share)``: the bound of ``[lo, hi]`` more of the draws ``x`` lie within
    ``rel`` of the width from ("lower" or "upper"), and the share of them that do."""
    tol = rel * (hi - lo)
    near = {"lower": np.mean(x - lo < tol), "upper": np.mean(hi - x < tol)}
    side = max(near, key=near.get)
    return side, float(near[side])


#: Why a noise scale's posterior may run into a bound: (scale, side) -> what it means.
_NOISE_BOUND_REASONS = {
    ("sigma_magnitude", "upper"): (
        " (the law gives up its magnitudes to fit its phases: the box, 30 times the "
        "tables' printed precision, is the largest magnitude noise fitdf believes)"
    ),
    ("sigma_phase_deg", "upper"): " (the law does not follow the measured phases)",
}


def noise_bound_warnings(log10_noise, rel=0.01, mass=0.025, law=None) -> list[str]:
    """The fitted noise scales whose posterior runs into a bound of :data:`NOISE_BOUNDS`,
    by the rule of :func:`posterior_bound_warnings` on draws ``(..., 2)`` of ``log10``
    ``(sigma_magnitude, sigma_phase_deg)``; with a fitted noise ``law``
    (:class:`~fitdf.inference.noise_models.NoiseLaw`), draws ``(..., k)`` of its parameters
    on its bounds."""
    names, bounds = (NOISE_NAMES, NOISE_BOUNDS) if law is None else (law.names, law.bounds)
    kind = "noise scale" if law is None else f"{law.name} noise law's parameter"
    draws = np.asarray(log10_noise, float).reshape(-1, len(names))
    out = []
    for j, name in enumerate(names):
        lo, hi = bounds[j]
        side, share = _bound_share(draws[:, j], lo, hi, rel)
        if share < mass:
            continue
        bound = 10.0 ** (lo if side == "lower" else hi)
        out.append(
            f"the posterior of the {kind} {name} runs into its {side} bound {bound:.3g}"
            f"{_NOISE_BOUND_REASONS.get((name, side), '')}: {100 * share:.0f} % of the "
            f"draws lie within {100 * rel:g} % of the box from it; the box, not the data, ends it"
        )
    return out
