"""Measurement chains: from a core's complex inductance ``N(I, f)`` to the measured DF.

The thesis measured its cores as *voltage out over voltage in* under a sinusoidal source
(section V.3), once with the generator straight on the winding and once through 600 ohm
(section V.5). A model gives ``N``, the flux linkage per ampere of winding current; a
chain maps ``N`` onto what the transfer-function analyser read:

* :class:`DirectChain` (``direct``) -- ``DF = N(V / input_scale)``: the textbook view in
  which the core *is* the nonlinearity and the input voltage only sets its amplitude
  scale. The model's own gain is the measured gain; there is no source impedance and no
  phase lead (a passive loop has ``Im N <= 0``). The baseline for comparing shapes.
* :class:`WindingChain` (``winding``) -- the circuit of Fig 5.10: source ``V``, series
  resistance ``R = R_source + r_winding``, and the winding of impedance
  ``Z(I, f) = j 2 pi f N(I, f)``. The current amplitude solves ``I |R + Z(I, f)| = V``
  and the output (the core's EMF, read on a secondary winding) over the input is
  ``DF = gain Z / (R + Z)``. Because ``Z`` leads the current by nearly 90 degrees and the
  current lags ``V``, the output *leads* the input (Fig 5.10, Graphs 5.4, 5.12).

Every chain has ``name``, ``title``, ``params`` and the class methods ``predict``,
``core_current`` and ``operating_point``; ``model_theta`` ``(p,)`` or ``(batch, p)`` and
``chain_theta`` ``(q,)`` or ``(batch, q)`` broadcast (MCMC walkers evaluate in one call).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, ClassVar

import numpy as np

from .errors import ModelError
from .params import ParamSpec, split_theta

__all__ = ["MeasurementChain", "DirectChain", "WindingChain", "OperatingPoint", "CHAINS",
           "get_chain", "chain_names", "solve_current"]

#: Smallest series resistance (ohm) the winding solver uses; ``R = 0`` is replaced by it.
R_MIN = 1e-12
_LN10 = np.log(10.0)


@dataclass(frozen=True)
class OperatingPoint:
    """Solved state at each data point (arrays of the broadcast shape): the winding current
    amplitude ``current`` (A, the model's input amplitude), ``inductance`` ``N(I, f)`` (H)
    and the predicted measured ``df``."""

    current: np.ndarray
    inductance: np.ndarray
    df: np.ndarray


def _model(model):
    from .models import get_model  # the registry imports every law; chains need it only here

    return get_model(model)


def _points(amplitude, frequency, source_impedance):
    V, f, Rs = (np.asarray(v, dtype=float) for v in (amplitude, frequency, source_impedance))
    if np.any(Rs < 0):
        raise ModelError("source_impedance must be >= 0 ohm")
    return V, f, Rs


class MeasurementChain:
    """Base class: what a chain declares and the three class methods it provides."""

    name: ClassVar[str] = ""
    title: ClassVar[str] = ""
    params: ClassVar[tuple[ParamSpec, ...]] = ()

    @classmethod
    def operating_point(cls, model, amplitude, frequency, source_impedance, model_theta,
                        chain_theta, *, initial_current=None) -> OperatingPoint:
        """Current, inductance and predicted DF at each point (one solve for all three)."""
        raise NotImplementedError

    @classmethod
    def predict(cls, model, amplitude, frequency, source_impedance, model_theta, chain_theta, *,
                initial_current=None):
        """Complex measured DF.

        Parameters
        ----------
        model : str or HysteresisModel subclass
            The hysteresis law (a registry name or the class).
        amplitude, frequency, source_impedance : array_like
            1-D arrays of the ``n`` data points: input voltage amplitude (V), frequency
            (Hz) and series source resistance (ohm).
        model_theta : array_like
            Model parameters, shape ``(p,)`` or ``(batch, p)``.
        chain_theta : array_like
            Chain parameters, shape ``(q,)`` or ``(batch, q)``.
        initial_current : array_like, optional
            Warm start for chains that solve for the current (e.g. the ``current`` of a
            previous :meth:`operating_point` at nearby parameters); only speed depends on it.

        Returns
        -------
        numpy.ndarray of complex
            Shape ``(n,)`` or ``(batch, n)``; ``angle > 0`` is a phase lead.
        """
        return cls.operating_point(model, amplitude, frequency, source_impedance, model_theta,
                                   chain_theta, initial_current=initial_current).df

    @classmethod
    def core_current(cls, model, amplitude, frequency, source_impedance, model_theta, chain_theta, *,
                     initial_current=None):
        """Amplitude of the winding current (the model's input amplitude), same shape as :meth:`predict`."""
        return cls.operating_point(model, amplitude, frequency, source_impedance, model_theta,
                                   chain_theta, initial_current=initial_current).current

    @classmethod
    def param_names(cls) -> list[str]:
        return [p.name for p in cls.params]

    @classmethod
    def defaults(cls) -> dict[str, float]:
        return {p.name: p.default for p in cls.params}

    @classmethod
    def describe(cls) -> dict:
        """Plain-dict description for listings and JSON."""
        return {"name": cls.name, "title": cls.title,
                "parameters": [{"name": p.name, "unit": p.unit, "default": p.default,
                                "bounds": list(p.bounds), "description": p.description,
                                "equation": p.equation, "log": p.log} for p in cls.params]}


class DirectChain(MeasurementChain):
    """``DF = N(V / input_scale)``: the core's DF read directly, input scaled to model units.

    The model's gain parameter (``k``, ``mu0``) plays the measured gain, so the model is
    dimensionless here (``k ~ 1``). It ignores ``source_impedance`` and cannot lead:
    ``angle(DF) = angle(N) <= 0`` for every passive loop. This is the comparison of shapes
    that section V.4.1 makes against Graphs 4.2 and 4.4.
    """

    name = "direct"
    title = "Core DF read directly (input scale only)"
    params = (
        ParamSpec("input_scale", 3e3, (1.0, 1e7), unit="V/A",
                  description="input volts per unit of model input (winding current)",
                  equation="sec V.4.1 (calibration in input volts)", log=True),
    )

    @classmethod
    def operating_point(cls, model, amplitude, frequency, source_impedance, model_theta,
                        chain_theta, *, initial_current=None) -> OperatingPoint:
        model = _model(model)
        V, f, _ = _points(amplitude, frequency, source_impedance)
        scale = split_theta(cls.params, chain_theta)["input_scale"]
        current = V / scale
        N = model.describing_function(current, f, **split_theta(model.params, model_theta))
        current, N = np.broadcast_arrays(current, N)
        return OperatingPoint(current.copy(), N.copy(), N.copy())


class WindingChain(MeasurementChain):
    """Sinusoidal source, series resistance and the core's winding (Fig 5.10, section V.5).

    The winding current amplitude ``I`` solves ``I |R + Z(I, f)| = V`` with
    ``R = R_source + r_winding`` and ``Z = j 2 pi f N(I, f)`` (:func:`solve_current`); the
    predicted reading is ``DF = gain Z / (R + Z)``. Where the loop has no height
    (``N = 0``, amplitudes inside a backlash-like dead zone) ``I = V / R`` and ``DF = 0``.
    As ``R -> 0``, ``DF -> gain`` wherever the core can carry the flux ``V / (2 pi f)``,
    i.e. below the saturation voltage ``2 pi f |I N(I)|_max``, which grows linearly with
    ``f`` (Graph 5.3). Above it even a vanishing ``R`` takes the excess voltage.

    ``gain`` is a calibration factor: the 0 ohm tables (B.1, B.2) plateau near 0.95
    rather than 1, and their footnote turns-ratio factors (1250/417, 2000/500) are
    doubtful, so the data demand a free gain; a perfect instrument has ``gain = 1``.
    Only the fundamental is modelled: the distortion of the current (Photos 8, 9) is
    the stated reason why the corrected and measured curves of Graph 5.10 differ.
    """

    name = "winding"
    title = "Winding in series with the source resistance (Fig 5.10)"
    params = (
        ParamSpec("r_winding", 70.0, (1.0, 5000.0), unit="ohm",
                  description="winding resistance (plus any fixed series resistance)",
                  equation="sec V.5, Fig 5.10", log=True),
        ParamSpec("gain", 1.0, (0.5, 1.5), unit="1",
                  description="calibration gain of the output reading (turns ratio, analyser)",
                  equation="Tables B.1-B.5 footnotes"),
    )

    @classmethod
    def _solve(cls, model, amplitude, frequency, source_impedance, model_theta, chain_theta, initial_current):
        model = _model(model)
        V, f, Rs = _points(amplitude, frequency, source_impedance)
        mkw = split_theta(model.params, model_theta)
        ckw = split_theta(cls.params, chain_theta)
        R = np.maximum(Rs + ckw["r_winding"], R_MIN)
        shape = np.broadcast_shapes(V.shape, f.shape, R.shape, *(np.shape(v) for v in mkw.values()))
        # Flat per-point copies let the solver evaluate the model on unconverged points only.
        flat_f = np.broadcast_to(f, shape).ravel()
        flat_kw = {k: np.broadcast_to(v, shape).ravel() for k, v in mkw.items()}

        def impedance(current, index):
            N = model.describing_function(current, flat_f[index], **{k: v[index] for k, v in flat_kw.items()})
            return 2j * np.pi * flat_f[index] * N

        current, Z = solve_current(impedance, np.broadcast_to(V, shape), np.broadcast_to(R, shape),
                                   initial=initial_current)

        def inductance(i):
            return model.describing_function(i, f, **mkw)

        return current, Z, ckw["gain"] * Z / (R + Z), inductance

    @classmethod
    def predict(cls, model, amplitude, frequency, source_impedance, model_theta, chain_theta, *,
                initial_current=None):
        """``gain Z / (R + Z)`` at the self-consistent current; see :meth:`MeasurementChain.predict`."""
        return cls._solve(model, amplitude, frequency, source_impedance, model_theta, chain_theta,
                          initial_current)[2]

    @classmethod
    def operating_point(cls, model, amplitude, frequency, source_impedance, model_theta,
                        chain_theta, *, initial_current=None) -> OperatingPoint:
        current, _, df, inductance = cls._solve(model, amplitude, frequency, source_impedance,
                                                model_theta, chain_theta, initial_current)
        N = inductance(current)
        shape = np.broadcast_shapes(df.shape, N.shape)
        return OperatingPoint(*(np.broadcast_to(a, shape).copy() for a in (current, N, df)))


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
    s_best[upd], f_best[upd], z_best[upd] = trial[rows, b][better], ft[rows, b][better], zt[rows, b][better]


def solve_current(impedance: Callable[[np.ndarray, np.ndarray], np.ndarray], voltage, resistance, *,
                  initial=None, tol: float = 1e-12, max_iter: int = 60, budget: int | None = None):
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
            step = np.concatenate([np.abs(f_base)[:, None] * np.array(multiples),
                                   np.broadcast_to(_LN10 * np.array(decades), (need.size, len(decades)))], axis=1)
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
            extra = int(min(31, budget // act.size - 1))  # never more evaluations than the first call
            if extra <= 0:  # many points left: one Illinois step each
                fs, zs = residual(guess, act)
                low = fs < 0
                move = np.where(low, -1, 1).astype(np.int8)
                lo[act], flo[act] = np.where(low, guess, l), np.where(low, fs, np.where(prev == 1, 0.5 * fl, fl))
                hi[act], fhi[act] = np.where(low, h, guess), np.where(low, np.where(prev == -1, 0.5 * fh, fh), fs)
                last[act] = move
                _keep_best(np.abs(fs)[:, None], guess[:, None], fs[:, None], zs[:, None], act, s_best, f_best, z_best)
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
        current = np.where((bracketed | (f_best == 0)) & np.isfinite(f_best), np.exp(s_best), np.nan)
    if not positive.all():  # V <= 0: no current; Z(0) is the model's small-signal limit
        zero = np.flatnonzero(~positive)
        current[zero], z_best[zero] = 0.0, impedance(np.zeros(zero.size), zero)
    return current.reshape(shape), z_best.reshape(shape)


#: Registered chains by name.
CHAINS: dict[str, type[MeasurementChain]] = {c.name: c for c in (DirectChain, WindingChain)}


def chain_names() -> list[str]:
    return list(CHAINS)


def get_chain(name) -> type[MeasurementChain]:
    """Chain class by name (a class passes through); :class:`ModelError` for unknown names."""
    if isinstance(name, type) and issubclass(name, MeasurementChain):
        return name
    if name not in CHAINS:
        raise ModelError(f"unknown measurement chain {name!r}; known chains: {', '.join(CHAINS)}")
    return CHAINS[name]
