"""When harmonic balance cannot be trusted: warnings about the plant of the loop.

Harmonic balance (:mod:`fitdf.loop.harmonic`) keeps the first harmonic of the element's
output and assumes the linear part

* is *low-pass*: it attenuates the harmonics ``3 omega, 5 omega, ...`` the nonlinear
  element makes, so that the signal coming back to the element is nearly sinusoidal (the
  filter hypothesis). A plant whose gain does not fall at high frequency (relative degree
  below 1: as many zeros as poles, or more) passes the harmonics through, and the
  predicted amplitudes and frequencies, even the existence of a cycle, are unreliable.
  At a cycle found, a third harmonic passed as strongly as the fundamental
  (``|G(3j omega)| >= |G(j omega)|``) is the same failure, there;
* is *stable in open loop*, or at least that the question is only whether a periodic
  solution exists. With a pole in the right half-plane the loop's fate (it settles, it
  diverges, it oscillates) is decided by more than the first harmonic: harmonic balance
  finds the periodic solutions, if any, but "no limit cycle" does not mean "stable".

:func:`plant_warnings` returns these, one sentence each, for
:class:`~fitdf.loop.response.LimitCycleResponse` (``warnings``; ``fitdf limit-cycle``
prints them and writes them to its JSON).
"""

from __future__ import annotations

import control
import numpy as np

from fitdf.loop.plant import Plant

__all__ = ["plant_warnings", "relative_degree", "unstable_poles"]

#: A pole is in the right half-plane when its real part exceeds this (times max(1, |p|)).
POLE_TOL = 1e-9


def _trimmed(p) -> np.ndarray:
    p = np.atleast_1d(np.asarray(p, float))
    scale = np.max(np.abs(p)) if p.size else 0.0
    nonzero = np.flatnonzero(np.abs(p) > 1e-12 * scale) if scale > 0 else []
    return p[nonzero[0] :] if len(nonzero) else np.zeros(1)


def relative_degree(plant: Plant, gain: float = 1.0) -> int:
    """Degree of the denominator minus that of the numerator of ``G`` at ``K = gain``."""
    num, den = (_trimmed(p) for p in plant.polynomials(gain))
    return (len(den) - 1) - (len(num) - 1)


def unstable_poles(plant: Plant, gain: float = 1.0) -> np.ndarray:
    """The poles of ``G`` (at ``K = gain``) with a positive real part, ordered by real part."""
    poles = np.atleast_1d(control.poles(plant.transfer_function(gain)))
    rhp = poles[poles.real > POLE_TOL * np.maximum(1.0, np.abs(poles))]
    return rhp[np.argsort(rhp.real)]


def _pole_text(poles) -> str:
    def one(p):
        if abs(p.imag) <= POLE_TOL * max(1.0, abs(p)):
            return f"{p.real:.4g}"
        return f"{p.real:.4g}{'+' if p.imag > 0 else '-'}{abs(p.imag):.4g}j"

    return ", ".join(one(p) for p in poles)


def plant_warnings(plant: Plant, gains, cycles=()) -> tuple[str, ...]:
    """The ways in which ``plant`` breaks the hypotheses of harmonic balance (none: ``()``).

    Parameters
    ----------
    plant : Plant
        The loop's linear part (:func:`fitdf.loop.plant.as_loop_plant`).
    gains : sequence of float
        The loop gains solved at (poles and degrees depend on them only when the plant's
        text uses ``K`` non-linearly).
    cycles : sequence of LimitCycle
        The cycles found: each is checked for a third harmonic the plant does not attenuate.

    Examples
    --------
    >>> from fitdf.loop.plant import parse_plant
    >>> plant_warnings(parse_plant("K/((1+s)(1+0.25s))"), [1.0])
    ()
    >>> print(plant_warnings(parse_plant("K/(s-1)"), [10.0])[0][:60])
    the plant is unstable in open loop (pole at s = 1): harmonic
    """
    gains = [float(g) for g in np.atleast_1d(gains)]
    if not plant.has_gain or plant.linear_in_gain:
        gains = gains[:1]  # K only scales G: poles and degree are those of any one gain
    out = []
    unstable = {g: unstable_poles(plant, g) for g in gains}
    if any(p.size for p in unstable.values()):
        g, poles = next((g, p) for g, p in unstable.items() if p.size)
        at = f" at K = {g:g}" if len(gains) > 1 else ""
        out.append(
            f"the plant is unstable in open loop (pole{'s' if poles.size > 1 else ''} at "
            f"s = {_pole_text(poles)}{at}): harmonic balance only finds periodic solutions; "
            "it does not tell whether the loop settles or diverges, so 'no limit cycle' "
            "does not mean the loop is stable"
        )
    degree = min(relative_degree(plant, g) for g in gains)
    if degree < 1:
        out.append(
            f"the plant is not low-pass (relative degree {degree}: |G(jw)| does not fall at "
            "high frequency): it passes the harmonics the element makes, so the "
            "harmonic-balance (filter) hypothesis fails and the cycles predicted, or their "
            "absence, are unreliable"
        )
    else:
        passed = [
            c
            for c in cycles
            if abs(plant.frequency_response(3.0 * c.omega, c.gain))
            >= abs(plant.frequency_response(c.omega, c.gain))
        ]
        if passed:
            c = passed[0]
            out.append(
                f"at the cycle of K = {c.gain:g} (omega {c.omega:.4g} rad/s) the plant passes "
                "the third harmonic as strongly as the fundamental (|G(3jw)| >= |G(jw)|): the "
                f"harmonic-balance (filter) hypothesis fails there ({len(passed)} cycle"
                f"{'s' if len(passed) > 1 else ''} affected)"
            )
    return tuple(out)
