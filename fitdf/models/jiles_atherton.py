"""Jiles-Atherton model (Jiles & Atherton 1986) in winding units, steady loops in closed form.

Jiles and Atherton write the magnetisation as an irreversible (pinned-wall) part and a
reversible (wall-bowing) part::

    H_e   = H + alpha M                              (Weiss mean field)
    M_an  = M_s L(H_e / a),  L(z) = coth z - 1/z     (Langevin anhysteretic)
    dM_irr/dH_e = (M_an - M_irr) / (delta k)         (pinning energy balance)
    M     = M_irr + c (M_an - M_irr)                 (reversible part)

with ``delta = sign(dH)``. This module keeps these four relations as they stand and
integrates them in the effective field ``H_e``::

    dM/dH_e = X = (1 - c) chi_irr + c dM_an/dH_e,   chi_irr = max(delta (M_an - M_irr), 0) / k,
    dH/dH_e = 1 - alpha X,   hence   dM/dH = X / (1 - alpha X).

:class:`JilesAtherton` is the law in winding units: with ``N`` turns, path ``l_e`` and
section ``A_e``, ``H = N i / l_e`` and the output is ``lambda = mu_0 N A_e M`` (the
``mu_0 H`` term, ~3e-4 H for the Permalloy core against >= 1 H from ``M``, is neglected),
with the parameters::

    lambda_s = mu_0 N A_e M_s (V s),   a = a_JA l_e / N,   k = k_JA l_e / N (A),
    c = c_JA,   zeta = alpha_JA M_s / (3 a_JA),   0 <= zeta <= 1,

so that ``i_e = i + alpha lambda`` with ``alpha = 3 zeta a / lambda_s`` (:func:`coupling`).
``zeta <= 1`` (no spontaneous magnetisation of the anhysteretic) is a fixed box bound, where
a bound on ``alpha`` would depend on ``a`` and ``lambda_s``. The anhysteretic initial
susceptibility, in winding units the inductance ``(lambda_s / 3a) / (1 - zeta)``, diverges
at ``zeta = 1`` (there ``M_an ~ H^(1/3)`` near the origin), and the bound is that limit
itself: the steady loop and its describing function are smooth through ``zeta = 1``, linear
in ``1 - zeta`` near it (``|N(1 - eps) - N(1)|`` is 0.8 to 33 ``eps |N|`` at the thesis
fits, the same for ``eps`` from 1e-2 to 1e-6), and computed there as accurately as anywhere
(within 6e-7 of ``|N|`` of an independent DOP853 integration of the equations, tests), so
``zeta`` is fitted on a linear scale up to 1. On a log scale of the margin ``1 - zeta`` (or
of the susceptibility) ``dN/d log(1 - zeta)`` is proportional to ``1 - zeta``: the fit's
Jacobian column would vanish toward the limit. A fit that reaches ``zeta = 1`` wants at
least the largest mean field a single-valued anhysteretic allows and bounds the
susceptibility only from below (:meth:`JilesAtherton.limit_warnings`). :func:`steady_loop`,
:func:`loop_figures` and :func:`ja_describing_function` give the steady loop, its coercive
current and remanence, and its describing function; any consistent units work
(:data:`JA_1986`, the published parameter set, is in SI).

Notes
-----
The 1986 paper's ``dM_irr/dH = (M_an - M_irr) / (delta k - alpha (M_an - M_irr))`` is this
model with the mean field fed by ``M_irr`` instead of ``M`` (the two agree for ``c = 0``).
After a reversal ``chi_irr`` stays 0 until ``M_an`` catches up with ``M_irr`` (the usual
fix of negative susceptibility), and for ``zeta <= 1`` the slope ``dM/dH`` is positive and
finite (at most ``(M_s/3a)/(1 - zeta)`` below 1), so the singular, negative or "avalanche"
slopes of the H-form cannot occur (for ``zeta > 1``, outside the bounds, a fold of
``H(H_e)`` becomes a vertical jump).

*Steady loops.* On a rising branch, once relaxing, the irreversible equation is linear in
``M_irr`` with a forcing ``M_an(H_e)`` that does not depend on the loop. With the forced
response ``Q`` (its solution from ``H_e = -infinity``, ``dQ/dH_e = (M_an - Q)/k``),
the rising branch from ``M_irr = mi0`` at its bottom ``H_e = h0`` is frozen until ``M_an``
reaches ``mi0`` at ``h_s``, then ``M_irr = Q(H_e) + (mi0 - Q(h_s)) e^(-(H_e - h_s)/k)``.
The symmetric steady loop of peak ``A`` (the limit of repeated cycling between ``-A`` and
``A``) has its tip at ``H_e = -h0`` and ``M_irr(-h0) = -mi0``: one equation in ``mi0``,
solved by Newton to rounding, with no half cycle integrated (for ``zeta > 1`` the half
cycle is integrated to its fixed point instead). ``Q`` is tabulated once per ``(lambda_s,
a, k)`` on nodes in ``H_e / a`` shared by every parameter set (its relaxation integrated
exactly for the cubic Hermite interpolant of ``M_an``, an exponential integrator, to well
below ``tol lambda_s``) and kept per process (:class:`~fitdf.models._ja_branch.ResponseCache`),
so a new amplitude or a new parameter set costs one equation and the branch's nodes. The
branch is laid out as nodes ``(H_e, M, dM/dH_e)`` (those of the table, plus the switch,
the tip and shorter steps where the transient ``e^(-(H_e - h_s)/k)`` or a minimum count
``n_min`` need them), between which it is the cubic Hermite interpolant; steps keep its
error below ``tol lambda_s``. A loop much narrower than the table's spacing (span below
``0.01 a``) takes ``M_irr`` from the relaxation integrated directly over the loop, which
keeps its relative precision. The describing function,
``N = (2/(pi A^2)) Int y_up'(x) [sqrt(A^2 - x^2) - j x] dx`` (eqs 2.1, 2.2 integrated by
parts), is evaluated piece by piece on that branch with a 10-node Gauss-Legendre rule, plus
a term for each jump; with the default ``tol = 1e-7`` it is within about 4e-6 of ``|N|`` of
a ``tol = 1e-11`` tabulation over realistic parameters (``benchmarks/bench_ja.py``) and
within 5e-7 of an independent DOP853 integration of the equations at the tests' parameter
sets.

References
----------
Jiles, D. C. and Atherton, D. L., "Theory of ferromagnetic hysteresis", J. Magn. Magn.
Mater. 61, 48 (1986).
"""

