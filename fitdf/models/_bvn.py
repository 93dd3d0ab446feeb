"""Standard bivariate normal distribution function, compiled (Genz's BVND algorithm).

``P(X <= h, Y <= k)`` for standard normal ``X, Y`` of correlation ``r``, scalar, in numba:
A. Genz, "Numerical computation of rectangular bivariate and trivariate normal and t
probabilities", *Statistics and Computing* 14 (2004) 251-260 (his ``BVND`` / ``bvnl``).
For ``|r| < 0.925`` it is the form of Z. Drezner and G. O. Wesolowsky, "On the computation
of the bivariate normal integral", *J. Statist. Comput. Simul.* 35 (1990) 101-107,

    P = Phi(h) Phi(k) + (1 / 2 pi) Int_0^{asin r} exp(-(h^2 + k^2 - 2 h k sin t) / (2 cos^2 t)) dt,

by Gauss-Legendre with 6, 12 or 20 points for ``|r| < 0.3``, ``< 0.75``, ``< 0.925``;
for ``|r| >= 0.925`` the integral in ``sqrt(1 - r^2)`` with its singular part removed
in closed form (a Taylor expansion) and the rest by 20 points, reflected to ``r > 0``.
Absolute accuracy ~1e-15 (Genz 2004); against the Owen's-``T`` form of
:func:`fitdf.models._preisach_everett._bvn` within 2e-15 on the test grids.

Everything that depends only on ``|r|`` (the sines of the nodes, or the node abscissae in
``1 - r^2``) is tabulated once by :func:`bvn_setup`, so a loop with a fixed correlation
pays only the exponentials. Arguments beyond ``+-40`` are taken as infinite
(``Phi(-40) < 1e-300``): exact to double precision, and it skips the quadrature. The caller
passes ``sqrt(1 - r^2)`` next to ``r`` (see :func:`bvn_setup`), which keeps the accuracy as
``r -> 1``, where the Owen's-``T`` form loses ~1e-16 / sqrt(1 - r^2).

numba caches a compiled caller (``cache=True``) by the caller's own source file: after
editing this module, delete ``fitdf/models/__pycache__/*.nb[ic]``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["BVN_TABLE_SHAPE", "bvn_setup", "bvn_lower_phi", "bvn_lower", "bvn"]

_RULES = (6, 12, 20)


def _gauss_legendre_table():
    """Abscissae shifted to [0, 2] (``1 + xi``) and weights of the three rules, one row each."""
    x, w = np.zeros((3, 20)), np.zeros((3, 20))
    for g, n in enumerate(_RULES):
        xi, wi = np.polynomial.legendre.leggauss(n)
        x[g, :n], w[g, :n] = 1.0 + xi, wi
    return x, w


_GL_X, _GL_W = _gauss_legendre_table()
_GL_N = np.array(_RULES)
#: Shape of the per-correlation table filled by :func:`bvn_setup`.
BVN_TABLE_SHAPE = (5, 20)
_TWO_PI = 2.0 * math.pi
_SQRT_TWO_PI = math.sqrt(2.0 * math.pi)
_BIG = 40.0


@numba.njit(cache=True)
def _phi(z):
    return 0.5 * math.erfc(-z * 0.7071067811865476)


@numba.njit(cache=True)
def bvn_setup(r, sq, tab):
    """Fill ``tab`` (:data:`BVN_TABLE_SHAPE`) with the node constants of ``|r|``; number of nodes.

    ``sq = sqrt(1 - r^2)``, from the caller: near ``|r| = 1`` it should come from the
    quantities that define ``r`` (``r = s/S``, ``sq = t/S``), as ``1 - r^2`` computed from a
    rounded ``r`` loses ``eps / (1 - r)`` relative (and the probability ``~eps / sq``).
    ``|r| < 0.925``: rows ``sin t_j``, ``1 / cos^2 t_j``, ``w_j asin(|r|) / (4 pi)``;
    ``0.925 <= |r| < 1``: rows ``1 / x_j``, ``x_j``, ``a w_j``, ``1 / sqrt(1 - x_j)``,
    ``x_j / (1 + sqrt(1 - x_j))^2`` with ``x_j = (a (1 + xi_j))^2``, ``a = sq / 2``.
    The table serves ``r`` and ``-r`` alike.
    """
    ar = abs(r)
    g = 0 if ar < 0.3 else (1 if ar < 0.75 else 2)
    n = _GL_N[g]
    if ar < 0.925:
        asr = 0.5 * math.asin(ar)
        for j in range(n):
            sn = math.sin(asr * _GL_X[g, j])
            tab[0, j] = sn
            tab[1, j] = 1.0 / ((1.0 - sn) * (1.0 + sn))
            tab[2, j] = _GL_W[g, j] * asr / _TWO_PI
    elif sq > 0.0:
        a = 0.5 * sq
        for j in range(n):
            xs = (a * _GL_X[g, j]) ** 2
            rs = math.sqrt(1.0 - xs)
            tab[0, j] = 1.0 / xs
            tab[1, j] = xs
            tab[2, j] = a * _GL_W[g, j]
            tab[3, j] = 1.0 / rs
            tab[4, j] = xs / (1.0 + rs) ** 2
    else:
        n = 0
    return n


@numba.njit(cache=True)
def _bvn_core(h, k, r, sq, ph, pk, tab, n):
    """``P(X <= h, Y <= k)`` for finite ``h, k`` given ``ph = Phi(h)``, ``pk = Phi(k)``.

    Genz's ``bvnu(-h, -k, r)``, written for the lower orthant; the ``Phi(-z)`` of his
    ``r < 0`` branch are taken as ``1 - Phi(z)``, exact to ``eps`` absolute.
    """
    if r == 0.0:
        return ph * pk
    hk = h * k
    ar = abs(r)
    if ar < 0.925:
        hs = 0.5 * (h * h + k * k)
        acc = 0.0
        if hs - ar * abs(hk) < 40.0:  # else every node is below exp(-40), the sum below 1e-18
            if r < 0.0:  # sin t_j -> -sin t_j and asin r -> -asin r
                hk = -hk
            for j in range(n):
                acc += tab[2, j] * math.exp((tab[0, j] * hk - hs) * tab[1, j])
            if r < 0.0:
                acc = -acc
        return acc + ph * pk
    if r > 0.0:
        bs = (h - k) ** 2
    else:  # reflected: (-h, k) with correlation -r
        bs = (h + k) ** 2
        hk = -hk
    bvn = 0.0
    if sq > 0.0:
        as_ = sq * sq
        a = sq
        c = (4.0 - hk) / 8.0
        d = (12.0 - hk) / 80.0
        asr = -0.5 * (bs / as_ + hk)
        if asr > -100.0:
            bvn = (
                a
                * math.exp(asr)
                * (1.0 - c * (bs - as_) * (1.0 - d * bs) / 3.0 + c * d * as_ * as_)
            )
        if -100.0 < hk < 1400.0:  # exp(-hk/2) underflows beyond
            b = math.sqrt(bs)
            sp = _SQRT_TWO_PI * _phi(-b / a)
            bvn -= math.exp(-0.5 * hk) * sp * b * (1.0 - c * bs * (1.0 - d * bs) / 3.0)
        acc = 0.0
        for j in range(n):
            asr = -0.5 * (bs * tab[0, j] + hk)
            if asr > -100.0:
                xs = tab[1, j]
                sp = 1.0 + c * xs * (1.0 + 5.0 * d * xs)
                ep = math.exp(-0.5 * hk * tab[4, j]) * tab[3, j]
                acc += tab[2, j] * math.exp(asr) * (sp - ep)
        bvn = (acc - bvn) / _TWO_PI
    if r > 0.0:
        return bvn + min(ph, pk)
    if h + k <= 0.0:
        return -bvn
    return ph + pk - 1.0 - bvn


@numba.njit(cache=True)
def bvn_lower_phi(h, k, r, sq, ph, pk, tab, n):
    """``P(X <= h, Y <= k)``, correlation ``r`` (``sq = sqrt(1 - r^2)``), given ``ph = Phi(h)``, ``pk = Phi(k)``.

    ``tab``/``n`` from ``bvn_setup(r, sq)`` (or ``-r``). Infinite (or beyond ``+-40``)
    arguments give the exact limits; the result is clipped to ``[0, 1]``.
    """
    if h < -_BIG or k < -_BIG:
        return 0.0
    if h > _BIG:
        return 1.0 if k > _BIG else pk
    if k > _BIG:
        return ph
    return min(max(_bvn_core(h, k, r, sq, ph, pk, tab, n), 0.0), 1.0)


@numba.njit(cache=True)
def bvn_lower(h, k, r, sq, tab, n):
    """:func:`bvn_lower_phi` computing ``Phi(h)`` and ``Phi(k)`` itself."""
    return bvn_lower_phi(h, k, r, sq, _phi(h), _phi(k), tab, n)


@numba.njit(cache=True)
def bvn(h, k, r):
    """Scalar ``P(X <= h, Y <= k)`` for standard normals of correlation ``r`` (tabulates ``r`` each call)."""
    tab = np.empty(BVN_TABLE_SHAPE)
    sq = math.sqrt((1.0 - r) * (1.0 + r))
    n = bvn_setup(r, sq, tab)
    return bvn_lower(h, k, r, sq, tab, n)
