"""Fig 4.2 loop whose width follows a cubic coercive-force law (thesis section IV.2).

The coercive force (loop half-width) is ``H_c = alpha H_m - beta H_m^3`` (eq 4.8) with,
as in the K-S magnet steel fit of eq 4.11, a dead zone below ``h0`` and a linear tail
beyond ``h1``. With ``A`` the peak input (``H_m``) the half-width is

    b(A) = max(alpha (A - h0) - beta A^3, 0)           for A <= h1,
    b(A) = b(h1) + tail_slope (A - h1)                  for A >  h1,

continuous by construction. It sets ``m = b(A)/A`` (clipped to ``[0, 1]``) in the loop
of Fig 4.2 (:class:`~fitdf.models.proportional_width.ProportionalWidthFig42`, eqs 4.6 and
4.7), exactly as the thesis substitutes eq 4.11 into eqs 4.6/4.7 for Graph 4.7.

Thesis discrepancies found and handled here:

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
    "cubic_from_kennelly",
    "ks_magnet_steel_hc",
    "KS_MAGNET_STEEL",
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

    Examples
    --------
    >>> N = CubicHc.describing_function(np.array([0.3, 2.0]), k=1.0, c=np.inf, **KS_MAGNET_STEEL)
    >>> print(np.round(N, 6))                  # dead zone: linear gain; then m = 0.42
    [1.  +0.j      0.58-0.26738j]
    """

    name = "cubic_hc"
    title = "Fig 4.2 loop, width from a cubic coercive-force law with dead zone and tail"
    equations = "eqs 4.6, 4.7 with 4.8 and 4.11 (made continuous); 4.9, 4.10 for alpha, beta"
    # The width clips at the widest loop (m = 1) and the width law has three joints:
    # chi-square has kinks and ledges. With 6 starts the polishes can all end far above the
    # best basin on Deltamax (B.5, seeds 0/1/2: 4492/23377/4072, 24 starts 4474/4162/4015).
    start_multiple = 4
    params = (
        K_SPEC,
        C_SPEC,
        ParamSpec(
            "alpha",
            0.1,
            (1e-3, 10.0),
            unit="1",
            description="initial slope of the coercive current vs amplitude",
            equation="eq 4.8 (alpha = 1/a, eq 4.9)",
            log=True,
        ),
        ParamSpec(
            "beta",
            1e5,
            (1e-2, 1e12),
            unit="A^-2",
            description="cubic bending of the coercive-current law",
            equation="eq 4.8 (eq 4.10)",
            log=True,
            quantity="per_current_squared",
        ),
        ParamSpec(
            "h0",
            1e-5,
            (1e-8, 1e-2),
            unit="A",
            description="end of the dead zone (loop without width below it)",
            equation="eq 4.11 (0.5)",
            log=True,
            quantity="current",
        ),
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
            "tail_slope",
            1e-3,
            (1e-6, 1.0),
            unit="1",
            description="slope of the width law beyond h1",
            equation="eq 4.11 (0.04)",
            log=True,
        ),
    )

    @classmethod
    def _m(cls, A, alpha, beta, h0, h1, tail_slope):
        b = cubic_width(A, alpha, beta, h0, h1, tail_slope)
        # A = 0: b/A -> 0 inside the dead zone (h0 > 0), -> alpha when h0 = 0
        m0 = np.where(np.asarray(h0) > 0.0, 0.0, alpha)
        return np.clip(ratio(b, A, m0), 0.0, 1.0)

    @classmethod
    def limit_warnings(cls, amplitude, *, alpha, beta, h0, h1, tail_slope, **_):
        """Rows whose eq 4.8 width reaches the widest Fig 4.2 loop, ``b(A) >= A``.

        ``m = b/A`` is clipped at 1 (a loop as wide as the input swing; eqs 4.6/4.7 at
        ``m = 1``), so where the law asks for more, the clip sets the loop and ``alpha``,
        ``beta`` are bounded by the data only from one side. The likelihood has a kink
        along ``m = 1``: a posterior that sits there (the square-loop Deltamax blocks B.2
        and B.5, with ``alpha`` ~ 1) is one that random-walk and independence moves
        explore slowly, so this names the cause of such a chain's slow mixing.
        """
        A = np.asarray(amplitude, float).ravel()
        b = cubic_width(A, alpha, beta, h0, h1, tail_slope)
        widest = (A > 0) & (b >= (1.0 - WIDEST_LOOP_MARGIN) * A)
        if not widest.any():
            return []
        lo, hi = A[widest].min(), A[widest].max()
        return [
            f"the cubic width law reaches the widest loop (b(A) >= {1 - WIDEST_LOOP_MARGIN:g} A) "
            f"at {int(widest.sum())} of {A.size} rows (peak currents {lo:.3g}..{hi:.3g} A): "
            "m = b/A is clipped at 1 there (a loop as wide as the input swing), where the DF's "
            "in-phase part, k (1 - m) below saturation, vanishes; those rows bound alpha and "
            "beta from one side only, and the likelihood has a kink along m = 1, on which "
            "MCMC mixes slowly"
        ]

    @classmethod
    def ascending_branch(
        cls, x, amplitude, frequency=0.0, *, k, c, alpha, beta, h0, h1, tail_slope
    ):
        """Rising branch of the Fig 4.2 loop with ``b = m(A) A``, ``m`` from :func:`cubic_width`."""
        A = np.asarray(amplitude, float)
        m = cls._m(A, alpha, beta, h0, h1, tail_slope)
        return fig42_branch(
            np.asarray(x, float), A, np.asarray(k, float), m * A, np.asarray(c, float)
        )

    @classmethod
    def describing_function(
        cls, amplitude, frequency=0.0, *, k, c, alpha, beta, h0, h1, tail_slope
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
        alpha, beta, h0, h1, tail_slope : array_like
            Width law, see :func:`cubic_width`.

        Returns
        -------
        numpy.ndarray of complex
            ``N`` (H). Inside the dead zone ``N = k`` (up to saturation): with ``H_c = 0``
            everywhere the law is the single-valued saturation, as the thesis notes.
        """
        A = np.asarray(amplitude, float)
        k = np.asarray(k, float)
        m = cls._m(A, alpha, beta, h0, h1, tail_slope)
        r = ratio(np.asarray(c, float), k * A, np.inf)
        return with_frequency_shape(fig42_df(k, r, m), frequency)
