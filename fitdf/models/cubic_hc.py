"""Fig 4.2 loop whose width follows a cubic coercive-force law (thesis section IV.2).

The coercive force (loop half-width) is ``H_c = alpha H_m - beta H_m^3`` (eq 4.8) with,
as in the K-S magnet steel fit of eq 4.11, a dead zone below ``h0`` and a linear tail
beyond ``h1``. With ``A`` the peak input (``H_m``) the half-width is::

    b(A) = max(alpha (A - h0) - beta A^3, 0)           for A <= h1,
    b(A) = b(h1) + tail_slope (A - h1)                  for A >  h1,

continuous by construction. It sets ``m = b(A)/A`` (clipped to ``[0, 1]``) in the loop
of Fig 4.2 (:class:`~fitdf.models.proportional_width.ProportionalWidthFig42`, eqs 4.6 and
4.7), exactly as the thesis substitutes eq 4.11 into eqs 4.6/4.7 for Graph 4.7.

:class:`CubicHc` is fitted in ``(h1, m1, tail_slope, h0_ratio, bend)`` instead of eq 4.8's
``(alpha, beta, h0, h1, tail_slope)`` (:func:`cubic_law` and :func:`cubic_shape` convert):
``m1 = b(h1)/h1`` is the loop's relative width (``m`` of eq 4.2) where the tail starts,
``h0_ratio = h0/h1`` where the dead zone ends, and ``bend = beta h1^3 / (alpha (h1 - h0))``
the fraction of the linear rise that the cubic term takes back at ``h1``, so that
``alpha = m1 / ((1 - h0_ratio)(1 - bend))``, ``h0 = h0_ratio h1`` and
``beta = bend m1 / ((1 - bend) h1^2)``. Rows on the tail determine ``b(h1) = m1 h1``, one
number for eq 4.8's three constants; ``h0_ratio`` and ``bend`` only shape the law below the
rows, and the data leave them as free axes of the box instead of a curved ridge through
``alpha``, ``beta`` and ``h0``. The family is eq 4.8's with ``0 <= h0 < h1`` and
``b(h1) > 0``; the bounds add ``bend <= 0.95``, ``h0_ratio <= 0.95`` and ``m1 <= 10``.

Notes
-----
Two printed formulas are corrected here:

* eq 4.11 as printed is discontinuous at ``H_m = 5``: the cubic piece gives
  ``0.6*5 - 0.3 - 7.5e-3*125 = 1.7625`` and the tail ``0.04*5 + 1.6 = 1.8``. The model
  starts the tail from the cubic's value (``1.7625 + 0.04 (H_m - 5)``); the printed law
  is kept as :func:`ks_magnet_steel_hc` for Graph 4.6. The printed cubic is also
  slightly negative just above 0.5 (``-9.4e-4`` at 0.5, zero at ~0.5016); the model
  clips it at 0.
* eq 4.9 as printed, ``H_c = H_m/a - b H_m^3 / (a (a + b H_m))``, has the wrong power:
  ``H/a - H/(a + bH) = b H^2 / (a (a + bH))``, so the Kennelly law ``H_c = H/(a + bH)``
  (eq 3.12 solved for ``H_c``) is ``H/a - b H^2/(a (a + bH))``. Eq 4.10,
  ``beta = b / (H_max a (a + b H_max))``, is what matching ``beta H_max^3`` to the
  ``H^2`` form at ``H_max`` gives, so 4.10 is right and only 4.9 is misprinted.
  :func:`cubic_from_kennelly` implements 4.10 (and ``alpha = 1/a``).
"""

from __future__ import annotations

import numpy as np

from fitdf.models._piecewise import fig42_branch, fig42_df, ratio, with_frequency_shape
from fitdf.models.base import HysteresisModel
from fitdf.models.constant_width import C_SPEC, K_SPEC
from fitdf.params import ParamSpec

__all__ = [
    "CubicHc",
    "WIDEST_LOOP_MARGIN",
    "cubic_width",
    "cubic_law",
    "cubic_shape",
    "cubic_from_kennelly",
    "ks_magnet_steel_hc",
    "KS_MAGNET_STEEL",
    "KS_MAGNET_STEEL_SHAPE",
]

#: Eq 4.11 (K-S magnet steel, thesis field units) in the parameters of :func:`cubic_width`.
KS_MAGNET_STEEL = {"alpha": 0.6, "beta": 7.5e-3, "h0": 0.5, "h1": 5.0, "tail_slope": 0.04}


