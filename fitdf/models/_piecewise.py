"""Closed-form describing functions and branches of the piecewise-linear loops.

Shared by :mod:`~fitdf.models.constant_width`, :mod:`~fitdf.models.proportional_width`
and :mod:`~fitdf.models.cubic_hc`. Every function works on *normalised* quantities so
that ``A = 0`` and ``c = inf`` need no special case:

* ``r = c / (k A)``: saturation level measured in units of the peak input (``inf`` for
  an unsaturated core or ``A = 0``);
* ``mu = b / A`` (``m`` in eq 4.2): half-width of the loop in units of the peak input.

All loops here are odd-symmetric (descending branch ``-y_up(-x)``) and piecewise linear
in ``x``. Over the rising half-period ``x = A sin(theta)``, ``theta`` in
``[-pi/2, pi/2]``, a segment ``y = A (p u + q)`` with ``u = x / A`` contributes, by
eqs 2.1 and 2.2 with the half-wave symmetry used in eq 2.4,

    G += (2/pi) [p P(u) + q Q(u)],          P(u) = (arcsin u - u sqrt(1 - u^2)) / 2,
    B += (2/pi) [p u^2 / 2 + q u],          Q(u) = -sqrt(1 - u^2),

evaluated between the segment's end points (:func:`segments_df`). The thesis formulas
(eqs 2.6, 2.8, 4.6, 4.7) are these sums worked out for particular segment layouts.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "ratio",
    "segments_df",
    "backlash_df",
    "lens_df",
    "fig42_df",
    "backlash_branch",
    "fig42_branch",
    "with_frequency_shape",
]

_TWO_OVER_PI = 2.0 / np.pi


def ratio(num, den, at_zero):
    """``num / den`` with ``0/0`` replaced by ``at_zero`` (a limit chosen by the caller).

    ``x/0`` with ``x > 0`` gives ``inf`` on purpose (``r = c/(kA)`` at ``A = 0``).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.true_divide(num, den)
    return np.where(np.isnan(out), at_zero, out)


def _P(u):
    u = np.clip(u, -1.0, 1.0)
    return 0.5 * (np.arcsin(u) - u * np.sqrt(1.0 - u * u))


def _Q(u):
    u = np.clip(u, -1.0, 1.0)
    return -np.sqrt(1.0 - u * u)


def segments_df(breaks, slopes, offsets):
    """Describing function of an odd-symmetric piecewise-linear loop (eqs 2.1, 2.2).

    Parameters
    ----------
    breaks : sequence of array_like
        ``n + 1`` normalised break points ``u = x/A`` of the ascending branch, from
        ``-1`` to ``1`` and non-decreasing (zero-length segments are allowed).
    slopes, offsets : sequence of array_like
        For each of the ``n`` segments, ``y / A = p u + q``: ``p`` (a gain) and ``q``.

    Returns
    -------
    numpy.ndarray of complex
        ``N = G + j B``; everything broadcasts.
    """
    G = 0.0
    B = 0.0
    for i, (p, q) in enumerate(zip(slopes, offsets)):  # loop over segments, not data
        u0, u1 = breaks[i], breaks[i + 1]
        G = G + p * (_P(u1) - _P(u0)) + q * (_Q(u1) - _Q(u0))
        B = B + p * 0.5 * (u1 * u1 - u0 * u0) + q * (u1 - u0)
    return _TWO_OVER_PI * (G + 1j * B)


def backlash_df(k, q, mu):
    """Clipped backlash of Figs 2.3/2.4: eqs 2.6 and 2.8 (2.9 and 2.13 unsaturated).

    Parameters
    ----------
    k : array_like
        Slope of the loop's sides.
    q : array_like
        Top of the loop over ``k A``: ``min(c/(kA), 1 - mu)``; the ``1 - mu`` branch is
        the unsaturated loop of Fig 2.4 (its top is ``k (A - b)``).
    mu : array_like
        ``b / A``; clipped to ``[0, 1]`` (``mu = 1`` gives ``N = 0``, the loop of zero
        height that every ``A <= b`` produces).

    Notes
    -----
    With ``sin U1 = b1/A = q - mu`` and ``sin U2 = b2/A = q + mu`` (so ``U2 = pi/2``
    and ``sin U1 = 1 - 2b/A`` without saturation, eq 2.11)::

        G = (k/pi) [U1 + U2 + sin(2 U1)/2 + sin(2 U2)/2]          (2.6)
        B = -(k/pi) (sin^2 U2 - sin^2 U1) = -(4k/pi) q mu          (2.8)

    One formula covers every regime; ``U1 < 0`` when ``c/k < b`` (the rising side of
    the loop lies entirely at ``x > 0``). Eq 2.5 as printed has ``(sin 2U1 - sin 2U2)/2``
    where the integral gives ``-(sin 2U1 + sin 2U2)/2``; only the corrected form
    reduces to eq 2.6, which is right.
    """
    mu = np.clip(mu, 0.0, 1.0)
    q = np.clip(np.minimum(q, 1.0 - mu), 0.0, None)
    s1 = np.clip(q - mu, -1.0, 1.0)
    s2 = np.clip(q + mu, -1.0, 1.0)
    G = (k / np.pi) * (
        np.arcsin(s1) + np.arcsin(s2) + s1 * np.sqrt(1.0 - s1 * s1) + s2 * np.sqrt(1.0 - s2 * s2)
    )
    B = -(k / np.pi) * (s2 * s2 - s1 * s1)
    return G + 1j * B


