"""Time-domain check of harmonic balance: the closed loop of Fig 5.12 simulated step by step.

The loop is error -> element -> plant -> output with unity negative feedback and no
reference input (thesis V.6, Fig 5.12), started from a small plant output. The plant
is discretised exactly for a piecewise-constant input (zero-order hold,
:func:`scipy.signal.cont2discrete`); the element is stepped at the same fixed ``dt``
and fed its input extrapolated to the middle of the step, so the hold adds no
half-step delay (the scheme is second order: halving ``dt`` moves the measured cycle
by well under 1 %). Whole batches (several gains, or initial conditions) run
together: one Python step per time step, never per batch member.

The elements (a saturation, a relay, a fitted core's loop operator) are in
:mod:`fitdf.loop.elements`.

Disagreement between this simulation and harmonic balance measures approximations,
not an error of either computation. With a fitted core two of them meet: the loop's
error signal is not sinusoidal (the DF approximation proper), and the winding chain's
DF assumes a sinusoidal *current*, which voltage drive does not give once the core
saturates (Photos 8-13). :func:`simulated_describing_function` measures the DF the
operator really has under sinusoidal voltage; harmonic balance on that DF
(:func:`tabulated_describing_function`) leaves only the first approximation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import signal
from scipy.interpolate import RegularGridInterpolator

from fitdf.errors import OptionError
from fitdf.loop.plant import as_loop_plant

__all__ = [
    "WARMUP_PERIODS",
    "TimeResponse",
    "simulate_loop",
    "measure_oscillation",
    "simulated_describing_function",
    "tabulated_describing_function",
]


# ---------------------------------------------------------------- simulation
#: Periods the element is driven open-loop before a loop started on a sinusoid
#: (``initial_omega``) is closed: one to leave the state at rest, one on the steady loop.
WARMUP_PERIODS = 2


@dataclass(frozen=True)
class TimeResponse:
    """Recorded signals, shape ``(batch, n)``; ``error`` is the element's input (= -output)."""

    t: np.ndarray
    gains: np.ndarray
    error: np.ndarray
    element_output: np.ndarray
    plant_output: np.ndarray
    probe: np.ndarray | None = None  # winding current (core) or None

    def measure(self, settle_fraction: float = 0.6) -> pd.DataFrame:
        """Oscillation amplitude and frequency per batch member (:func:`measure_oscillation`)."""
        rows = []
        for b in range(self.error.shape[0]):  # per batch member, on the recorded arrays
            m = measure_oscillation(self.t, self.error[b], settle_fraction)
            my = measure_oscillation(self.t, self.plant_output[b], settle_fraction)
            row = {"gain": float(self.gains[b]), **m, "plant_output_amplitude": my["amplitude"]}
            if self.probe is not None:
                row["probe_amplitude"] = measure_oscillation(
                    self.t, self.probe[b], settle_fraction
                )["amplitude"]
            rows.append(row)
        return pd.DataFrame(rows)