from __future__ import annotations

import numpy as np

from fitdf.models._ja_branch import (
    _T_OF_V,
    _W_OF_V,
    ROW_MEMO,
    _branch_rows,
    _capacity,
    _df_rows,
    _flat,
    _own,
    _table,
    grid,
    response_tables,
)
from fitdf.models._ja_integrate import (
    _COARSE_NMIN,
    _COARSE_TOL,
    _NMIN,
    _TOL,
    anhysteretic,
    coupling,
    langevin,
)
from fitdf.models.base import HysteresisModel
from fitdf.params import ParamSpec

__all__ = [
    "JilesAtherton",
    "langevin",
    "anhysteretic",
    "coupling",
    "steady_loop",
    "loop_figures",
    "ja_describing_function",
    "JA_1986",
]

#: Parameter set attributed to Jiles & Atherton (1986) in SI units (fields in A/m, output M in A/m).
JA_1986 = {
    "lambda_s": 1.6e6,
    "a": 1100.0,
    "k": 400.0,
    "c": 0.2,
    "zeta": 1.6e-3 * 1.6e6 / (3 * 1100.0),
}


#: ``zeta`` this close to 1 counts as the limit ``zeta = 1`` in
#: :meth:`JilesAtherton.limit_warnings` (the bound warnings' 1e-3 of the box's width).
ZETA_LIMIT_WITHIN = 1e-3


