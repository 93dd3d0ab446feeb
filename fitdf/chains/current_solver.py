"""The winding chain's current solver: ``I |R + Z(I)| = V`` for all data points at once."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from fitdf.chains.base import R_MIN

__all__ = ["solve_current"]

_LN10 = np.log(10.0)

# Bracket-search rounds (multiples of the fixed-point step |F|, decades): large multiples
# serve a flat F (a saturated core behind a small R), decades a far-off root.
_BRACKET_ROUNDS = (((1.0,), ()), ((4.0, 16.0, 64.0, 256.0), (0.5, 2.0, 8.0)), ((), (32.0,)))


def _evaluate(residual, trial, index):
    """``residual`` at a ``(m, K)`` array of trial points of the points ``index``."""
    ft, zt = residual(trial.ravel(), np.repeat(index, trial.shape[1]))
    return ft.reshape(trial.shape), zt.reshape(trial.shape)


def _keep_best(score, trial, ft, zt, index, s_best, f_best, z_best):
    """Store, in place, each point's trial with the smallest ``|F|`` if it beats the best so far."""
    rows = np.arange(index.size)
    b = np.argmin(score, axis=1)
    better = score[rows, b] < np.abs(f_best[index])
    upd = index[better]
    s_best[upd], f_best[upd], z_best[upd] = (
        trial[rows, b][better],
        ft[rows, b][better],
        zt[rows, b][better],
    )


