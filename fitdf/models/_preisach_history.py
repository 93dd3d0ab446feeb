"""Preisach output under an arbitrary input history (wiping-out rule, batched).

:class:`PreisachState` keeps the stack of alternating dominant extrema and the partial
sums of Everett masses; :func:`preisach_output` runs it along an input sequence. The
density and its Everett function come from :mod:`fitdf.models._preisach_everett`.
"""

from __future__ import annotations

import numpy as np
from scipy.special import ndtr

from fitdf.models._preisach_everett import _bvn, _scales, everett, reversible_part

__all__ = ["PreisachState", "preisach_output"]

_SHAPE = ("i_c", "sigma_c", "i_i")


def _demag_excess(x_max, x_min, *, i_c, sigma_c, i_i):
    """Mass of relays with ``u < 0``, ``alpha > x_max``, ``beta < x_min`` (``x_min <= 0 <= x_max``).

    These relays are up in the AC-demagnetised state and were never switched since, so the
    demagnetised output exceeds the one from "negative saturation, then up to 0" by twice
    this mass. With ``c = min((x_max + x_min)/2, 0)`` the binding constraint is
    ``alpha > x_max`` for ``u < c`` and ``beta < x_min`` for ``c < u < 0``; both pieces are
    bivariate normal probabilities of ``(U, H + U)`` and ``(U, U - H)`` (correlation ``i_i/S``).
    """
    m, s, t, S, Z = _scales(i_c, sigma_c, i_i)
    c = np.minimum(0.5 * (x_max + x_min), 0.0) / t
    r = t / S
    upper = ndtr(c) - _bvn(c, (x_max - m) / S, r)
    lower = _bvn(0.0, (x_min + m) / S, r) - _bvn(c, (x_min + m) / S, r)
    return np.maximum(upper + lower, 0.0) / Z


