"""Coercive force growing with frequency (eq 3.23) on the proportional-width loop (eq 4.2).

Section III.9 proposes ``H_c = a f + b f**2`` (eq 3.23) as the correction, for one input
amplitude, to the coercive force read from the static ``H_c(H_m)`` curve (the text after
eq 3.23: "first ... find the value of ``H_c`` corresponding to this amplitude; then ...
add the correction for ``f``"). With the amplitude law of section IV.1, ``H_c = m A``
(eq 4.2), the half-width of the Fig 2.3 loop becomes

    b(A, f) = m A + hc_a f + hc_b f**2,

and the describing function is that of the constant-width loop (eqs 2.6/2.8, 2.9/2.13)
evaluated at this ``b`` -- legitimately so, by the argument of section IV.1 that ``b`` is
constant over one cycle of a given amplitude and frequency. ``N`` depends on ``A`` and
``f``; below ``A = b(A, f)``, i.e. ``A (1 - m) <= hc_a f + hc_b f**2``, the loop has no
height and ``N = 0`` (the backlash-like start of the Deltamax curves, Graph 5.16).

Thesis discrepancy: eq 3.22 equates the loss *power* of eq 3.14 (W, Steinmetz and eddy
terms ``K_h f B^n + K_e f^2 B^2``) with the loop *energy per cycle* of eq 3.21
(``K_L B_m H_c``, "joules ... per cycle"). Per cycle the losses are
``K_h B^n + K_e f B^2``, so the dimensionally consistent version of eq 3.23 is
``H_c = H_c(A) + a f``: a static part plus a term linear in ``f``. The ``f**2`` term is
kept as the thesis prints it; ``hc_b = 0`` is the corrected law, and a fit can tell
whether the data need ``hc_b``.
"""

from __future__ import annotations

import numpy as np

from fitdf.models.base import HysteresisModel
from fitdf.models.constant_width import C_SPEC, K_SPEC, ConstantWidth
from fitdf.models.proportional_width import M_SPEC
from fitdf.params import ParamSpec

__all__ = ["FrequencyHc", "coercive_current"]


def coercive_current(amplitude, frequency, m, hc_a, hc_b):
    """Half-width ``b(A, f) = m A + hc_a f + hc_b f**2`` (eqs 4.2 and 3.23), in ampere."""
    f = np.asarray(frequency, dtype=float)
    return m * np.abs(np.asarray(amplitude, dtype=float)) + hc_a * f + hc_b * f * f


class FrequencyHc(HysteresisModel):
    """Fig 2.3 loop whose half-width grows with amplitude and frequency (eqs 4.2, 3.23).

    Composes :meth:`ConstantWidth.describing_function` with :func:`coercive_current`;
    nothing of the constant-width closed form is repeated here.

    Examples
    --------
    >>> import numpy as np
    >>> N = FrequencyHc.describing_function(np.array([1e-5, 1e-3]), np.array([10.0, 10.0]),
    ...                                     k=100.0, c=0.03, m=0.3, hc_a=2e-6, hc_b=0.0)
    >>> bool(N[0] == 0), bool(N[1].imag < 0)       # A below b(A, f); a lagging loop
    (True, True)
    """

    name = "frequency_hc"
    title = "Constant-width loop with b = m A + a f + b f^2 (frequency-dependent coercive force)"
    equations = "eqs 3.23, 4.2 in eqs 2.6/2.8, 2.9/2.13 (Fig 2.3)"
    frequency_dependent = True
    params = (
        K_SPEC,
        C_SPEC,
        M_SPEC,
        ParamSpec(
            "hc_a",
            2e-6,
            (0.0, 2e-5),
            unit="A/Hz",
            description="coercive current per hertz (a of eq 3.23)",
            equation="eq 3.23",
            quantity="current_per_hz",
            limits=(0.0, float("inf")),
        ),
        ParamSpec(
            "hc_b",
            4e-8,
            (0.0, 4e-7),
            unit="A/Hz^2",
            description="coercive current per hertz squared (b of eq 3.23; 0 in the "
            "dimensionally consistent law)",
            equation="eq 3.23",
            quantity="current_per_hz2",
            limits=(0.0, float("inf")),
        ),
    )

    @classmethod
    def ascending_branch(cls, x, amplitude, frequency=0.0, *, k, c, m, hc_a, hc_b):
        """Rising branch of the Fig 2.3 loop with half-width ``b(A, f)``."""
        b = coercive_current(amplitude, frequency, m, hc_a, hc_b)
        return ConstantWidth.ascending_branch(x, amplitude, frequency, k=k, b=b, c=c)

    @classmethod
    def describing_function(cls, amplitude, frequency=0.0, *, k, c, m, hc_a, hc_b):
        """Complex inductance ``N(A, f)`` (H); broadcasts over all arguments.

        Parameters
        ----------
        amplitude : array_like
            Current amplitude ``A`` (A).
        frequency : array_like
            Frequency ``f`` (Hz).
        k, c : array_like
            Slope (H) and saturation flux linkage (V s; ``inf``: none) of Fig 2.3.
        m : array_like
            Width-to-amplitude ratio of eq 4.2.
        hc_a, hc_b : array_like
            Frequency coefficients of eq 3.23 (A/Hz, A/Hz^2).

        Returns
        -------
        numpy.ndarray of complex
            ``N`` with ``Im N <= 0``; 0 where ``A <= b(A, f)``.
        """
        b = coercive_current(amplitude, frequency, m, hc_a, hc_b)
        return ConstantWidth.describing_function(amplitude, frequency, k=k, b=b, c=c)
