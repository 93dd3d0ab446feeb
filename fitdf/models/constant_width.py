"""Piecewise-linear hysteresis loop of constant width (thesis section II.2, Figs 2.3/2.4).

The loop is a backlash (play) of half-width ``b`` whose output, of slope ``k``, is
clipped at the saturation level ``+-c``. At peak input ``A`` its ascending branch is

    y_up(x) = clip(k (x - b), y_bottom, c),   y_bottom = -min(c, k max(A - b, 0)),

and the descending branch is ``-y_up(-x)``. Regimes of the describing function:

* ``A <= b``: the input never takes up the play, ``N = 0``;
* ``b < A < c/k + b``: not saturated (Fig 2.4), eqs 2.9 and 2.13 with
  ``sin U1 = 1 - 2b/A`` (eq 2.11);
* ``A >= b2 = c/k + b``: saturated (Fig 2.3), eqs 2.6 and 2.8 with
  ``U1 = arcsin(b1/A)``, ``U2 = arcsin(b2/A)``, ``b1 = c/k - b``; ``b1 < 0`` (a loop
  wider than it is tall, ``c/k < b``) is covered by the same formulas.

All regimes are one formula in :func:`fitdf.models._piecewise.backlash_df`.
"""

from __future__ import annotations

import numpy as np

from fitdf.models._piecewise import backlash_branch, backlash_df, ratio, with_frequency_shape
from fitdf.models.base import HysteresisModel
from fitdf.params import ParamSpec

__all__ = ["ConstantWidth", "K_SPEC", "C_SPEC"]

#: Slope of the loop's sides, shared by the piecewise-linear laws.
K_SPEC = ParamSpec(
    "k",
    100.0,
    (1.0, 1e4),
    unit="H",
    description="slope of the loop's sides (unsaturated inductance)",
    equation="eqs 2.6, 2.8",
    log=True,
    quantity="inductance",
)
#: Saturation level of the output, shared by the piecewise-linear laws.
C_SPEC = ParamSpec(
    "c",
    0.03,
    (1e-4, 10.0),
    unit="V s",
    description="saturation flux linkage (np.inf in calls: no saturation)",
    equation="eqs 2.6, 2.8 (C = (b2 - b) K)",
    log=True,
    quantity="flux_linkage",
)


class ConstantWidth(HysteresisModel):
    """Clipped backlash: constant half-width ``b``, slope ``k``, saturation ``c``.

    Examples
    --------
    >>> import numpy as np
    >>> N = ConstantWidth.describing_function(np.array([0.5, 2.0, 100.0]), k=1.0, b=1.0, c=5.0)
    >>> print(np.round(N, 6))           # A <= b; eqs 2.9, 2.13; eqs 2.6, 2.8
    [0.      +0.j       0.5     -0.31831j  0.063632-0.000637j]
    """

    name = "constant_width"
    title = "Piecewise-linear loop of constant width (backlash with saturation)"
    equations = "eqs 2.6, 2.8 (saturated), 2.9, 2.13 (not saturated); Figs 2.3, 2.4"
    params = (
        K_SPEC,
        ParamSpec(
            "b",
            3e-5,
            (1e-8, 1e-1),
            unit="A",
            description="half-width of the loop (coercive current)",
            equation="Fig 2.3; eq 2.11",
            log=True,
            quantity="current",
        ),
        C_SPEC,
    )

    @classmethod
    def ascending_branch(cls, x, amplitude, frequency=0.0, *, k, b, c):
        """Rising branch ``clip(k (x - b), -min(c, k max(A - b, 0)), c)`` (Fig 2.3).

        Parameters
        ----------
        x, amplitude : array_like
            Input on the branch (``-A <= x <= A``) and peak input ``A``.
        frequency : array_like
            Ignored (the law is rate independent).
        k, b, c : array_like
            Slope, half-width (negative values act as 0) and saturation level.
        """
        return backlash_branch(
            np.asarray(x, float),
            np.asarray(amplitude, float),
            np.asarray(k, float),
            np.asarray(b, float),
            np.asarray(c, float),
        )

    @classmethod
    def describing_function(cls, amplitude, frequency=0.0, *, k, b, c):
        """Closed-form ``N(A) = G + jB`` of eqs 2.6/2.8 and 2.9/2.13.

        Parameters
        ----------
        amplitude : array_like
            Peak input ``A`` (A).
        frequency : array_like
            Ignored, but broadcast into the result's shape.
        k : array_like
            Slope (H).
        b : array_like
            Half-width (A); may be an array broadcasting with ``amplitude`` (a width
            law ``b(A, f)`` composed by another model). Negative values act as 0: a
            passive core cannot run its loop anticlockwise.
        c : array_like
            Saturation level (V s); ``np.inf`` for the unsaturated loop of Fig 2.4.

        Returns
        -------
        numpy.ndarray of complex
            ``N`` (H), ``Im N <= 0``. ``N = 0`` for ``A <= b``; at ``A = 0`` with
            ``b = 0`` the limit ``k`` (linear gain) is returned.
        """
        A = np.asarray(amplitude, float)
        k = np.asarray(k, float)
        b = np.maximum(np.asarray(b, float), 0.0)
        c = np.asarray(c, float)
        mu = ratio(b, A, 0.0)  # b = A = 0: the linear limit
        r = ratio(c, k * A, np.inf)
        return with_frequency_shape(backlash_df(k, r, mu), frequency)