def cubic_width(amplitude, alpha, beta, h0, h1, tail_slope):
    """Continuous coercive-force law ``b(A)``: eq 4.8 with eq 4.11's dead zone and tail.

    Parameters
    ----------
    amplitude : array_like
        Peak input ``A`` (``H_m``).
    alpha, beta : array_like
        Coefficients of eq 4.8, ``H_c = alpha H_m - beta H_m^3``.
    h0 : array_like
        End of the dead zone: the linear term is ``alpha (A - h0)`` (eq 4.11 writes
        ``0.6 H_m - 0.3 = 0.6 (H_m - 0.5)``).
    h1 : array_like
        Start of the linear tail.
    tail_slope : array_like
        Slope of the tail (0.04 in eq 4.11).

    Returns
    -------
    numpy.ndarray
        ``b(A) >= 0``; continuous in ``A`` (unlike the printed eq 4.11).

    Examples
    --------
    >>> print(np.round(cubic_width(np.array([0.4, 2.0, 5.0, 10.0]), **KS_MAGNET_STEEL), 6))
    [0.     0.84   1.7625 1.9625]
    """
    A = np.asarray(amplitude, float)
    h1 = np.asarray(h1, float)

    def cubic(h):
        return np.maximum(alpha * (h - h0) - beta * h**3, 0.0)

    return np.where(A <= h1, cubic(A), cubic(h1) + tail_slope * (A - h1))


def cubic_law(h1, m1, tail_slope, h0_ratio, bend):
    """Eq 4.8's constants from the fitted coordinates of :class:`CubicHc`.

    Returns ``{"alpha", "beta", "h0", "h1", "tail_slope"}`` for :func:`cubic_width`:
    ``alpha = m1/((1 - h0_ratio)(1 - bend))``, ``h0 = h0_ratio h1``,
    ``beta = bend m1/((1 - bend) h1^2)``, so that ``b(h1) = m1 h1`` (module docstring).
    Needs ``h0_ratio < 1`` and ``bend < 1``.

    Examples
    --------
    >>> law = cubic_law(**KS_MAGNET_STEEL_SHAPE)
    >>> print({n: round(float(v), 12) for n, v in law.items()})
    {'alpha': 0.6, 'beta': 0.0075, 'h0': 0.5, 'h1': 5.0, 'tail_slope': 0.04}
    """
    h1, m1, tail_slope, h0_ratio, bend = (
        np.asarray(v, float) for v in (h1, m1, tail_slope, h0_ratio, bend)
    )
    return {
        "alpha": m1 / ((1.0 - h0_ratio) * (1.0 - bend)),
        "beta": bend * m1 / ((1.0 - bend) * h1**2),
        "h0": h0_ratio * h1,
        "h1": h1,
        "tail_slope": tail_slope,
    }


def cubic_shape(alpha, beta, h0, h1, tail_slope):
    """Inverse of :func:`cubic_law`: the coordinates of :class:`CubicHc` of eq 4.8's law.

    Needs ``0 <= h0 < h1`` and ``b(h1) = alpha (h1 - h0) - beta h1^3 > 0`` (the family
    :class:`CubicHc` fits).
    """
    alpha, beta, h0, h1, tail_slope = (
        np.asarray(v, float) for v in (alpha, beta, h0, h1, tail_slope)
    )
    rise = alpha * (h1 - h0)
    return {
        "h1": h1,
        "m1": (rise - beta * h1**3) / h1,
        "tail_slope": tail_slope,
        "h0_ratio": h0 / h1,
        "bend": beta * h1**3 / rise,
    }


#: :data:`KS_MAGNET_STEEL` in the coordinates of :class:`CubicHc` (:func:`cubic_shape`).
KS_MAGNET_STEEL_SHAPE = {n: float(v) for n, v in cubic_shape(**KS_MAGNET_STEEL).items()}