def simulate_loop(
    plant,
    element,
    gains=1.0,
    *,
    t_end: float,
    dt: float,
    initial_output=0.1,
    initial_omega=None,
    time_scale: float = 1.0,
    record_every: int = 1,
) -> TimeResponse:
    """Simulate the loop of Fig 5.12 (no reference; ``e = -y``) for a batch of gains.

    Parameters
    ----------
    plant : str, (num, den), control system or LoopPlant
        Strictly proper ``G0`` (the loop is ``K G0``, or ``G(s; K)`` for text with ``K``).
    element : Saturation, RelayHysteresis, CoreElement or any object with ``start(batch, dt)``
        returning a runner whose ``step(v, t)`` gives the element's output.
    gains : float or array_like
        One simulation per gain (run together).
    t_end, dt : float
        Duration and fixed step (s).
    initial_output : float or array_like
        Plant output at ``t = 0``, per batch member or shared.
    initial_omega : float or array_like, optional
        None: the plant starts in the minimum-norm state with that output and the element
        at rest. A frequency (rad/s, per member or shared): the loop starts on the sinusoid
        ``y = initial_output cos(initial_omega t)`` -- the plant in its steady state for it
        (``G(j omega)`` finite and nonzero), the element after :data:`WARMUP_PERIODS` periods
        (of the slowest member) driven by the matching error ``-y`` -- so a loop started on a
        predicted cycle settles in a few periods. Started from rest instead, a fitted core
        follows the loop of amplitude zero until its current first turns (thesis IV.1's
        slowly varying amplitude does not hold at a step) and the loop may collapse and grow
        back over tens of periods.
    time_scale : float
        Simulate ``G(s / time_scale)``.
    record_every : int
        Keep every n-th sample.

    Returns
    -------
    TimeResponse
    """
    lp = as_loop_plant(plant, time_scale)
    gains = np.atleast_1d(np.asarray(gains, float))
    if not (dt > 0 and t_end > dt):
        raise OptionError("need dt > 0 and t_end > dt")
    n_steps = int(round(t_end / dt))
    if n_steps > 5_000_000:
        raise OptionError(f"{n_steps} steps is too many; raise dt or lower t_end")
    Ad, Bd, C = _discretise(lp, gains, dt)
    B = gains.size
    y0 = np.broadcast_to(np.asarray(initial_output, float), (B,))
    if initial_omega is None:
        x = np.einsum("bij,bj->bi", np.linalg.pinv(C[:, None, :]), y0[:, None])  # y(0) = y0
    else:
        w0 = np.broadcast_to(np.asarray(initial_omega, float), (B,))
        x = _sinusoidal_state(lp, gains, y0, w0)
    runner = element.start(B, dt)
    e_prev = None
    if initial_omega is not None:  # the element on its loop for the sinusoid it will see
        n_warm = int(np.ceil(WARMUP_PERIODS * 2 * np.pi / w0.min() / dt))
        for n in range(-n_warm, 0):  # ends at t = 0, where the loop takes over
            runner.step(-y0 * np.cos(w0 * (n + 0.5) * dt), (n + 0.5) * dt)
        e_prev = -y0 * np.cos(w0 * -dt)
    n_rec = n_steps // record_every + 1
    rec = {k: np.empty((B, n_rec)) for k in ("e", "u", "y", "p")}
    for n in range(n_steps + 1):  # time necessarily steps; the batch is vectorised
        y = np.einsum("bi,bi->b", C, x)
        e = -y
        # the element's output is held over [t_n, t_n + dt]: feed it the input extrapolated
        # to the middle of the step, so the hold adds no half-step delay (2nd order in dt)
        e_mid = e if e_prev is None else 1.5 * e - 0.5 * e_prev
        e_prev = e
        u = runner.step(e_mid, (n + 0.5) * dt)
        if n % record_every == 0:
            r = n // record_every
            rec["e"][:, r], rec["u"][:, r], rec["y"][:, r] = e, u, y
            if runner.probe is not None:
                rec["p"][:, r] = runner.probe
        x = np.einsum("bij,bj->bi", Ad, x) + Bd * u[:, None]
    t = np.arange(n_rec) * dt * record_every
    return TimeResponse(
        t, gains, rec["e"], rec["u"], rec["y"], rec["p"] if runner.probe is not None else None
    )


def _realisations(lp, gains):
    """Continuous state-space ``(A, B, C)`` of ``G0`` (one, ``K`` applied at the input) or of
    ``G(s; K)`` per gain when ``K`` enters the plant otherwise; the realisation
    :func:`_discretise` samples."""
    out = []
    for g in [1.0] if lp.linear_in_gain else gains:  # one model, or one per gain when K is inside
        num, den = lp.polynomials(g)
        num = np.trim_zeros(np.asarray(num, float), "f")
        if num.size == 0:
            num = np.zeros(1)
        if num.size >= np.trim_zeros(np.asarray(den, float), "f").size:
            raise OptionError(
                "the time-domain check needs a strictly proper plant (more poles than zeros)"
            )
        A, Bm, C, _ = signal.tf2ss(num, den)
        out.append((A, Bm[:, 0], C[0]))
    return out


