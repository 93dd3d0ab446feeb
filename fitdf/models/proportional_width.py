"""Piecewise-linear loops whose width is proportional to the amplitude (thesis IV.1).

Both laws put ``b = m A`` (eq 4.2, Fig 4.1) into a piecewise-linear loop of slope ``k``
saturating at ``+-c``; they saturate from ``A_sat = (c/k) / (1 - m)`` on. Below
``A_sat`` the describing function does not depend on ``A`` (a point in the Nyquist
plane, Graphs 4.1 and 4.4), except for the Fig 4.2 loop with ``m > 0.5`` (see below).

:class:`ProportionalWidth` -- the loop of Fig 2.3 (clipped backlash) with ``b = m A``:
eqs 4.3 (``U1 = arcsin(c/(kA) - m)``, ``U2 = arcsin(c/(kA) + m)`` in eqs 2.6/2.8)
when saturated and eqs 4.4/4.5 (``sin U1 = 1 - 2m``) when not.

:class:`ProportionalWidthFig42` -- the second loop shape of Fig 4.2. The figure is
missing from the available copy; the definition below was reconstructed from eqs
4.6, 4.7, the printed non-saturated forms, and the text (segment O-S of slope
``1 - 2m``; "impractical" for ``m > 0.5``; same DF as the first model at ``m = 0.5``)
and is the definition used by fitdf. With ``b = m A``:

* **not saturated**, ``(1 - m) k A <= c`` and ``k b <= c``: the quadrilateral with
  vertices ``(-A, -(1-m)kA)``, ``(0, -kb)``, ``(A, (1-m)kA)``, ``(0, kb)``. Its ascending
  branch is ``k (x - b)`` for ``x >= 0`` and ``(1 - 2m) k x - k b`` for ``x < 0`` (the
  thesis's segment O-S; at ``m = 0.5`` it is flat and the loop is the first model's
  unsaturated loop; for ``m > 0.5`` its slope is negative). The first harmonic of
  that branch is ``N = k [(1 - m) - j 2m/pi]``, the printed non-saturated form with
  the gain ``k`` restored.
* **saturated, lens**, ``A > A_sat`` and ``b <= c/k``: a lens whose tips are the
  saturation points ``+-(s, c)``, ``s = c/k + b``, and whose vertices are ``(0, +-kb)``.
  Ascending branch: ``-c`` up to ``x = -s``, the straight line from ``(-s, -c)`` to
  ``(0, -kb)``, then ``k (x - b)`` up to ``(s, c)``, then ``c``. The segment sum
  (eqs 2.1/2.2 integrated over the four pieces) gives exactly eqs 4.6/4.7 with
  ``sin U1 = s/A = c/(kA) + m``: the lens deviates from its axis (a saturation of
  slope ``c/s`` through ``(+-s, +-c)``) by a function that is even in ``x``, so the
  real part is that of the axis, ``(2c/(pi s)) (U1 + sin U1 cos U1)``, which is 4.6
  since ``c/s = k (1 - m/sin U1)``; the imaginary part is ``-(2k/pi) m sin U1`` (4.7).
  At ``A = A_sat`` (``sin U1 = 1``) this meets the quadrilateral.
* **saturated, clipped**, ``A > A_sat`` and ``b > c/k``, i.e. ``A > c/(k m)`` (from
  ``A_sat`` on for ``m >= 0.5``; at large amplitudes for any ``m > 0``): the middle
  segment would run from ``-c`` below ``-c``; clipped at ``-c`` the loop is exactly the
  first model's clipped backlash, so the DF is eqs 2.6/2.8 with ``b = m A``. Eqs
  4.6/4.7 do **not** hold there. At ``m = 0.5`` the two models coincide at every ``A``.
* **not saturated, cut**, ``c/(k m) < A < A_sat`` (only for ``m > 0.5``; not treated
  in the thesis, which calls ``m > 0.5`` impractical): the quadrilateral's lower
  vertex ``(0, -kb)`` lies below ``-c`` and is cut by the same clip, so the output never
  exceeds the saturation level; the DF then depends on ``A`` and is the closed-form
  segment sum of :func:`fitdf.models._piecewise.segments_df`. Without saturation
  (``c = inf``, Graph 4.4) this regime does not occur.

The ascending branch implemented below is exactly this loop (one formula with a clip
to ``+-c``), so the numerical referee checks every regime, and the DF is continuous
across all regime boundaries.
"""

from __future__ import annotations

import numpy as np

from fitdf.models._piecewise import (
    backlash_branch,
    backlash_df,
    fig42_branch,
    fig42_df,
    ratio,
    with_frequency_shape,
)
from fitdf.models.base import HysteresisModel
from fitdf.models.constant_width import C_SPEC, K_SPEC
from fitdf.params import ParamSpec

__all__ = ["ProportionalWidth", "ProportionalWidthFig42", "saturation_amplitude", "M_SPEC"]

#: Width-to-amplitude ratio of eq 4.2, shared by both laws.
M_SPEC = ParamSpec(
    "m",
    0.3,
    (0.0, 0.99),
    unit="1",
    description="loop half-width over amplitude, b = m A",
    equation="eq 4.2, Fig 4.1",
    limits=(0.0, 1.0),
)