def ks_magnet_steel_hc(hm):
    """Coercive force of K-S magnet steel, eq 4.11 exactly as printed (Graph 4.6).

    ``0`` for ``H_m <= 0.5``; ``0.6 H_m - 0.3 - 7.5e-3 H_m^3`` for ``0.5 < H_m <= 5``;
    ``0.04 H_m + 1.6`` beyond. Jumps from 1.7625 to 1.8 at ``H_m = 5`` and dips to
    ``-9.4e-4`` just above 0.5 (see the module docstring). ``hm`` is a peak field
    (``>= 0``); negative values are taken by magnitude.
    """
    h = np.abs(np.asarray(hm, float))
    return np.where(
        h <= 0.5, 0.0, np.where(h <= 5.0, 0.6 * h - 0.3 - 7.5e-3 * h**3, 0.04 * h + 1.6)
    )


def cubic_from_kennelly(a, b, hm_max):
    """Coefficients of eq 4.8 from the Kennelly-type law ``H_m/H_c = a + b H_m`` (eq 3.12).

    ``alpha = 1/a`` (same initial slope) and ``beta = b / (hm_max a (a + b hm_max))``
    (eq 4.10: same ``H_c`` at ``hm_max``).

    Parameters
    ----------
    a, b : array_like
        Constants of eq 3.12 (``a_1`` and ``b_1`` of Table 3.1; ``1/b`` is the
        coercivity ``H_c,inf``).
    hm_max : array_like
        Largest peak field of the problem.

    Returns
    -------
    (alpha, beta) : tuple of numpy.ndarray

    Notes
    -----
    Eq 4.9 is misprinted with ``H_m^3`` in the second term; the exact identity is
    ``H/(a + bH) = H/a - b H^2 / (a (a + bH))`` and eq 4.10 follows from it.

    Examples
    --------
    >>> alpha, beta = cubic_from_kennelly(0.3, 1 / 0.037, 0.2)   # 4-79 Mo Permalloy
    >>> hm = 0.2
    >>> print(round(float(alpha * hm - beta * hm**3), 9), round(hm / (0.3 + hm / 0.037), 9))
    0.035054477 0.035054477
    """
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    hm_max = np.asarray(hm_max, float)
    return 1.0 / a, b / (hm_max * a * (a + b * hm_max))


#: :meth:`CubicHc.limit_warnings` names the rows whose width is within this fraction of the
#: widest loop, ``b(A) = A`` (a posterior near the clip is as hard to sample as one on it).
WIDEST_LOOP_MARGIN = 0.01