def steady_loop(amplitude, *, lambda_s, a, k, c, zeta, tol=_TOL, n_min=_NMIN, n_out=4):
    """Samples of the ascending branch of the steady loop of peak ``amplitude`` (scalars).

    Parameters
    ----------
    amplitude : float
        Peak input ``A`` (A).
    lambda_s, a, k, c, zeta : float
        Model parameters (:class:`JilesAtherton`).
    tol, n_min : float, int
        Step control (module docstring).
    n_out : int
        Samples per monotone piece of the parametric branch (between nodes).

    Returns
    -------
    x, y : numpy.ndarray
        From ``(-A, -lambda_tip)`` to ``(A, lambda_tip)``; ``x`` non-decreasing (equal at a
        jump, only for ``zeta > 1``), ``y`` non-decreasing. The descending branch is
        ``(-x[::-1], -y[::-1])``.
    """
    alpha = float(coupling(lambda_s=lambda_s, a=a, zeta=zeta))
    th = (float(lambda_s), float(a), float(k), float(c), alpha)
    tabs, _ = response_tables(*(np.array([v]) for v in th[:3]), tol)
    x, y, _ = _table(
        float(abs(amplitude)), th, tol, n_min, _capacity(n_min), grid(tol), tabs[0], n_out
    )
    return x, y


def loop_figures(amplitude, *, lambda_s, a, k, c, zeta, tol=_TOL, n_min=_NMIN, n_out=16):
    """Coercive current, remanence, tip flux linkage and loop area of one steady loop (scalars).

    Read off :func:`steady_loop` samples: ``coercive`` is the zero of the ascending branch,
    ``remanence`` minus its value at ``x = 0`` (linear interpolation between samples),
    ``area`` ``Int (y_down - y_up) dx`` by the trapezoid rule (relative error ~``n_out^-2``).
    """
    x, y = steady_loop(
        amplitude, lambda_s=lambda_s, a=a, k=k, c=c, zeta=zeta, tol=tol, n_min=n_min, n_out=n_out
    )
    xd, yd = -x[::-1], -y[::-1]
    area = np.trapezoid(yd, xd) - np.trapezoid(y, x)
    return {
        "coercive": float(np.interp(0.0, y, x)),
        "remanence": float(-np.interp(0.0, x, y)),
        "tip": float(y[-1]),
        "area": float(area),
    }


def ja_describing_function(amplitude, *, lambda_s, a, k, c, zeta, tol=_TOL, n_min=_NMIN):
    """``N(A)`` (H) of the steady JA loop; all arguments broadcast; numba loop over points.

    Parameters
    ----------
    amplitude : array_like
        Peak current ``A`` (A); the sign is irrelevant.
    lambda_s, a, k, c, zeta : array_like
        Model parameters (:class:`JilesAtherton`).
    tol, n_min : float, int
        Step control: cubic-Hermite error per step below ``tol lambda_s``, at least ``n_min``
        steps per branch. Over realistic parameters (``benchmarks/bench_ja.py``) the
        default ``tol = 1e-7`` is within 4e-6 of ``|N|`` of a ``tol = 1e-11`` refinement
        (1.1e-6 about the report's fits; ``tol = 1e-8``: 7e-7, 1.4x slower); ``tol = 1e-6,
        n_min = 12`` is ~1.5x faster again within 4e-5 (``Im N``: 9e-5 of ``|Im N|``); all
        are far worse at the box's corners (nearly rectangular loops, ``A/a ~ 5e6``).

    Returns
    -------
    numpy.ndarray of complex
        ``N`` with ``Im N <= 0``. At ``A = 0`` the small-signal limit ``c L / (1 - zeta c)``,
        ``L = lambda_s / 3a`` (for ``A << k`` the irreversible part hardly moves over a
        cycle). NaN where no steady loop was found (never met within the bounds in the tests).
    """
    alpha = coupling(lambda_s=lambda_s, a=a, zeta=zeta)
    shape, (A, lam, a_, k_, c_, al) = _flat(amplitude, lambda_s, a, k, c, alpha)
    out = np.empty(A.size, dtype=complex)
    tabs, row = response_tables(lam, a_, k_, tol)
    P = (np.abs(A), lam, a_, k_, c_, al)
    _df_rows(P, tol, n_min, _capacity(n_min), grid(tol), tabs, row, _T_OF_V, _W_OF_V, out)
    return out.reshape(shape)