def _sinusoidal_state(lp, gains, y0, w0):
    """States at ``t = 0`` of the plant's steady response ``y = y0 cos(w0 t)``: with
    ``X = (j w0 I - A)^-1 B`` the state is ``Re(X U)`` and the output ``Re(C X U)``, so
    ``U = y0 / (C X)`` (the input's scale, gain included, drops out)."""
    mats = _realisations(lp, gains)
    x = np.empty((gains.size, mats[0][0].shape[0]))
    for b in range(gains.size):  # one small solve per batch member
        A, Bv, C = mats[0] if lp.linear_in_gain else mats[b]
        bad = not (np.isfinite(w0[b]) and w0[b] > 0)
        if not bad:
            try:
                X = np.linalg.solve(1j * w0[b] * np.eye(A.shape[0]) - A, Bv)
            except np.linalg.LinAlgError:  # a pole of the plant at j w0
                bad = True
        G = C @ X if not bad else np.nan
        if bad or not (np.isfinite(G) and G != 0):
            raise OptionError(
                f"initial_omega {w0[b]:g} rad/s: need a positive frequency where the plant's "
                "response is finite and nonzero"
            )
        x[b] = np.real(X * y0[b] / G)
    return x


def _discretise(lp, gains, dt):
    mats = []
    for A, Bv, C in _realisations(lp, gains):
        Ad, Bd, Cd, _, _ = signal.cont2discrete(
            (A, Bv[:, None], C[None, :], np.zeros((1, 1))), dt, method="zoh"
        )
        mats.append((Ad, Bd[:, 0], Cd[0]))
    if lp.linear_in_gain:
        Ad, Bd, C = mats[0]
        n = gains.size
        return (
            np.broadcast_to(Ad, (n,) + Ad.shape),
            gains[:, None] * Bd,
            np.broadcast_to(C, (n, C.size)),
        )
    return (
        np.stack([m[0] for m in mats]),
        np.stack([m[1] for m in mats]),
        np.stack([m[2] for m in mats]),
    )


def measure_oscillation(t, x, settle_fraction: float = 0.6) -> dict:
    """Amplitude and frequency of the steady oscillation in the tail of a record.

    Uses the samples after ``settle_fraction`` of the record: upward zero crossings of
    ``x - mean`` (linearly interpolated) give the period over the whole cycles; the
    amplitude is half the peak-to-peak over those cycles and ``amplitude_h1`` the
    first-harmonic amplitude (projection on ``sin``/``cos`` at the measured frequency).
    ``oscillating`` is False when fewer than three cycles remain or the oscillation
    decays (the last cycle's peak-to-peak below 90 % of the first one's in the tail, or
    below 1e-9 of the record's scale); ``drift`` is the relative change of the
    peak-to-peak from the first to the last tail cycle.
    """
    t, x = np.asarray(t, float), np.asarray(x, float)
    tail = t >= t[0] + settle_fraction * (t[-1] - t[0])
    tt, xx = t[tail], x[tail]
    nan = {
        "oscillating": False,
        "amplitude": np.nan,
        "amplitude_h1": np.nan,
        "omega": np.nan,
        "frequency_hz": np.nan,
        "n_cycles": 0,
        "drift": np.nan,
    }
    scale = np.max(np.abs(x)) if x.size else 0.0
    if tt.size < 8 or scale == 0:
        return nan
    xc = xx - xx.mean()
    idx = np.nonzero((xc[:-1] < 0) & (xc[1:] >= 0))[0]
    if idx.size < 4:
        return nan
    tc = tt[idx] + (tt[idx + 1] - tt[idx]) * (-xc[idx] / (xc[idx + 1] - xc[idx]))
    period = (tc[-1] - tc[0]) / (tc.size - 1)
    whole = (tt >= tc[0]) & (tt < tc[-1])
    xw, tw = xx[whole], tt[whole]
    omega = 2 * np.pi / period
    h1 = 2 * np.hypot(np.mean(xw * np.sin(omega * tw)), np.mean(xw * np.cos(omega * tw)))
    p2p = [np.ptp(xx[(tt >= a) & (tt < b)]) for a, b in ((tc[0], tc[1]), (tc[-2], tc[-1]))]
    drift = (p2p[1] - p2p[0]) / p2p[0] if p2p[0] > 0 else np.nan
    amp = 0.5 * np.ptp(xw)
    osc = bool(p2p[1] > 0.9 * p2p[0] and amp > 1e-9 * scale)
    return {
        "oscillating": osc,
        "amplitude": float(amp),
        "amplitude_h1": float(h1),
        "omega": float(omega),
        "frequency_hz": float(omega / (2 * np.pi)),
        "n_cycles": int(tc.size - 1),
        "drift": float(drift),
    }