class CubicHc(HysteresisModel):
    """Fig 4.2 loop with the cubic coercive-force width law of eqs 4.8 and 4.11.

    Fitted in ``(k, c, h1, m1, tail_slope, h0_ratio, bend)``; eq 4.8's ``alpha``, ``beta``
    and ``h0`` follow from :func:`cubic_law` (module docstring: why).

    Examples
    --------
    >>> N = CubicHc.describing_function(np.array([0.3, 2.0]), k=1.0, c=np.inf, **KS_MAGNET_STEEL_SHAPE)
    >>> print(np.round(N, 6))                  # dead zone: linear gain; then m = 0.42
    [1.  +0.j      0.58-0.26738j]
    """

    name = "cubic_hc"
    title = "Fig 4.2 loop, width from a cubic coercive-force law with dead zone and tail"
    equations = "eqs 4.6, 4.7 with 4.8 and 4.11 (made continuous); 4.9, 4.10 for alpha, beta"
    # The width clips at the widest loop (m = 1) and the width law has three joints:
    # chi-square has kinks and ledges, and the usual few starts can all miss the best basin.
    start_multiple = 4
    params = (
        K_SPEC,
        C_SPEC,
        ParamSpec(
            "h1",
            3e-4,
            (1e-7, 1.0),
            unit="A",
            description="start of the linear tail of the width law",
            equation="eq 4.11 (5)",
            log=True,
            quantity="current",
        ),
        ParamSpec(
            "m1",
            0.1,
            (1e-4, 10.0),
            unit="1",
            description="relative loop width b(h1)/h1 where the tail starts (above 1: the widest loop there)",
            equation="eq 4.2's m at h1 (eq 4.11: 1.7625/5)",
            log=True,
        ),
        ParamSpec(
            "tail_slope",
            1e-3,
            (1e-6, 1.0),
            unit="1",
            description="slope of the width law beyond h1",
            equation="eq 4.11 (0.04)",
            log=True,
        ),
        ParamSpec(
            "h0_ratio",
            0.03,
            (1e-5, 0.95),
            unit="1",
            description="end of the dead zone as a fraction of h1, h0/h1 (loop without width below h0)",
            equation="eq 4.11 (0.5/5)",
            log=True,
            limits=(0.0, 1.0),
        ),
        ParamSpec(
            "bend",
            0.1,
            (0.0, 0.95),
            unit="1",
            description="fraction of the linear rise alpha (h1 - h0) that the cubic term beta h1^3 takes back at h1",
            equation="eq 4.8 (eq 4.11: 0.9375/2.7)",
            limits=(0.0, 1.0),
        ),
    )

    @classmethod
    def _m(cls, A, h1, m1, tail_slope, h0_ratio, bend):
        law = cubic_law(h1, m1, tail_slope, h0_ratio, bend)
        b = cubic_width(A, **law)
        # A = 0: b/A -> 0 inside the dead zone (h0 > 0), -> alpha when h0 = 0
        m0 = np.where(np.asarray(h0_ratio) > 0.0, 0.0, law["alpha"])
        return np.clip(ratio(b, A, m0), 0.0, 1.0)

    @classmethod
    def limit_warnings(cls, amplitude, *, h1, m1, tail_slope, h0_ratio, bend, **_):
        """Rows whose eq 4.8 width reaches the widest Fig 4.2 loop, ``b(A) >= A``.

        ``m = b/A`` is clipped at 1 (a loop as wide as the input swing; eqs 4.6/4.7 at
        ``m = 1``), so where the law asks for more, the clip sets the loop and the width
        law is bounded by the data only from one side. The likelihood has a kink along
        ``m = 1``: a posterior that sits there (the square-loop Deltamax blocks B.2 and
        B.5) is one that random-walk and independence moves explore slowly, so this names
        the cause of such a chain's slow mixing.
        """
        A = np.asarray(amplitude, float).ravel()
        b = cubic_width(A, **cubic_law(h1, m1, tail_slope, h0_ratio, bend))
        widest = (A > 0) & (b >= (1.0 - WIDEST_LOOP_MARGIN) * A)
        if not widest.any():
            return []
        lo, hi = A[widest].min(), A[widest].max()
        return [
            f"the cubic width law reaches the widest loop (b(A) >= {1 - WIDEST_LOOP_MARGIN:g} A) "
            f"at {int(widest.sum())} of {A.size} rows (peak currents {lo:.3g}..{hi:.3g} A): "
            "m = b/A is clipped at 1 there (a loop as wide as the input swing), where the DF's "
            "in-phase part, k (1 - m) below saturation, vanishes; those rows bound the width "
            "law from one side only, and the likelihood has a kink along m = 1, on which "
            "MCMC mixes slowly"
        ]

    @classmethod
    def ascending_branch(
        cls, x, amplitude, frequency=0.0, *, k, c, h1, m1, tail_slope, h0_ratio, bend
    ):
        """Rising branch of the Fig 4.2 loop with ``b = m(A) A``, ``m`` from :func:`cubic_width`."""
        A = np.asarray(amplitude, float)
        m = cls._m(A, h1, m1, tail_slope, h0_ratio, bend)
        return fig42_branch(
            np.asarray(x, float), A, np.asarray(k, float), m * A, np.asarray(c, float)
        )

    @classmethod
    def describing_function(
        cls, amplitude, frequency=0.0, *, k, c, h1, m1, tail_slope, h0_ratio, bend
    ):
        """Closed-form ``N(A)``: eqs 4.6/4.7 (2.6/2.8 when ``k b > c``) with ``m = b(A)/A``.

        Parameters
        ----------
        amplitude : array_like
            Peak input ``A`` (A).
        frequency : array_like
            Ignored, but broadcast into the result's shape.
        k, c : array_like
            Slope (H) and saturation level (V s; ``np.inf``: never saturates).
        h1, m1, tail_slope, h0_ratio, bend : array_like
            Width law, see :func:`cubic_law` and :func:`cubic_width`.

        Returns
        -------
        numpy.ndarray of complex
            ``N`` (H). Inside the dead zone ``N = k`` (up to saturation): with ``H_c = 0``
            everywhere the law is the single-valued saturation, as the thesis notes.
        """
        A = np.asarray(amplitude, float)
        k = np.asarray(k, float)
        m = cls._m(A, h1, m1, tail_slope, h0_ratio, bend)
        r = ratio(np.asarray(c, float), k * A, np.inf)
        return with_frequency_shape(fig42_df(k, r, m), frequency)