class JilesAtherton(HysteresisModel):
    """Jiles-Atherton hysteresis in winding units (module docstring: formulation and mapping).

    Examples
    --------
    >>> import numpy as np
    >>> theta = dict(lambda_s=0.03, a=1e-3, k=1e-3, c=0.2, zeta=0.5)
    >>> N = JilesAtherton.describing_function(np.array([1e-4, 1e-3, 3e-2]), **theta)
    >>> bool(np.all(N.imag < 0)), bool(np.all(np.diff(np.abs(N[1:])) < 0))
    (True, True)
    """

    name = "jiles_atherton"
    title = "Jiles-Atherton model (Langevin anhysteretic, pinning, reversible bowing, mean field)"
    equations = "Jiles & Atherton (1986); steady loop by integration; DF eqs 2.1, 2.2"
    closed_form = False
    params = (
        ParamSpec(
            "lambda_s",
            0.03,
            (1e-4, 10.0),
            "V s",
            "saturation flux linkage mu0 N A_e M_s",
            "JA M_s",
            log=True,
            quantity="flux_linkage",
        ),
        ParamSpec(
            "a",
            1e-3,
            (1e-7, 1e-1),
            "A",
            "Langevin shape current a_JA l_e / N",
            "JA a",
            log=True,
            quantity="current",
        ),
        ParamSpec(
            "k",
            1e-3,
            (1e-7, 1e-1),
            "A",
            "pinning current k_JA l_e / N (~ coercive current)",
            "JA k",
            log=True,
            quantity="current",
        ),
        ParamSpec(
            "c",
            0.2,
            (1e-3, 0.99),
            "",
            "reversible (wall-bowing) fraction",
            "JA c",
            log=True,
            limits=(0.0, 1.0),
        ),
        ParamSpec(
            "zeta",
            0.5,
            (0.0, 1.0),
            "",
            "mean-field ratio alpha_JA M_s / 3 a_JA (<= 1: no spontaneous magnetisation)",
            "JA alpha",
            log=False,
            limits=(0.0, 1.0),
        ),
    )

    @classmethod
    def limit_warnings(cls, amplitude, *, lambda_s, a, zeta, **_):
        """At ``zeta = 1`` (within :data:`ZETA_LIMIT_WITHIN`): what the data leave open.

        ``zeta = 1`` is the largest mean field with a single-valued anhysteretic (no
        spontaneous magnetisation). There the anhysteretic initial susceptibility, in winding
        units the inductance ``(lambda_s / 3a) / (1 - zeta)`` (the Langevin anhysteretic with
        the Weiss mean field of Jiles & Atherton 1986, module docstring, linearised at the
        origin), diverges, and a fit that ends there bounds it only from below, by its value
        at the lower end of ``zeta``'s interval. The bound warning says that ``zeta`` is on
        its bound; this says what that means.
        """
        zeta = float(np.max(zeta))
        if zeta < 1.0 - ZETA_LIMIT_WITHIN:
            return []
        slope = float(np.max(np.asarray(lambda_s, float) / (3.0 * np.asarray(a, float))))
        return [
            f"zeta = {zeta:.6g} is at its limit 1, the largest mean field with a single-valued "
            "anhysteretic (no spontaneous magnetisation): there the anhysteretic initial "
            f"susceptibility (lambda_s/3a)/(1 - zeta), lambda_s/3a = {slope:.4g} H in winding "
            "units, diverges, and the data determine only a lower bound on it, "
            f"{slope:.4g} H/(1 - zeta_lo) with zeta_lo the lower end of zeta's interval"
        ]

    @classmethod
    def ascending_branch(cls, x, amplitude, frequency=0.0, *, lambda_s, a, k, c, zeta):
        """Rising branch of the steady loop (the parametric cubic of its nodes); broadcasts.

        One steady loop is computed per distinct broadcast ``(amplitude, theta)`` element and
        evaluated (Newton inversion of ``H(H_e)``) at all the ``x`` that share it, in one
        compiled call. The forced responses of recent parameter sets are kept
        (:class:`~fitdf.models._ja_branch.ResponseCache`), and the nodes of the previous
        call's rows (:class:`~fitdf.models._ja_branch.RowMemo`: the ``voltage`` chain asks
        for the same rows at new ``x`` in consecutive calls); both give the bits a new solve
        would, so results do not depend on what ran before.
        """
        return _steady_branch(x, amplitude, lambda_s, a, k, c, zeta, _TOL, _NMIN)

    @classmethod
    def rough_branch(cls, x, amplitude, frequency=0.0, *, lambda_s, a, k, c, zeta):
        """The branch on the coarse tabulation (``tol = 1e-5``, 8 steps at least): the same
        steady loop (the forced response on coarser nodes), within 3e-5 ``lambda_s`` of the
        brute-force loop where :meth:`ascending_branch` is within 4e-7 (tests), on a third
        of the nodes (the ``voltage`` chain's initial guess and coarse stage)."""
        return _steady_branch(x, amplitude, lambda_s, a, k, c, zeta, _COARSE_TOL, _COARSE_NMIN)

    @classmethod
    def describing_function(cls, amplitude, frequency=0.0, *, lambda_s, a, k, c, zeta):
        """``N(A)`` (H) from :func:`ja_describing_function`; ``frequency`` is only broadcast."""
        N = ja_describing_function(amplitude, lambda_s=lambda_s, a=a, k=k, c=c, zeta=zeta)
        return np.broadcast_to(N, np.broadcast_shapes(N.shape, np.shape(frequency))).copy()