def simulated_describing_function(
    element,
    amplitude,
    frequency_hz,
    *,
    cycles: int = 8,
    settle_cycles: int = 4,
    steps_per_period: int = 1000,
) -> np.ndarray:
    """The DF an element really has under a sinusoidal *voltage* ``v = A sin(2 pi f t)``.

    Every amplitude (and frequency) is one batch member, run together; the first
    harmonic of the output over the last ``cycles - settle_cycles`` periods gives
    ``N = (a1 + j b1) / A`` (lead positive, as in :mod:`fitdf.numerical_df`). For a
    :class:`~fitdf.loop.elements.CoreElement` in the winding chain this is what the
    analyser of section V.2 read -- the current is whatever the circuit makes it --
    whereas the chain's DF assumes a sinusoidal current; the difference is the error of
    that assumption.
    """
    A, f = np.broadcast_arrays(
        np.atleast_1d(np.asarray(amplitude, float)), np.atleast_1d(np.asarray(frequency_hz, float))
    )
    A, f = A.ravel(), f.ravel()
    if np.any(f <= 0) or cycles <= settle_cycles:
        raise OptionError("need positive frequencies and cycles > settle_cycles")
    T = 1.0 / f
    dt = T / steps_per_period  # per member: same phase resolution at every frequency
    n = cycles * steps_per_period
    runner = element.start(A.size, dt)
    acc_s, acc_c = np.zeros(A.size), np.zeros(A.size)
    start = settle_cycles * steps_per_period
    for k in range(n):  # time steps; amplitudes are the batch
        phase = 2 * np.pi * (k + 0.5) / steps_per_period
        u = runner.step(A * np.sin(phase), (k + 0.5) * dt)  # t per member (frequency estimate)
        if k >= start:
            acc_s += u * np.sin(phase)
            acc_c += u * np.cos(phase)
    m = n - start
    with np.errstate(divide="ignore", invalid="ignore"):
        N = np.where(A > 0, 2 * (acc_s + 1j * acc_c) / m / A, 0.0)
    return N.reshape(np.broadcast(np.asarray(amplitude), np.asarray(frequency_hz)).shape)


def tabulated_describing_function(
    element,
    amplitude_range,
    omega_range,
    *,
    n_amplitude: int = 28,
    n_omega: int = 8,
    steps_per_period: int = 400,
    cycles: int = 6,
):
    """:func:`simulated_describing_function` on a log grid, as a callable ``N(A, omega)``.

    One batched simulation covers the whole grid; ``N`` is interpolated linearly in
    ``(ln A, ln omega)`` (real and imaginary parts) and held constant outside the grid.
    Harmonic balance on this table isolates the one approximation that is left, the
    sinusoidal *error signal* of the loop, from the chain's sinusoidal-current DF.
    """
    la = np.linspace(*np.log(amplitude_range), int(n_amplitude))
    lw = np.linspace(*np.log(omega_range), int(n_omega))
    LA, LW = np.meshgrid(la, lw, indexing="ij")
    N = simulated_describing_function(
        element,
        np.exp(LA),
        np.exp(LW) / (2 * np.pi),
        cycles=cycles,
        settle_cycles=cycles // 2,
        steps_per_period=steps_per_period,
    )
    re = RegularGridInterpolator((la, lw), N.real)
    im = RegularGridInterpolator((la, lw), N.imag)

    def table(A, omega):
        A, omega = np.broadcast_arrays(np.asarray(A, float), np.asarray(omega, float))
        pts = np.stack(
            [np.clip(np.log(A), la[0], la[-1]), np.clip(np.log(omega), lw[0], lw[-1])], axis=-1
        )
        return re(pts) + 1j * im(pts)

    return table