def lens_df(k, sin_u1, m):
    """The Fig 4.2 loop while ``k b <= c``: eqs 4.6 and 4.7 with the gain ``k`` restored.

    ``sin U1 = min(c/(kA) + m, 1)`` (``= 1``: the unsaturated quadrilateral, whose DF
    ``k [(1 - m) - j 2m/pi]`` is the printed non-saturated form)::

        G = (2k/pi) [(1 - m/sin U1) U1 + (sin U1 - m) cos U1]     (4.6)
        B = -(2k/pi) m sin U1                                     (4.7)
    """
    s = np.clip(sin_u1, 0.0, 1.0)
    u1 = np.arcsin(s)
    # sin U1 = 0 only for c = 0 and m = 0, where the output is identically 0
    m_over_s = ratio(m, s, 0.0)
    G = _TWO_OVER_PI * k * ((1.0 - m_over_s) * u1 + (s - m) * np.sqrt(1.0 - s * s))
    B = -_TWO_OVER_PI * k * m * s
    return G + 1j * B


def fig42_df(k, r, m):
    """Describing function of the Fig 4.2 loop in all four regimes.

    Parameters
    ----------
    k : array_like
        Slope of the steep sides.
    r : array_like
        ``c / (k A)`` (``inf`` without saturation or at ``A = 0``).
    m : array_like
        ``b / A``; clipped to ``[0, 1]``.

    Notes
    -----
    * ``m <= r`` (``k b <= c``): quadrilateral or lens, eqs 4.6/4.7 (:func:`lens_df`);
    * ``m > r`` and ``r <= 1 - m`` (saturated, ``k b > c``): the clipped backlash,
      eqs 2.6/2.8 with ``b = m A`` (:func:`backlash_df`);
    * ``m > r > 1 - m`` (only for ``m > 0.5``): the quadrilateral whose lower vertex
      ``(0, -k b)`` is cut at ``-c``; not treated in the thesis. Its DF is the segment
      sum of :func:`segments_df` over the ascending branch ``(1-2m) k x - k b``,
      ``-c``, ``k (x - b)``.
    """
    m = np.clip(m, 0.0, 1.0)
    lens = lens_df(k, np.minimum(r + m, 1.0), m)
    clipped_sat = backlash_df(k, r, m)
    # cut quadrilateral; inputs are sanitised so the unused branches stay finite
    rr = np.minimum(r, 1.0)
    den = np.where(2.0 * m - 1.0 > 0.0, 2.0 * m - 1.0, 1.0)
    u_low = np.clip(-(m - rr) / den, -1.0, 0.0)
    u_high = np.clip(m - rr, 0.0, 1.0)
    cut = segments_df(
        [-1.0, u_low, u_high, 1.0], [k * (1.0 - 2.0 * m), 0.0, k], [-k * m, -k * rr, -k * m]
    )
    return np.where(m <= r, lens, np.where(r <= 1.0 - m, clipped_sat, cut))


def backlash_branch(x, amplitude, k, b, c):
    """Ascending branch of the clipped backlash (Figs 2.3/2.4).

    ``y = clip(k (x - b), y_bottom, c)`` with ``y_bottom = -min(c, k max(A - b, 0))``:
    the play keeps the output at the bottom of the previous half-cycle until the input
    has risen by ``2 b``; ``y = 0`` for ``A <= b``.
    """
    b = np.maximum(b, 0.0)
    bottom = -np.minimum(c, k * np.maximum(amplitude - b, 0.0))
    return np.minimum(np.maximum(k * (x - b), bottom), c)


def fig42_branch(x, amplitude, k, b, c):
    """Ascending branch of the Fig 4.2 loop with half-width ``b`` (``0 <= b <= A``).

    With ``s = c/k + b`` (the saturation point's input) and ``s_eff = min(A, s)``, the
    branch is ``-k (s_eff - b)`` for ``x < -s_eff``, the straight line from
    ``(-s_eff, -k (s_eff - b))`` to ``(0, -k b)``, then ``k (x - b)``, everything
    clipped to ``[-c, c]``. The clip turns the lens into the clipped backlash when
    ``k b > c`` and cuts the lower vertex of the quadrilateral when ``m > r > 1 - m``.
    """
    s_eff = np.minimum(amplitude, c / k + b)
    # s_eff = 0 only at A = 0, where x = b = 0 too
    t = x / np.where(s_eff > 0.0, s_eff, 1.0)
    middle = k * (x - b) - 2.0 * k * b * t
    left = np.where(x < -s_eff, -k * (s_eff - b), middle)
    y = np.where(x >= 0.0, k * (x - b), left)
    return np.minimum(np.maximum(y, -c), c)


def with_frequency_shape(value, frequency):
    """Broadcast a frequency-independent ``N`` against the ``frequency`` argument."""
    shape = np.broadcast_shapes(np.shape(value), np.shape(frequency))
    return np.broadcast_to(value, shape).copy()
