"""Scalar Preisach model with a Gaussian relay density, a reversible part and saturation.

The classical Preisach model writes the output as a superposition of rectangular relays
``gamma_{alpha,beta}`` that switch up (+1) when the input rises to ``alpha`` and down (-1)
when it falls to ``beta <= alpha``. In the coercive and interaction coordinates
``h = (alpha - beta) / 2 >= 0`` (half-width of a relay) and ``u = (alpha + beta) / 2`` (its
bias), this module takes the product density (an assumption: the two are independent)::

    q(h, u) = f(h) g(u),   f = N(i_c, s^2) truncated to h >= 0,   g = N(0, i_i^2),

``s = sigma_c i_c``, normalised to unit mass, so the irreversible output ``P`` lies in
``[-1, 1]``. The flux linkage is::

    lambda = lambda_s [ (1 - f_rev) P + f_rev (2/pi) atan(x / i_r) ],
    i_r = 2 f_rev lambda_s / (pi l_rev),

saturating at ``+-lambda_s``: the relays give the irreversible part, the single-valued
arctangent the reversible rotation of section III.1 (its ``1/x`` approach to saturation is
that of the Frohlich-Kennelly law). :class:`Preisach` is the law; :func:`everett`,
:func:`preisach_branch` and :func:`preisach_describing_function` its closed forms, and
:class:`PreisachState` / :func:`preisach_output` its output under any input history.

Notes
-----
The Everett function ``E(alpha, beta)``, the mass of relays with
``beta <= beta', alpha' <= alpha``, is a difference of bivariate normal distribution
functions (Owen's ``T``), and its ``alpha`` derivative a Gaussian times a difference of
``erf``. After wiping out, the rising branch of the symmetric steady loop of peak ``A``
(relays outside ``T(A, -A)`` frozen with zero net output, as after AC demagnetisation) is
``P_up(x) = -E(A, -A) + 2 E(x, -A)``, ``P_down(x) = -P_up(-x)``. Integrating eqs 2.1/2.2
by parts gives, for any loop,
``N = (2 / (pi A^2)) Int_{-A}^{A} y_up'(x) [sqrt(A^2 - x^2) - j x] dx``: the reversible
part is exactly ``N_rev = 2 l_rev / (1 + sqrt(1 + (A/i_r)^2))``,
and the relay part, with ``y_up' = 2 (1 - f_rev) lambda_s dE/dalpha(x, -A)``, is a smooth
1-D integral taken by a fixed graded Gauss-Legendre rule. Because ``f(0) g(0) > 0`` the
density is constant near the origin, which makes the loops of amplitudes well below
``i_c`` and ``i_i`` Rayleigh loops (eqs 3.1, 3.7) with ``mu0 = l_rev`` and
``gamma = (1 - f_rev) lambda_s f(0) g(0)`` (:func:`rayleigh_constant`). Material constants
(``N`` turns, path ``l_e``, section ``A_e``): ``B_s = lambda_s / (N A_e)``; the coercive
field of the major loop ``H_c ~ N i_c / l_e`` when ``sigma_c``, ``i_i / i_c`` and ``f_rev``
are small; ``mu_i = l_rev l_e / (mu_0 N^2 A_e)``; the Rayleigh constant ``eta`` of
``B = mu_i H + eta H^2`` is ``gamma l_e^2 / (N^3 A_e)`` in T m^2/A^2.

References
----------
Preisach, F., "Über die magnetische Nachwirkung", Z. Phys. 94, 277 (1935).

Mayergoyz, I. D., *Mathematical Models of Hysteresis*, Springer (1991), ch. 1.

Della Torre, E., *Magnetic Hysteresis*, IEEE Press (1999).

Néel, L., "Théorie des lois d'aimantation de Lord Rayleigh", Cahiers de Physique 12 (1942).
"""

from __future__ import annotations

import numpy as np

from fitdf.models._preisach_everett import (
    everett,
    everett_slope,
    preisach_branch,
    preisach_describing_function,
    preisach_flux_rows,
    rayleigh_constant,
    reversible_part,
)
from fitdf.models._preisach_history import PreisachState, preisach_output
from fitdf.models.base import HysteresisModel
from fitdf.params import ParamSpec

__all__ = [
    "Preisach",
    "everett",
    "everett_slope",
    "preisach_branch",
    "reversible_part",
    "rayleigh_constant",
    "preisach_describing_function",
    "PreisachState",
    "preisach_output",
]


