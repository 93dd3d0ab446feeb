"""The loop's nonlinear elements in time: a saturation, a relay with hysteresis, a fitted core.

Each element has ``start(batch, dt)``, which returns a runner whose ``step(v, t)``
gives the element's output for a batch of inputs, and ``describing_function(A,
omega)``; :func:`fitdf.loop.simulate.simulate_loop` steps them in the closed loop.

The core in time (:class:`CoreElement`)
---------------------------------------
The fitted law gives a family of steady-state loops, one per peak input ``a``
(``ascending_branch``; the descending branch is ``-y_up(-x)``). In time, the loop
operator follows the branch of amplitude ``a = |last turning point|`` of the winding
current -- the slowly-varying-amplitude (Krylov-Bogoliubov) assumption of thesis IV.1
-- shifted by a constant so that the flux is continuous at the turning point. With the
``winding`` chain the source voltage ``v`` (the loop's error signal) drives

    v = R i + d(lambda)/dt,    lambda = loop(i),    output = gain d(lambda)/dt,

``R = R_source + r_series``. Each step is implicit (backward Euler on ``lambda``, with
half the previous current increment added to ``v`` so that ``R i`` is centred too):
``R i + (loop(i) - lambda_prev)/dt = v`` is solved for ``i`` on the current branch,
whose left side increases strictly with ``i`` (``R > 0``, branch non-decreasing), so
saturation flats (zero slope) only mean that the current takes the whole voltage. The
branch between turning points is tabulated once per half cycle (``n_table`` points,
dense over ``2.2 a``, geometric beyond) and each step inverts that piecewise-linear
table exactly; the
output ``gain (v - R i)`` is then bounded by the input, without spikes. The
``direct`` chain is the static loop ``output = input_scale loop(v / input_scale)``.
A frequency-dependent law is evaluated at the frequency implied by the last half cycle.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fitdf.chains import get_chain
from fitdf.errors import OptionError
from fitdf.params import calibration_gain

__all__ = ["Saturation", "RelayHysteresis", "CoreElement"]


@dataclass(frozen=True)
class Saturation:
    """``y = clip(slope x, -limit, limit)``; DF ``(2 k / pi)(asin r + r sqrt(1 - r^2))``, ``r = limit/(k A)``."""

    slope: float = 1.0
    limit: float = 1.0

    def start(self, batch, dt):
        return _StaticRunner(lambda v: np.clip(self.slope * v, -self.limit, self.limit))

    def describing_function(self, A, omega=0.0):
        A = np.asarray(A, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.minimum(self.limit / (self.slope * A), 1.0)
            N = (2 * self.slope / np.pi) * (np.arcsin(r) + r * np.sqrt(1.0 - r * r))
        return (
            np.broadcast_to(np.where(np.isfinite(N), N, self.slope), np.broadcast(A, omega).shape)
            + 0j
        )


@dataclass(frozen=True)
class RelayHysteresis:
    """Relay of levels ``+-M`` switching at ``+-h``; DF ``4M/(pi A) (sqrt(1 - (h/A)^2) - j h/A)``."""

    M: float = 1.0
    h: float = 0.1

    def start(self, batch, dt):
        return _RelayRunner(self.M, self.h, batch)

    def describing_function(self, A, omega=0.0):
        A = np.asarray(A, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            N = 4 * self.M / (np.pi * A) * (np.sqrt(1 - (self.h / A) ** 2) - 1j * self.h / A)
        return np.broadcast_to(np.where(A > self.h, N, np.nan), np.broadcast(A, omega).shape)


class _StaticRunner:
    def __init__(self, func):
        self.func = func
        self.probe = None

    def step(self, v, t):
        return self.func(v)


class _RelayRunner:
    def __init__(self, M, h, batch):
        self.M, self.h = M, h
        self.state = np.full(batch, M)
        self.probe = None

    def step(self, v, t):
        self.state = np.where(v >= self.h, self.M, np.where(v <= -self.h, -self.M, self.state))
        return self.state


@dataclass(frozen=True)
class CoreElement:
    """A fitted core as a loop operator in time (module docstring).

    Parameters
    ----------
    model : HysteresisModel subclass
    theta : dict
        The law's parameter values.
    chain : {"voltage", "winding", "direct"}
        ``voltage`` and ``winding`` step the same circuit ``v = R i + d lambda/dt``; they
        differ only in the DF :meth:`describing_function` reports (exact or
        sinusoidal-current).
    resistance : float
        Total series resistance ``R_source + r_series`` (ohm; winding chain).
    gain : float
        Output calibration gain (winding chain).
    input_scale : float
        Volts per model input unit (direct chain).
    source_impedance : float
        Kept to evaluate the matching DF.
    frequency_guess : float
        Hz used by a frequency-dependent law before the first half cycle is seen.
    n_table : int
        Points per branch table.
    """

    model: type
    theta: dict
    chain: str = "winding"
    resistance: float = 1.0
    gain: float = 1.0
    input_scale: float = 1.0
    source_impedance: float = 0.0
    frequency_guess: float = 3.0
    n_table: int = 1600
    chain_theta: dict = field(default_factory=dict, repr=False)

    @classmethod
    def from_fit(cls, result, source_impedance: float = 0.0, **kw) -> CoreElement:
        """The core of a fitted result, driven through ``source_impedance`` ohm."""
        model = result.problem.model
        chain = result.problem.chain.name
        values = result.values
        theta = {p.name: float(values[p.name]) for p in model.params}
        gain = calibration_gain(values)
        ctheta = {
            p.name: float(values.get(p.name, gain if p.name == "gain" else p.default))
            for p in result.problem.chain.params
        }
        if chain in ("winding", "voltage"):  # the same circuit in time; the chain sets the DF
            return cls(
                model,
                theta,
                chain,
                resistance=float(source_impedance) + float(values["r_series"]),
                gain=gain,
                source_impedance=float(source_impedance),
                chain_theta=ctheta,
                **kw,
            )
        if chain == "direct":
            return cls(
                model,
                theta,
                "direct",
                input_scale=float(values["input_scale"]),
                chain_theta=ctheta,
                **kw,
            )
        raise OptionError(f"no time-domain operator for the {chain!r} chain")

    def describing_function(self, A, omega):
        """The DF this element has under sinusoidal input (the chain's prediction)."""
        ch = get_chain(self.chain)
        A, omega = np.broadcast_arrays(np.asarray(A, float), np.asarray(omega, float))
        m = np.array([self.theta[p.name] for p in self.model.params])
        c = np.array([self.chain_theta[p.name] for p in ch.params])
        out = ch.predict(
            self.model,
            A.ravel(),
            omega.ravel() / (2 * np.pi),
            np.full(A.size, self.source_impedance),
            m,
            c,
        )
        return out.reshape(A.shape)

    def start(self, batch, dt):
        if self.chain in ("winding", "voltage"):
            if not self.resistance > 0:
                raise OptionError("the winding operator needs a positive series resistance")
            return _WindingRunner(self, batch, dt)
        return _DirectRunner(self, batch)

    def branch(self, x, d, a, f):
        """Output on the rising (``d = +1``) or falling (``d = -1``) branch of amplitude ``a``."""
        d = np.asarray(d, float)
        return d * self.model.ascending_branch(d * x, a, f, **self.theta)


class _WindingRunner:
    """State of the implicit winding operator for a batch (see the module docstring)."""

    def __init__(self, el: CoreElement, batch: int, dt: float):
        # dt may differ per member (simulated_describing_function runs each frequency at its own step)
        self.el, self.R = el, el.resistance
        self.dt = np.broadcast_to(np.asarray(dt, float), (batch,)).copy()
        self.i = np.zeros(batch)
        self.lam = np.zeros(batch)
        self.d = np.ones(batch)
        self.a = np.zeros(batch)
        self.i_tp = np.zeros(batch)
        self.lam_tp = np.zeros(batch)
        self.t_rev = np.zeros(batch)
        self.f = np.full(batch, float(el.frequency_guess))
        M = int(el.n_table)
        self.S, self.G = np.zeros((batch, M)), np.zeros((batch, M))
        self.built = np.zeros(batch, bool)
        self.offsets = np.arange(batch) * M
        self.di = np.zeros(batch)
        self.probe = self.i

    def _build(self, rows, span):
        el, M = self.el, self.S.shape[1]
        a = np.maximum(self.a[rows], 1e-15)
        dense = 2.2 * a
        m1 = M // 2
        span = np.maximum(span, 1.5 * dense)
        u = np.linspace(0.0, 1.0, m1)
        geo = np.exp(np.linspace(0.0, 1.0, M - m1 + 1)[1:, None] * np.log(span / dense)).T
        S = np.concatenate([dense[:, None] * u, dense[:, None] * geo], axis=1)
        d = self.d[rows][:, None]
        x = self.i_tp[rows][:, None] + d * S
        Y = el.branch(x, d, a[:, None], self.f[rows][:, None])
        Y = Y - Y[:, :1]  # flux relative to the turning point (continuity)
        G = self.R * S + d * Y / self.dt[rows][:, None]
        self.S[rows] = S
        self.G[rows] = np.maximum.accumulate(G, axis=1)  # guard round-off in flats
        self.built[rows] = True

    def step(self, v, t):
        R, dt = self.R, self.dt
        # v is the mid-step drive; the implicit equation puts R i at the step's end, half a
        # step late. Half of the previous increment of i, moved to the right-hand side,
        # restores second order without the ringing a trapezoidal R i has on saturation flats.
        v = v + 0.5 * R * self.di
        rev = self.d * (v - R * self.i) < 0
        if rev.any():  # a turning point of the current: new branch of amplitude |i|
            t = np.broadcast_to(t, rev.shape)[rev]
            half = t - self.t_rev[rev]
            self.f[rev] = np.where(half > 4 * dt[rev], 0.5 / np.maximum(half, dt[rev]), self.f[rev])
            self.t_rev[rev] = t
            self.a[rev] = np.abs(self.i[rev])
            self.i_tp[rev], self.lam_tp[rev] = self.i[rev], self.lam[rev]
            self.d[rev] = -self.d[rev]
            self.built[rev] = False
        tau = self.d * (v - R * self.i_tp) + self.d * (self.lam - self.lam_tp) / dt
        need = ~self.built | (tau >= self.G[:, -1])
        if need.any():  # new half cycle, or the current runs past the table's end
            rows = np.nonzero(need)[0]
            self._build(rows, 4.0 * np.abs(tau[rows]) / R + 1e-300)
        M = self.G.shape[1]
        k = np.minimum(np.maximum((self.G < tau[:, None]).sum(axis=1), 1), M - 1) + self.offsets
        G, S = self.G.ravel(), self.S.ravel()  # flat gathers: cheaper than take_along_axis
        g0, g1, s0, s1 = G[k - 1], G[k], S[k - 1], S[k]
        dg = g1 - g0
        w = np.minimum(np.maximum((tau - g0) / np.where(dg > 0, dg, np.inf), 0.0), 1.0)
        i_new = self.i_tp + self.d * (s0 + w * (s1 - s0))
        emf = v - R * i_new  # d(lambda)/dt from the implicit equation
        self.lam = self.lam + dt * emf
        self.di = i_new - self.i
        self.i[:] = i_new
        return self.el.gain * emf


class _DirectRunner:
    """Static loop operator ``input_scale * loop(v / input_scale)`` with turning-point memory."""

    def __init__(self, el: CoreElement, batch: int):
        self.el = el
        self.x = np.zeros(batch)
        self.d = np.ones(batch)
        self.a = np.zeros(batch)
        self.offset = np.zeros(batch)
        self.lam = np.zeros(batch)
        self.f = np.full(batch, float(el.frequency_guess))
        self.probe = self.x

    def step(self, v, t):
        el = self.el
        x = v / el.input_scale
        rev = self.d * (x - self.x) < 0
        if rev.any():
            self.a[rev] = np.abs(self.x[rev])
            self.d[rev] = -self.d[rev]
            self.offset[rev] = self.lam[rev] - el.branch(
                self.x[rev], self.d[rev], self.a[rev], self.f[rev]
            )
        self.lam = el.branch(x, self.d, self.a, self.f) + self.offset
        self.x[:] = x
        return el.input_scale * self.lam
