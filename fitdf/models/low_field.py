"""What the laws give at low field amplitude, against Rayleigh's law (eqs 3.1-3.11).

Rayleigh's law ``mu = mu_i + nu H_m`` gives the parabolic loop of eq 3.7, whose describing
function (:func:`fitdf.models.rayleigh.rayleigh_describing_function`) is

    N(A) = mu_i + gamma A - j (4 / (3 pi)) gamma A,

an in-phase part rising linearly from ``mu_i`` and a quadrature part linear in ``A`` (the
loss per cycle ``-pi A^2 Im N = (4/3) gamma A^3``, eq 3.15), their ratio
``-Im N / (Re N - mu_i) = 4 / (3 pi) = 0.424``. :func:`rayleigh_slopes` reads these two
slopes and the ratio off any law's ``N``; the limits of the laws as ``A -> 0``:

* **Preisach** (any density ``q(h, u)`` finite and continuous at the origin): for ``A``
  below the scale on which ``q`` changes, every relay of the triangle ``T(A, -A)`` has the
  density ``q(0, 0)``, ``E(x, -A) = q(0, 0) (x + A)^2 / 4``, and the loop is eq 3.7 exactly
  with ``gamma = lambda_irr q(0, 0)`` and ``mu_i`` the reversible inductance. The Gaussian
  coercive density ``N(i_c, (sigma_c i_c)^2)`` gives ``q(0, 0) ~ exp(-1 / (2 sigma_c^2))``
  (exponentially small for square loops), and it changes by a factor ``e`` over
  ``h ~ sigma_c^2 i_c`` (its logarithmic slope at 0 is ``1 / (sigma_c^2 i_c)``): the Rayleigh
  region ends there, after which ``Re N`` rises exponentially, not linearly
  (:func:`fitdf.models.preisach.rayleigh_constant`).
* **Jiles-Atherton**: after a reversal ``M_irr`` is frozen until ``M_an`` catches up, then
  relaxes as ``dM_irr/dH_e = (M_an - M_irr)/k``. For ``A << k`` the steady loop of
  ``M_irr`` is flat from the tip to ``H_e ~ 0`` and then the parabola
  ``-m + chi H_e^2 / (2k)`` (``chi = lambda_s / (3a)``, ``m = chi A_e^2 / (4k)``); eqs 2.1,
  2.2 give ``Re = -Im = 2 chi A_e / (3 pi k)`` for that part, and the reversible part and
  the mean field (``H = H_e - alpha M``, ``alpha chi = zeta``) map it to
  (:func:`ja_low_field`)::

      N -> L0 + g A (1 - j),   L0 = c chi / (1 - zeta c),
      g = 2 (1 - c) chi / (3 pi k (1 - zeta c)^3).

  The in-phase part rises linearly and the loss grows as ``A^3``, as in Rayleigh's law,
  but the ratio ``-Im N / (Re N - L0)`` is 1, not ``4 / (3 pi)``: its small loops carry
  2.36 times the loss of a Rayleigh loop of the same permeability rise.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["RAYLEIGH_RATIO", "rayleigh_slopes", "ja_low_field"]

#: ``-Im N / (Re N - mu_i)`` of Rayleigh's loop (eq 3.7): ``4 / (3 pi)``.
RAYLEIGH_RATIO = 4.0 / (3.0 * math.pi)


def rayleigh_slopes(model, amplitudes, frequency=0.0, *, floor=1e-9, **theta) -> dict:
    """Rayleigh's constants as a law's ``N`` gives them at each amplitude.

    Parameters
    ----------
    model : HysteresisModel subclass
    amplitudes : array_like
        Peak currents ``A`` (A), positive.
    floor : float
        ``mu_i`` is ``Re N`` at ``floor * min(amplitudes)``.

    Returns
    -------
    dict
        ``mu_i`` (H); per amplitude ``in_phase`` ``(Re N - mu_i) / A`` and ``quadrature``
        ``-Im N 3 pi / (4 A)`` (both ``gamma`` for a Rayleigh loop, H/A) and ``ratio``
        ``-Im N / (Re N - mu_i)`` (:data:`RAYLEIGH_RATIO` for a Rayleigh loop).
    """
    A = np.asarray(amplitudes, dtype=float)
    mu_i = float(np.real(model.describing_function(floor * A.min(), frequency, **theta)))
    N = np.asarray(model.describing_function(A, frequency, **theta))
    rise = N.real - mu_i
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = -N.imag / rise
    return {
        "mu_i": mu_i,
        "in_phase": rise / A,
        "quadrature": -N.imag / (RAYLEIGH_RATIO * A),
        "ratio": ratio,
    }


def ja_low_field(*, lambda_s, a, k, c, zeta, **_) -> tuple[float, float]:
    """``(L0, g)`` of the Jiles-Atherton law's small loops, ``N -> L0 + g A (1 - j)`` (module docstring)."""
    chi = lambda_s / (3.0 * a)
    feedback = 1.0 - zeta * c
    return c * chi / feedback, 2.0 * (1.0 - c) * chi / (3.0 * math.pi * k * feedback**3)