def saturation_amplitude(k, c, m):
    """Amplitude at which the loop starts to saturate, ``A_sat = (c/k) / (1 - m)``.

    From section IV.1 (after eq 4.5): the tips of either loop reach ``+-c`` there.
    ``inf`` for ``m >= 1``. For the Fig 4.2 loop with ``m > 0.5`` the lower vertex
    ``(0, -k m A)`` reaches ``-c`` earlier, at ``A = c/(k m)``, and the describing
    function depends on ``A`` from there on.
    """
    with np.errstate(divide="ignore"):
        return (np.asarray(c, float) / np.asarray(k, float)) / np.maximum(
            1.0 - np.asarray(m, float), 0.0
        )


def _clip_m(m):
    # m outside [0, 1] has no loop (negative width, or a width above the amplitude);
    # clipping keeps N continuous for optimisers that step outside the bounds
    return np.clip(np.asarray(m, float), 0.0, 1.0)


class ProportionalWidth(HysteresisModel):
    """Clipped backlash of Fig 2.3 with half-width ``b = m A`` (eqs 4.2-4.5).

    Examples
    --------
    >>> import numpy as np
    >>> N = ProportionalWidth.describing_function(np.array([1.0, 4.0]), k=1.0, c=5.0, m=0.0)
    >>> print(np.round(N, 12))                 # m = 0: linear gain below saturation
    [1.+0.j 1.+0.j]
    """

    name = "proportional_width"
    title = "Piecewise-linear loop, width proportional to amplitude (Fig 2.3 shape)"
    equations = "eqs 4.2-4.5 (with 2.6, 2.8); Graphs 4.1-4.3"
    params = (K_SPEC, C_SPEC, M_SPEC)

    @classmethod
    def ascending_branch(cls, x, amplitude, frequency=0.0, *, k, c, m):
        """Rising branch of the Fig 2.3 loop with ``b = m A`` (see ``ConstantWidth``)."""
        A = np.asarray(amplitude, float)
        return backlash_branch(
            np.asarray(x, float), A, np.asarray(k, float), _clip_m(m) * A, np.asarray(c, float)
        )

    @classmethod
    def describing_function(cls, amplitude, frequency=0.0, *, k, c, m):
        """Closed-form ``N(A)``: eqs 4.3 with 2.6/2.8 (saturated), 4.4/4.5 (not).

        Parameters
        ----------
        amplitude : array_like
            Peak input ``A`` (A).
        frequency : array_like
            Ignored, but broadcast into the result's shape.
        k, c : array_like
            Slope (H) and saturation level (V s; ``np.inf``: never saturates).
        m : array_like
            ``b / A`` (eq 4.2), clipped to ``[0, 1]``.

        Returns
        -------
        numpy.ndarray of complex
            ``N`` (H). For ``A < A_sat`` it is the amplitude-independent value of eqs
            4.4/4.5, ``k/pi [arcsin(1-2m) + pi/2 + sin(2 arcsin(1-2m))/2]
            - j (4k/pi) m (1-m)``, also returned at ``A = 0`` (the limit).
        """
        A = np.asarray(amplitude, float)
        k = np.asarray(k, float)
        r = ratio(np.asarray(c, float), k * A, np.inf)
        return with_frequency_shape(backlash_df(k, r, _clip_m(m)), frequency)


class ProportionalWidthFig42(HysteresisModel):
    """Second loop shape (Fig 4.2, reconstructed; see the module docstring), ``b = m A``.

    Examples
    --------
    >>> import numpy as np
    >>> N = ProportionalWidthFig42.describing_function(np.array([1.0, 2.0]), k=1.0, c=5.0, m=0.5)
    >>> print(np.round(N, 6))                  # 1 - m - j 2m/pi, independent of A
    [0.5-0.31831j 0.5-0.31831j]
    """

    name = "proportional_width_fig42"
    title = "Piecewise-linear loop of Fig 4.2, width proportional to amplitude"
    equations = "eqs 4.2, 4.6, 4.7 and the non-saturated forms after them; Graphs 4.4, 4.5"
    params = (K_SPEC, C_SPEC, M_SPEC)

    @classmethod
    def ascending_branch(cls, x, amplitude, frequency=0.0, *, k, c, m):
        """Rising branch of the Fig 4.2 loop with ``b = m A`` (module docstring)."""
        A = np.asarray(amplitude, float)
        return fig42_branch(
            np.asarray(x, float), A, np.asarray(k, float), _clip_m(m) * A, np.asarray(c, float)
        )

    @classmethod
    def describing_function(cls, amplitude, frequency=0.0, *, k, c, m):
        """Closed-form ``N(A)`` of the Fig 4.2 loop (eqs 4.6, 4.7; 2.6/2.8 when ``kb > c``).

        Parameters
        ----------
        amplitude : array_like
            Peak input ``A`` (A).
        frequency : array_like
            Ignored, but broadcast into the result's shape.
        k, c : array_like
            Slope (H) and saturation level (V s; ``np.inf``: never saturates).
        m : array_like
            ``b / A`` (eq 4.2), clipped to ``[0, 1]``.

        Returns
        -------
        numpy.ndarray of complex
            ``N`` (H); ``k [(1 - m) - j 2m/pi]`` below saturation (and at ``A = 0``).
        """
        A = np.asarray(amplitude, float)
        k = np.asarray(k, float)
        r = ratio(np.asarray(c, float), k * A, np.inf)
        return with_frequency_shape(fig42_df(k, r, _clip_m(m)), frequency)