def _steady_branch(x, amplitude, lambda_s, a, k, c, zeta, tol, n_min):
    """:meth:`JilesAtherton.ascending_branch` with the tabulation ``(tol, n_min)``.

    Written for a small fixed cost per call (the ``voltage`` chain's root search calls it on
    a handful of points at a time): NumPy only where shapes need it.
    """
    values = [np.asarray(v, dtype=float) for v in (amplitude, lambda_s, a, k, c, zeta)]
    x = np.asarray(x, dtype=float)
    pshape = np.broadcast_shapes(*(v.shape for v in values))
    full = pshape if x.shape == pshape else np.broadcast_shapes(x.shape, pshape)
    A, lam, a_, k_, c_, z_ = (
        _own(v if v.shape == pshape else np.broadcast_to(v, pshape)) for v in values
    )
    A = np.abs(A)
    al = coupling(lambda_s=lam, a=a_, zeta=z_)
    padded = (1,) * (len(full) - len(pshape)) + tuple(pshape)
    lead = len(padded)
    while lead and padded[lead - 1] == 1:
        lead -= 1
    order = None
    if padded[:lead] == full[:lead]:  # each row's inputs are one block of the flat inputs
        size = 1
        for n in full[lead:]:
            size *= n
        index = np.arange(0, (A.size + 1) * size, size)
        xs = _own(x if x.shape == full else np.broadcast_to(x, full))
    else:
        owner = np.broadcast_to(np.arange(A.size).reshape(pshape), full).reshape(-1)
        order = np.argsort(owner, kind="stable")
        index = np.searchsorted(owner[order], np.arange(A.size + 1))
        xs = np.broadcast_to(x, full).reshape(-1)[order]
    tabs, row = response_tables(lam, a_, k_, tol)
    out = np.empty(xs.size)
    keep = A.size <= ROW_MEMO.max_rows
    memo = ROW_MEMO.get(tol, n_min)
    P = (A, lam, a_, k_, c_, al)
    G = grid(tol)
    memo = _branch_rows(P, tol, n_min, _capacity(n_min), G, tabs, row, xs, index, out, memo, keep)
    if keep:
        ROW_MEMO.keep(tol, n_min, memo)
    if order is None:
        return out.reshape(full)
    result = np.empty_like(out)
    result[order] = out
    return result.reshape(full)
