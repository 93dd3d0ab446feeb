"""Preisach law with a Rayleigh population: a relay density finite at the origin.

The Gaussian density of :mod:`fitdf.models.preisach` puts its relays about the coercive
current ``i_c``; when ``sigma_c`` is small its value at the origin,
``f(0) g(0) ~ exp(-1 / (2 sigma_c^2))``, is exponentially small, and so is the Rayleigh
constant of the low-amplitude loop (eqs 3.1, 3.7): the fitted law is a linear inductor
``l_rev`` up to amplitudes near ``i_c``. Soft alloys instead follow Rayleigh's law at low
fields, ``mu = mu_i + nu H_m``, which in Preisach terms is a density finite at the origin
(Néel 1942: domain walls pinned in a random potential switch at small, centred fields).
This law adds that population: a fraction ``f_ray`` of the relay mass is moved from the
Gaussian density ``q_G`` of :class:`~fitdf.models.preisach.Preisach` to

    q_R(alpha, beta) = (1 / (pi i_ray^2)) exp(-(alpha^2 + beta^2) / (2 i_ray^2)),  alpha >= beta,

i.e. the switching inputs ``alpha``, ``beta`` independent normal with deviation ``i_ray``,
restricted to ``alpha >= beta`` (unit mass). The flux linkage is::

    lambda = lambda_s [ (1 - f_rev) ((1 - f_ray) P_G + f_ray P_R) + f_rev (2/pi) atan(x / i_r) ].

Notes
-----
*Everett function.* With ``Phi`` the standard normal distribution function and
``p = Phi(x / i_ray)``, the mass of ``q_R`` in ``beta' >= beta, alpha' <= alpha`` is twice
the probability that two independent normals satisfy ``beta <= beta' <= alpha' <= alpha``::

    E_R(alpha, beta) = (Phi(alpha / i_ray) - Phi(beta / i_ray))^2,

so the rising branch of the steady loop of peak ``A`` is
``P_R(x) = -E_R(A, -A) + 2 E_R(x, -A)``, in closed form.

*Describing function.* ``N = (2 / (pi A^2)) Int y_up'(x) [sqrt(A^2 - x^2) - j x] dx``
(eqs 2.1, 2.2 by parts; :mod:`fitdf.models.preisach`) with
``y_up' = 4 lambda_R (Phi(u) - Phi(-a)) phi(u) / i_ray``, ``u = x / i_ray``,
``a = A / i_ray``, ``lambda_R = (1 - f_rev) f_ray lambda_s``. ``Phi(u) - 1/2`` is odd, so
the in-phase part keeps only ``(Phi(a) - 1/2) Int phi(u) sqrt(A^2 - x^2) dx``, a Bessel
integral; the quadrature part integrates by parts (``u phi = -phi'``)::

    Re N_R = (4 lambda_R / (i_ray sqrt(2 pi))) (Phi(a) - 1/2) [I0(a^2/4) + I1(a^2/4)] e^(-a^2/4),
    Im N_R = -(8 lambda_R i_ray / (pi A^2)) F(a),
    F(a)   = (2 Phi(sqrt(2) a) - 1) / (2 sqrt(pi)) - phi(a) (2 Phi(a) - 1)
           = (a^3/3 - 2 a^5/15 + a^7/30 - ...) / pi.

*Rayleigh limit.* For ``a -> 0``: ``N_R -> gamma_R A - j 4 gamma_R A / (3 pi)`` with
``gamma_R = 2 lambda_R / (pi i_ray^2)``, Rayleigh's loop (eq 3.7) exactly; the law's
Rayleigh constant is ``gamma = gamma_R + (1 - f_ray) gamma_G`` (:func:`rayleigh_constant`)
and its initial inductance ``l_rev``. Rayleigh's region ends near ``A ~ i_ray``: beyond it
the population saturates (``Re N_R -> 4 lambda_R / (pi A)``, a relay's, and its loop area
``-pi A^2 Im N_R`` tends to ``4 lambda_R i_ray / sqrt(pi)``), as the Rayleigh region of real alloys
ends near their coercive field. Material constants (``N`` turns, path ``l_e``, section
``A_e``): ``mu_i = l_rev l_e / (mu_0 N^2 A_e)``, ``eta = gamma l_e^2 / (N^3 A_e)`` of
``B = mu_i H + eta H^2`` (T m^2/A^2) and ``nu = 2 eta / mu_0`` of ``mu = mu_i + nu H``.

References
----------
Néel, L., "Théorie des lois d'aimantation de Lord Rayleigh", Cahiers de Physique 12 (1942).

Bertotti, G., *Hysteresis in Magnetism*, Academic Press (1998), ch. 9 and 13.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import erf, ive, ndtr

from fitdf.models._preisach_everett import (
    _reversible_width,
    preisach_branch,
    preisach_describing_function,
    reversible_part,
)
from fitdf.models._preisach_everett import rayleigh_constant as gaussian_rayleigh_constant
from fitdf.models.base import HysteresisModel
from fitdf.models.preisach import Preisach
from fitdf.params import ParamSpec

__all__ = [
    "PreisachRayleigh",
    "rayleigh_everett",
    "rayleigh_population_branch",
    "rayleigh_population_df",
    "rayleigh_constant",
]

_SQRT_2PI = math.sqrt(2.0 * math.pi)
#: Below this ``a = A / i_ray`` the quadrature part is summed from its series (the closed
#: form loses ~2 log10(1/a) digits to cancellation; the next term is ``a^6 / 100``
#: relative, below 1e-14 here).
_SERIES_A = 0.02


def rayleigh_everett(alpha, beta, *, i_ray):
    """``E_R(alpha, beta) = (Phi(alpha / i_ray) - Phi(beta / i_ray))^2`` for ``alpha > beta``, else 0."""
    alpha = np.asarray(alpha, dtype=float)
    beta = np.asarray(beta, dtype=float)
    d = ndtr(alpha / i_ray) - ndtr(beta / i_ray)
    return np.where(alpha > beta, d * d, 0.0)


def rayleigh_population_branch(x, amplitude, *, i_ray):
    """Normalised rising branch ``P_R(x) = -E_R(A, -A) + 2 E_R(x, -A)`` of the steady loop, in ``[-1, 1]``."""
    A = np.abs(np.asarray(amplitude, dtype=float))
    return -rayleigh_everett(A, -A, i_ray=i_ray) + 2.0 * rayleigh_everett(x, -A, i_ray=i_ray)


def _quadrature_factor(a):
    """``F(a) / a^2``, ``F(a) = Int_{-a}^{a} Phi(u) phi(u) u du`` (module docstring); the series
    at small ``a`` (no cancellation, no underflow of ``a^2``)."""
    a = np.asarray(a, dtype=float)
    a2 = a * a
    series = a * (1.0 / 3.0 - a2 * (2.0 / 15.0 - a2 / 30.0)) / math.pi
    big = np.where(a < _SERIES_A, 1.0, a)  # the closed form where it is used
    closed = (
        (2.0 * ndtr(math.sqrt(2.0) * big) - 1.0) / (2.0 * math.sqrt(math.pi))
        - np.exp(-0.5 * big * big) / _SQRT_2PI * erf(big / math.sqrt(2.0))
    ) / (big * big)
    return np.where(a < _SERIES_A, series, closed)


def rayleigh_population_df(amplitude, *, i_ray):
    """``N_R(A)`` per unit flux linkage of the Rayleigh population (1/A): closed form.

    ``Re = (4 / (i_ray sqrt(2 pi))) (Phi(a) - 1/2) e^(-a^2/4) [I0 + I1](a^2/4)``,
    ``Im = -(8 i_ray / (pi A^2)) F(a)``, ``a = A / i_ray`` (module docstring); 0 at ``A = 0``.
    ``Phi(a) - 1/2`` is taken as ``erf(a / sqrt 2) / 2`` and ``F / a^2`` as such (both exact
    to the last digits down to ``A = 0``).
    """
    A = np.abs(np.asarray(amplitude, dtype=float))
    i_ray = np.asarray(i_ray, dtype=float)
    a = A / i_ray
    z = 0.25 * a * a
    re = 2.0 / (i_ray * _SQRT_2PI) * erf(a / math.sqrt(2.0)) * (ive(0, z) + ive(1, z))
    im = -8.0 / (math.pi * i_ray) * _quadrature_factor(a)
    return re + 1j * im


def rayleigh_constant(*, lambda_s, i_c, sigma_c, i_i, f_rev, f_ray, i_ray, **_):
    """Rayleigh constant ``gamma`` (H/A) of the law's low-amplitude loop (eq 3.7).

    ``gamma = (1 - f_rev) lambda_s [(1 - f_ray) f(0) g(0) + f_ray 2 / (pi i_ray^2)]``: the
    relay density at the origin times the irreversible flux linkage; ``mu0 = l_rev``.
    """
    gauss = gaussian_rayleigh_constant(
        lambda_s=lambda_s, i_c=i_c, sigma_c=sigma_c, i_i=i_i, f_rev=f_rev
    )
    lam_irr = (1.0 - np.asarray(f_rev, float)) * np.asarray(lambda_s, float)
    f_ray = np.asarray(f_ray, float)
    return (1.0 - f_ray) * gauss + f_ray * lam_irr * 2.0 / (math.pi * np.asarray(i_ray, float) ** 2)


class PreisachRayleigh(HysteresisModel):
    """Preisach law whose relay density is finite at the origin: Gaussian plus a Rayleigh population.

    :class:`~fitdf.models.preisach.Preisach` with a fraction ``f_ray`` of its relay mass
    in a population centred on the origin (switching inputs normal with deviation
    ``i_ray``), which gives Rayleigh's law (eqs 3.1, 3.7) below ``A ~ i_ray`` with
    ``mu0 = l_rev`` and :func:`rayleigh_constant`. ``closed_form`` is False (the Gaussian
    population's relay part is a fixed quadrature); the Rayleigh population's part is in
    closed form. Rate independent.

    Examples
    --------
    >>> import numpy as np
    >>> theta = dict(lambda_s=0.03, i_c=1e-3, sigma_c=0.2, i_i=2e-4, l_rev=10.0, f_rev=0.2,
    ...              f_ray=0.1, i_ray=3e-4)
    >>> N = PreisachRayleigh.describing_function(np.array([0.0, 1e-6]), **theta)
    >>> gamma = rayleigh_constant(**theta)
    >>> bool(N[0] == 10.0), bool(abs(N[1] - (10.0 + gamma * 1e-6 * (1 - 4j / (3 * np.pi)))) < 1e-6)
    (True, True)
    """

    name = "preisach_rayleigh"
    title = "Preisach model with a Rayleigh population (relay density finite at the origin)"
    equations = (
        "Preisach (1935); Rayleigh population (Néel 1942) giving eqs 3.1, 3.7 at low fields; "
        "reversible arctangent ~ Frohlich-Kennelly (sec III.1); DF eqs 2.1, 2.2"
    )
    closed_form = False
    params = (
        *Preisach.params,
        ParamSpec(
            "f_ray",
            0.05,
            (1e-4, 0.99),
            "",
            "fraction of the relay mass in the Rayleigh population (switching fields about 0)",
            "Rayleigh population (Néel 1942)",
            log=True,
            limits=(0.0, 1.0),
        ),
        ParamSpec(
            "i_ray",
            2e-4,
            (1e-7, 1e-1),
            "A",
            "rms switching current of the Rayleigh population: the end of Rayleigh's region",
            "Rayleigh population (Néel 1942)",
            log=True,
            quantity="current",
        ),
    )

    @classmethod
    def ascending_branch(
        cls,
        x,
        amplitude,
        frequency=0.0,
        *,
        lambda_s,
        i_c,
        sigma_c,
        i_i,
        l_rev,
        f_rev,
        f_ray,
        i_ray,
    ):
        """``lambda_s [(1 - f_rev)((1 - f_ray) P_G + f_ray P_R) + f_rev (2/pi) atan(x / i_r)]``."""
        P_G = preisach_branch(x, amplitude, i_c=i_c, sigma_c=sigma_c, i_i=i_i)
        P_R = rayleigh_population_branch(x, amplitude, i_ray=i_ray)
        lam = np.asarray(lambda_s, dtype=float)
        w = np.asarray(f_ray, dtype=float)
        irr = (1.0 - np.asarray(f_rev, float)) * lam * ((1.0 - w) * P_G + w * P_R)
        return irr + reversible_part(x, lambda_s=lam, l_rev=l_rev, f_rev=f_rev)

    @classmethod
    def describing_function(
        cls,
        amplitude,
        frequency=0.0,
        *,
        lambda_s,
        i_c,
        sigma_c,
        i_i,
        l_rev,
        f_rev,
        f_ray,
        i_ray,
    ):
        """``N(A)`` (H): reversible part + ``(1 - f_ray)`` Gaussian relays + ``f_ray`` Rayleigh population.

        ``N(0) = l_rev``; ``N -> l_rev + gamma A - j 4 gamma A / (3 pi)`` at small ``A``
        (:func:`rayleigh_constant`). Broadcasts over all arguments.
        """
        A = np.abs(np.asarray(amplitude, dtype=float))
        lam = np.asarray(lambda_s, dtype=float)
        frev = np.asarray(f_rev, dtype=float)
        w = np.asarray(f_ray, dtype=float)
        full = preisach_describing_function(
            A, lambda_s=lam, i_c=i_c, sigma_c=sigma_c, i_i=i_i, l_rev=l_rev, f_rev=frev
        )
        rev = (
            2.0
            * np.asarray(l_rev, float)
            / (1.0 + np.hypot(1.0, A / _reversible_width(lam, l_rev, frev)))
        )
        N = (
            rev
            + (1.0 - w) * (full - rev)
            + w * (1.0 - frev) * lam * rayleigh_population_df(A, i_ray=i_ray)
        )
        shape = np.broadcast_shapes(
            *(
                np.shape(v)
                for v in (
                    amplitude,
                    frequency,
                    lambda_s,
                    i_c,
                    sigma_c,
                    i_i,
                    l_rev,
                    f_rev,
                    f_ray,
                    i_ray,
                )
            )
        )
        return np.broadcast_to(N, shape).copy()