class PreisachState:
    """Preisach output under an arbitrary input history, for a batch (wiping-out rule, exact).

    The memory is the stack of alternating dominant extrema ``e_1, e_2, ...`` left by the
    wiping-out property (Mayergoyz 1991, ch. 1): a new input that passes the previous
    extremum of its own kind erases that extremum and the one after it. From negative
    saturation (a virtual ``e_0 = -inf``) the irreversible output is

        P = -1 + 2 sum_k sign(e_k - e_{k-1}) E(max(e_k, e_{k-1}), min(e_k, e_{k-1})),

    the last ``e`` being the present input; the partial sums are stored with the stack, so
    an update costs one Everett evaluation per batch element whatever the depth.
    ``initial="positive"`` is the mirror image (``P -> -P``, ``x -> -x``; the density is
    even in ``u``). ``"demagnetized"`` (relays with ``u < 0`` up, input at 0) is "negative
    saturation, then up to 0" plus twice the mass of the relays the history has never
    switched that the demagnetised state holds up (:func:`_demag_excess`), which depends only
    on the running extremes. From that state the input ``0 -> A -> -A -> x`` gives exactly
    the steady rising branch of :meth:`Preisach.ascending_branch`.

    Parameters
    ----------
    x0 : array_like
        Input (A) at which the state starts; from ``"demagnetized"`` the input moves
        monotonically from 0 to ``x0``.
    initial : {"demagnetized", "negative", "positive"}
        Starting state.
    lambda_s, i_c, sigma_c, i_i, l_rev, f_rev : array_like
        Model parameters (:class:`Preisach`); broadcast with ``x0`` into the batch shape.

    Examples
    --------
    >>> st = PreisachState(0.0, lambda_s=0.03, i_c=1e-3, sigma_c=0.3, i_i=3e-4, l_rev=5.0, f_rev=0.1)
    >>> tip = st.update(5e-3); remanence = st.update(0.0)
    >>> bool(0.0 < remanence < tip < 0.03)
    True
    """

    def __init__(
        self, x0=0.0, *, initial="demagnetized", lambda_s, i_c, sigma_c, i_i, l_rev, f_rev
    ):
        if initial not in ("demagnetized", "negative", "positive"):
            raise ValueError(
                f"initial must be 'demagnetized', 'negative' or 'positive', not {initial!r}"
            )
        arrays = np.broadcast_arrays(
            *(np.asarray(v, dtype=float) for v in (x0, lambda_s, i_c, sigma_c, i_i, l_rev, f_rev))
        )
        self.shape = arrays[0].shape
        x0, lam, *rest = (np.array(a.reshape(-1)) for a in arrays)
        self._shape_kw = dict(zip(_SHAPE, rest[:3]))
        self._lam, self._lrev, self._frev = lam, rest[3], rest[4]
        self._demag = initial == "demagnetized"
        self._sign = -1.0 if initial == "positive" else 1.0
        size = x0.size
        self._rows = np.arange(size)
        self._ext = np.full((size, 16), -np.inf)
        self._pre = np.full((size, 16), -1.0)
        self._n = np.ones(size, dtype=int)
        start = np.zeros(size) if self._demag else self._sign * x0
        self._ext[:, 1] = start
        self._pre[:, 1] = -1.0 + 2.0 * everett(start, -np.inf, **self._shape_kw)
        self._x = start
        self._xmax = np.zeros(size)
        self._xmin = np.zeros(size)
        self._p = self._pre[:, 1].copy()
        if self._demag:
            self.update(x0.reshape(self.shape))

    @property
    def irreversible(self):
        """Normalised relay output ``P`` in ``[-1, 1]``."""
        return (self._sign * self._p).reshape(self.shape)

    @property
    def output(self):
        """Flux linkage (V s): ``lambda_s ((1 - f_rev) P + f_rev (2/pi) atan(x / i_r))``."""
        x = self._sign * self._x
        rev = reversible_part(x, lambda_s=self._lam, l_rev=self._lrev, f_rev=self._frev)
        return ((1.0 - self._frev) * self._lam * self._sign * self._p + rev).reshape(self.shape)

    def update(self, x):
        """Move the input (monotonically) to ``x`` and return the new flux linkage."""
        x = self._sign * np.broadcast_to(np.asarray(x, dtype=float), self.shape).reshape(-1)
        rows, n = self._rows, self._n
        if np.any(n + 1 >= self._ext.shape[1]):
            grow = self._ext.shape[1]
            self._ext = np.concatenate((self._ext, np.full_like(self._ext, -np.inf)), axis=1)[
                :, : 2 * grow
            ]
            self._pre = np.concatenate((self._pre, np.zeros_like(self._pre)), axis=1)[:, : 2 * grow]
        ext = self._ext
        last, prev = ext[rows, n], ext[rows, n - 1]
        n = n + ((x - last) * np.sign(last - prev) < 0)  # a reversal opens a new extremum
        ext[rows, n] = x
        while True:  # wiping out
            d = np.sign(x - ext[rows, n - 1])
            wipe = (n >= 2) & (d * (x - ext[rows, np.maximum(n - 2, 0)]) >= 0)
            if not wipe.any():
                break
            n = np.where(wipe, n - 2, n)
            ext[rows, n] = x
        prev = ext[rows, n - 1]
        step = np.sign(x - prev) * everett(
            np.maximum(x, prev), np.minimum(x, prev), **self._shape_kw
        )
        self._pre[rows, n] = self._pre[rows, n - 1] + 2.0 * step
        self._n, self._x = n, x
        p = self._pre[rows, n]
        if self._demag:
            self._xmax = np.maximum(self._xmax, x)
            self._xmin = np.minimum(self._xmin, x)
            p = p + 2.0 * _demag_excess(self._xmax, self._xmin, **self._shape_kw)
        self._p = p
        return self.output


def preisach_output(inputs, *, initial="demagnetized", lambda_s, i_c, sigma_c, i_i, l_rev, f_rev):
    """Flux linkage along an input sequence (time on the last axis), for any history.

    Parameters
    ----------
    inputs : array_like, shape (..., n)
        Successive inputs (A); the input is taken to move monotonically between samples,
        so turning points are enough and extra samples are harmless.
    initial : {"demagnetized", "negative", "positive"}
        State before ``inputs[..., 0]`` (:class:`PreisachState`).
    lambda_s, i_c, sigma_c, i_i, l_rev, f_rev : array_like
        Broadcast against ``inputs``; constant along the last axis (the first sample's
        value is used), so ``split_theta``'s ``(batch, 1)`` arrays give a batch of histories.

    Returns
    -------
    numpy.ndarray
        Flux linkage (V s) at every sample, the broadcast shape.
    """
    theta = dict(lambda_s=lambda_s, i_c=i_c, sigma_c=sigma_c, i_i=i_i, l_rev=l_rev, f_rev=f_rev)
    inputs = np.asarray(inputs, dtype=float)
    if inputs.ndim == 0:
        raise ValueError("inputs must have a time axis (the last one)")
    shape = np.broadcast_shapes(inputs.shape, *(np.shape(v) for v in theta.values()))
    xs = np.broadcast_to(inputs, shape)
    kw = {k: np.broadcast_to(np.asarray(v, dtype=float), shape)[..., 0] for k, v in theta.items()}
    out = np.empty(shape)
    state = PreisachState(xs[..., 0], initial=initial, **kw)
    out[..., 0] = state.output
    for j in range(1, shape[-1]):
        out[..., j] = state.update(xs[..., j])
    return out