def solve_current(
    impedance: Callable[[np.ndarray, np.ndarray], np.ndarray],
    voltage,
    resistance,
    *,
    initial=None,
    tol: float = 1e-12,
    max_iter: int = 60,
    budget: int | None = None,
):
    """Solve ``I |R + Z(I)| = V`` for the current amplitude, all points at once.

    Works on ``F(s) = s + ln|R + Z(e^s)| - ln V`` in ``s = ln I`` (the log of the relative
    residual), on all unconverged points together:

    1. *Bracket.* For a passive loop (``Re Z >= 0``) ``F(ln(V/R)) >= 0``: ``I = V/R`` is an
       upper end and the start, unless ``initial`` gives one. Towards the root the
       fixed-point step ``s - F(s)`` is tried first, then 4-256 times that step with 0.5,
       2 and 8 decades, then 32 decades (one model call per round, on the points still
       unbracketed). A warm start (currents at nearby parameters) halves the calls.
    2. *Refine.* While many points are left, one Illinois step each (regula falsi whose
       end kept twice in a row has its value halved); when few are left (the model's
       per-call overhead dominates), up to 31 equally spaced points across the bracket
       per call (at most ``budget`` evaluations), keeping the narrowest sign change, so
       kinks of ``N`` (dead zone, onset of saturation, relay-like loops) cost a few calls.

    Stops where ``|F| <= tol`` or the bracket is a few ulps wide.

    Uniqueness: with the fundamental flux ``Phi(I) = I N(I)`` and loop area
    ``S(I) = -pi Im Phi``, ``h(I)^2 = (I |R + Z|)^2 = R^2 I^2 + 2 R omega S / pi +
    omega^2 |Phi|^2``: ``h`` increases strictly (one root) when ``S`` and ``|Phi|`` do not
    decrease with ``I``, true for nested loop families (constant or growing width:
    constant_width, proportional_width(_fig42), frequency_hc, Rayleigh; checked in the
    tests). A width shrinking with amplitude (cubic_hc) can break it; then one root is
    returned.

    Parameters
    ----------
    impedance : callable
        ``Z(I, index)`` (ohm, complex) for flat currents ``I`` at the points ``index``
        (indices into ``voltage.ravel()``).
    voltage, resistance : array_like
        Source amplitude ``V`` (V) and total series resistance ``R`` (ohm; values below
        ``R_MIN`` are raised to it), broadcast together.
    initial : array_like, optional
        Starting currents (A), broadcasting with ``voltage``; entries that are not positive
        and finite start from ``V / R``.
    tol : float
        Target ``|F|``, the relative residual of ``I |R + Z| = V``.
    max_iter : int
        Cap on refinement calls.
    budget : int, optional
        Largest number of model evaluations in one refinement call; by default the number
        of points, clipped to ``[64, 1024]``.

    Returns
    -------
    current, Z : numpy.ndarray
        ``I`` (0 where ``V <= 0``; NaN where no root was bracketed) and ``Z(I)``.

    Notes
    -----
    Long by design: the stages above share the per-point state (brackets, their values, the
    best point, the model calls left) and hand the unconverged points from one to the next;
    their order and hand-over are the algorithm, read here in one place.
    """
    shape = np.broadcast_shapes(np.shape(voltage), np.shape(resistance))
    V = np.broadcast_to(np.asarray(voltage, float), shape).ravel()
    R = np.maximum(np.broadcast_to(np.asarray(resistance, float), shape).ravel(), R_MIN)
    positive = V > 0
    log_v = np.log(np.where(positive, V, 1.0))
    budget = min(max(V.size, 64), 1024) if budget is None else budget

    def residual(s, index):
        Z = impedance(np.exp(s), index)
        return s + np.log(np.abs(R[index] + Z)) - log_v[index], Z

    with np.errstate(over="ignore", invalid="ignore"):
        s_best = log_v - np.log(R)
        if initial is not None:
            guess = np.broadcast_to(np.asarray(initial, float), shape).ravel()
            usable = np.isfinite(guess) & (guess > 0)
            s_best = np.where(usable, np.log(np.where(usable, guess, 1.0)), s_best)
        f_best, z_best = residual(s_best, np.arange(V.size))
        lo, hi = np.full(V.size, -np.inf), np.full(V.size, np.inf)
        flo, fhi = np.full(V.size, np.nan), np.full(V.size, np.nan)
        start_low = f_best < 0  # below the root (warm start, or an active Z): search upwards
        lo[start_low], flo[start_low] = s_best[start_low], f_best[start_low]
        hi[~start_low], fhi[~start_low] = s_best[~start_low], f_best[~start_low]
        done = (f_best == 0) | ~positive | ~np.isfinite(f_best)
        for multiples, decades in _BRACKET_ROUNDS:  # 1. bracket, on the points still without one
            need = np.flatnonzero(~done & ~(np.isfinite(lo) & np.isfinite(hi)))
            if not need.size:
                break
            up = ~np.isfinite(hi[need])
            base = np.where(up, lo[need], hi[need])
            f_base = np.where(up, flo[need], fhi[need])
            step = np.concatenate(
                [
                    np.abs(f_base)[:, None] * np.array(multiples),
                    np.broadcast_to(_LN10 * np.array(decades), (need.size, len(decades))),
                ],
                axis=1,
            )
            trial = base[:, None] + np.where(up, 1.0, -1.0)[:, None] * np.sort(step, axis=1)
            ft, zt = _evaluate(residual, trial, need)
            flipped = np.sign(f_base)[:, None] * ft <= 0  # first trial across the root
            j, found = np.argmax(flipped, axis=1), flipped.any(axis=1)
            rows = np.arange(need.size)
            s_far, f_far = trial[rows, j], ft[rows, j]
            last = trial.shape[1] - 1
            s_near = np.where(found, np.where(j > 0, trial[rows, j - 1], base), trial[rows, last])
            f_near = np.where(found, np.where(j > 0, ft[rows, j - 1], f_base), ft[rows, last])
            # The nearest point of the root's sign is the new end on that side.
            lo[need] = np.where(up, s_near, np.where(found, s_far, lo[need]))
            flo[need] = np.where(up, f_near, np.where(found, f_far, flo[need]))
            hi[need] = np.where(up, np.where(found, s_far, hi[need]), s_near)
            fhi[need] = np.where(up, np.where(found, f_far, fhi[need]), f_near)
            _keep_best(np.abs(ft), trial, ft, zt, need, s_best, f_best, z_best)
        bracketed = np.isfinite(lo) & np.isfinite(hi)
        done |= ~bracketed | (np.abs(f_best) <= tol)
        last = np.zeros(V.size, np.int8)  # Illinois memory: -1 lo moved last, +1 hi moved, 0 both
        for _ in range(max_iter):  # 2. refine
            act = np.flatnonzero(~done)
            if not act.size:
                break
            l, h, fl, fh, prev = lo[act], hi[act], flo[act], fhi[act], last[act]
            den = fh - fl
            guess = np.where(den > 0, h - fh * (h - l) / den, 0.5 * (l + h))
            extra = int(
                min(31, budget // act.size - 1)
            )  # never more evaluations than the first call
            if extra <= 0:  # many points left: one Illinois step each
                fs, zs = residual(guess, act)
                low = fs < 0
                move = np.where(low, -1, 1).astype(np.int8)
                lo[act], flo[act] = (
                    np.where(low, guess, l),
                    np.where(low, fs, np.where(prev == 1, 0.5 * fl, fl)),
                )
                hi[act], fhi[act] = (
                    np.where(low, h, guess),
                    np.where(low, np.where(prev == -1, 0.5 * fh, fh), fs),
                )
                last[act] = move
                _keep_best(
                    np.abs(fs)[:, None],
                    guess[:, None],
                    fs[:, None],
                    zs[:, None],
                    act,
                    s_best,
                    f_best,
                    z_best,
                )
                lost = ~np.isfinite(fs)
            else:  # few points left (the model's per-call overhead dominates): add a K-section
                grid = l[:, None] + (h - l)[:, None] * (np.arange(1, extra + 1) / (extra + 1.0))
                trial = np.sort(np.concatenate([guess[:, None], grid], axis=1), axis=1)
                ft, zt = _evaluate(residual, trial, act)
                seq_s = np.concatenate([l[:, None], trial, h[:, None]], axis=1)
                seq_f = np.concatenate([fl[:, None], ft, fh[:, None]], axis=1)
                cond = (seq_f[:, :-1] <= 0) & (seq_f[:, 1:] >= 0)
                j, lost = np.argmax(cond, axis=1), ~cond.any(axis=1)  # lost: NaN from the model
                rows = np.arange(act.size)
                kept_lo, kept_hi = j == 0, j == extra + 1
                lo[act], hi[act] = seq_s[rows, j], seq_s[rows, j + 1]
                flo[act] = np.where(kept_lo & (prev == 1), 0.5, 1.0) * seq_f[rows, j]
                fhi[act] = np.where(kept_hi & (prev == -1), 0.5, 1.0) * seq_f[rows, j + 1]
                last[act] = np.where(kept_lo, 1, np.where(kept_hi, -1, 0)).astype(np.int8)
                _keep_best(np.abs(ft), trial, ft, zt, act, s_best, f_best, z_best)
            narrow = hi[act] - lo[act] <= 4e-16 * np.maximum(1.0, np.abs(s_best[act]))
            done[act] = lost | narrow | (np.abs(f_best[act]) <= tol)
        current = np.where(
            (bracketed | (f_best == 0)) & np.isfinite(f_best), np.exp(s_best), np.nan
        )
    if not positive.all():  # V <= 0: no current; Z(0) is the model's small-signal limit
        zero = np.flatnonzero(~positive)
        current[zero], z_best[zero] = 0.0, impedance(np.zeros(zero.size), zero)
    return current.reshape(shape), z_best.reshape(shape)