class Preisach(HysteresisModel):
    """Preisach model: Gaussian coercive x Gaussian interaction relays, arctangent reversible part.

    See the module docstring for the density, the Everett function and the describing
    function. ``closed_form`` is False: the relay part of ``N`` is a fixed quadrature of a
    closed-form integrand (``closed_form`` refers to ``N`` itself). Rate independent:
    ``frequency`` is only broadcast.

    Examples
    --------
    >>> import numpy as np
    >>> theta = dict(lambda_s=0.03, i_c=1e-3, sigma_c=0.5, i_i=5e-4, l_rev=10.0, f_rev=0.2)
    >>> N = Preisach.describing_function(np.array([0.0, 1e-5, 1e-3, 5e-2]), **theta)
    >>> bool(N[0] == 10.0), bool(np.all(N[1:].imag < 0))
    (True, True)
    """

    name = "preisach"
    title = "Preisach model (Gaussian coercive and interaction fields) with reversible part"
    equations = (
        "Preisach (1935); Everett function (Mayergoyz 1991); Rayleigh limit eqs 3.1, 3.7; "
        "reversible arctangent ~ Frohlich-Kennelly (sec III.1); DF eqs 2.1, 2.2"
    )
    closed_form = False
    params = (
        ParamSpec(
            "lambda_s",
            0.03,
            (1e-4, 10.0),
            "V s",
            "saturation flux linkage N A_e B_s (irreversible + reversible)",
            "sec III.1",
            log=True,
            quantity="flux_linkage",
        ),
        ParamSpec(
            "i_c",
            1e-3,
            (1e-7, 1e-1),
            "A",
            "peak of the coercive-current distribution (~ coercive current N^-1 l_e H_c of square loops)",
            "Preisach density",
            log=True,
            quantity="current",
        ),
        ParamSpec(
            "sigma_c",
            0.5,
            (0.01, 10.0),
            "",
            "relative spread of the coercive currents (Gaussian sd / i_c, truncated at 0)",
            "Preisach density",
            log=True,
        ),
        ParamSpec(
            "i_i",
            5e-4,
            (1e-8, 1e-1),
            "A",
            "interaction-current spread (Gaussian sd of the relay bias)",
            "Preisach density",
            log=True,
            quantity="current",
        ),
        ParamSpec(
            "l_rev",
            10.0,
            (1e-2, 1e4),
            "H",
            "reversible (initial) inductance, mu0 of eq 3.1",
            "eq 3.1",
            log=True,
            quantity="inductance",
        ),
        ParamSpec(
            "f_rev",
            0.2,
            (1e-3, 0.95),
            "",
            "reversible fraction of lambda_s (sets the squareness)",
            "sec III.1",
            log=True,
            limits=(0.0, 1.0),
        ),
    )

    @classmethod
    def ascending_branch(
        cls, x, amplitude, frequency=0.0, *, lambda_s, i_c, sigma_c, i_i, l_rev, f_rev
    ):
        """``lambda_s [(1 - f_rev)(-E(A, -A) + 2 E(x, -A)) + f_rev (2/pi) atan(x/i_r)]`` for ``-A <= x <= A``.

        A table of rows ``(R, K)`` with per-row amplitude and parameters (the chains'
        tables) runs in one compiled loop (:func:`preisach_flux_rows`); other shapes
        broadcast elementwise."""
        rows = preisach_flux_rows(
            x,
            amplitude,
            lambda_s=lambda_s,
            i_c=i_c,
            sigma_c=sigma_c,
            i_i=i_i,
            l_rev=l_rev,
            f_rev=f_rev,
        )
        if rows is not None:
            return rows
        P = preisach_branch(x, amplitude, i_c=i_c, sigma_c=sigma_c, i_i=i_i)
        lam = np.asarray(lambda_s, dtype=float)
        return (1.0 - np.asarray(f_rev, float)) * lam * P + reversible_part(
            x, lambda_s=lam, l_rev=l_rev, f_rev=f_rev
        )

    @classmethod
    def describing_function(
        cls, amplitude, frequency=0.0, *, lambda_s, i_c, sigma_c, i_i, l_rev, f_rev
    ):
        """``N(A)`` (H) by :func:`preisach_describing_function`; broadcasts over all arguments.

        ``Im N <= 0`` (relay loops run anticlockwise only); ``N(0) = l_rev``;
        ``N -> l_rev + gamma A - j 4 gamma A / (3 pi)`` at small ``A`` (:func:`rayleigh_constant`).
        """
        N = preisach_describing_function(
            amplitude,
            lambda_s=lambda_s,
            i_c=i_c,
            sigma_c=sigma_c,
            i_i=i_i,
            l_rev=l_rev,
            f_rev=f_rev,
        )
        return np.broadcast_to(N, np.broadcast_shapes(N.shape, np.shape(frequency))).copy()
