r"""The ``voltage`` chain: the exact periodic steady state of the circuit of Fig 5.10.

Provides :class:`VoltageChain` (registered as ``voltage``, the default chain of every fit),
its numerical settings :class:`VoltageSettings`, and :func:`steady_state_waveform`, one
point's current, flux linkage and output over a whole period (:class:`SteadyState`).

A sinusoidal source drives the core's winding through ``R = R_source + r_series``
(thesis section V.5, Fig 5.10), and the winding's flux linkage ``lambda`` follows the
law's hysteresis loop::

    V sin(wt) = R i + d lambda / dt,        output = gain d lambda / dt.

The DF is the output's first harmonic over ``V`` with the convention of
:mod:`fitdf.numerical_df` (``angle > 0`` is a lead). Unlike the ``winding`` chain, this chain
assumes no current waveform: the current takes whatever shape the loop and the drive give
it ("introducing resistance in series also changes the current wave shape", end of section
V.5; Photos 8, 9).

Notes
-----
In the half-wave-symmetric steady state the current rises monotonically from ``-I_p`` to
``I_p`` over half a period, so the core runs exactly the law's loop of amplitude ``I_p``.
The rising half is integrated along that loop's ascending branch from the phase
``phi0 = -arcsin(R I_p / V)`` at which the EMF rises through zero (BDF2 steps on a
piecewise-linear table of the branch, each implicit step solved exactly; compiled in
:mod:`fitdf.chains._periodic`), and ``I_p`` is the root of ``G(I_p) = i_peak - I_p``, found
for all points at once by a coarse and then a fine secant search that also handles the
jumps of ``G`` where the peak is reached by a jump onto a saturation flat. The first
harmonic is taken from the flux, ``DF = gain j w Lambda_1 / V`` with
``Lambda_1 = (2/pi) int lambda (sin + j cos) d(wt)``, corrected for BDF2's dispersion.
The method assumes one monotone rise and fall of the current per period (no minor loops,
no subharmonics). With the default :class:`VoltageSettings` the DF is accurate to about
2e-4 for every registered law at 0 and 600 ohm, against exact piecewise-linear integration
and ``scipy.integrate.solve_ivp`` (``tests/test_voltage_chain.py``,
``benchmarks/bench_voltage.py``); its discrete decisions (step refinement, node placement,
convergence) make it jitter by up to ~1e-5 (1e-4 at the edge of a jump) between parameter
sets a hair apart, so finite-difference Jacobians need steps above that. The full method
is in the documentation's method pages (measurement chains).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace

import numpy as np

from fitdf.chains._periodic import (
    N_OUT,
    half_period_wave,
    half_periods,
    kernel_array,
    place_nodes,
)
from fitdf.chains._secant import secant_update
from fitdf.chains.base import R_MIN, MeasurementChain, OperatingPoint, as_points
from fitdf.chains.winding import WindingChain
from fitdf.errors import ModelError
from fitdf.models import get_model
from fitdf.params import split_theta

__all__ = ["VoltageChain", "VoltageSettings", "SteadyState", "steady_state_waveform"]


@dataclass(frozen=True)
class VoltageSettings:
    """Numerical knobs of :class:`VoltageChain` (defaults from the convergence study).

    Attributes
    ----------
    steps : int
        BDF2 steps per half period (fine stage).
    nodes : int
        Branch table nodes (fine stage; the kernel splits each cell once more).
    coarse_steps, coarse_nodes : int
        The same for the coarse root search.
    placement_nodes : int
        Uniform nodes of the coarse table from which the fine nodes are placed.
    refine_factor : float
        A step is shortened when the state moves along the branch more than this many
        times the distance a sinusoid covers in a regular step at its fastest.
    coarse_tol, tol : float
        Relative tolerance in ``I_p`` of the coarse root and of the final secant root.
    df_tol : float
        Largest linear DF correction from the last evaluation to the root accepted (the
        interpolation error is a fraction of it).
    max_iter : int
        Cap on evaluations per stage.
    weights : tuple of float
        Shares of current range, flux swing and bending in the node placement.
    threads : int
        numba threads for large kernel calls (1: none; on two shared cores threads are
        slower, ``benchmarks/README.md``).
    """

    steps: int = 192
    nodes: int = 64
    coarse_steps: int = 32
    coarse_nodes: int = 24
    placement_nodes: int = 32
    refine_factor: float = 3.0
    coarse_tol: float = 1e-2
    tol: float = 2e-3
    df_tol: float = 2e-4
    max_iter: int = 40
    weights: tuple = (1.0, 1.0, 1.0)
    threads: int = 1


class _Points:
    """Flat per-point data of one call and the branch tables/kernel runs on subsets."""

    def __init__(self, model, V, f, R, kw, threads=1, rate=None):
        self.model, self.V, self.f, self.R, self.kw = model, V, f, R, kw
        self.w = 2.0 * np.pi * f
        self.threads = threads
        # coefficients (c_cl, c_ex) of the rate-dependent current per point, or None
        self.rate = rate

    def branch(self, idx, x, a, rough=False):
        """``B(x; a)`` at the points ``idx``; ``x`` is ``(m, K)``, ``a`` is ``(m,)``; with
        ``rough``, the law's :meth:`~fitdf.models.base.HysteresisModel.rough_branch`."""
        kw = {k: v[idx, None] for k, v in self.kw.items()}
        law = self.model.rough_branch if rough else self.model.ascending_branch
        return kernel_array(law(x, a[:, None], self.f[idx, None], **kw), x.shape)

    def run(self, idx, a, u, steps, refine_factor, rough=False, B=None, peak=False):
        """Kernel on tables at nodes ``u`` (``(m, M)`` or ``(M,)``): ``(G, DF without gain, B)``;
        ``B``, if given, is the branch at those nodes (already evaluated); with ``peak``, the
        excess of the largest total current over the largest ``i_h`` is appended."""
        u = np.broadcast_to(u, (idx.size, np.shape(u)[-1]))
        x = np.ascontiguousarray(a[:, None] * u)
        if B is None:
            B = self.branch(idx, x, a, rough)
        V, R = self.V[idx], self.R[idx]
        phi0 = -np.arcsin(np.minimum(R * a / V, 1.0))
        out = np.empty((idx.size, N_OUT))
        c_cl, c_ex = (None, None) if self.rate is None else (c[idx] for c in self.rate)
        half_periods(
            x,
            B,
            V,
            R,
            self.w[idx],
            phi0,
            int(steps),
            refine_factor * np.pi / steps,
            out,
            self.threads,
            c_cl,
            c_ex,
        )
        df = 1j * _bdf2_response(steps) * self.w[idx] * (out[:, 1] + 1j * out[:, 2]) / V
        if peak:  # by how much the total current's peak exceeds the branch's (rate-dependent)
            return out[:, 0] - a, df, B, out[:, 4] - out[:, 0]
        return out[:, 0] - a, df, B


def _place(pts, idx, I, st):
    """Fine nodes ``u`` (``(m, nodes)``) for the points ``idx`` at amplitudes ``I``.

    Placed (:func:`~fitdf.chains._periodic.place_nodes`) from a uniform table of
    ``placement_nodes``, then again from the table they give; where one cell still holds a
    fifth of the flux swing (a step narrower than a node spacing: an almost rectangular
    loop), again, up to 3 more times. Returns the nodes and where that was needed.
    """
    w = np.asarray(st.weights, float)
    u0 = kernel_array(np.linspace(-1.0, 1.0, st.placement_nodes), (idx.size, st.placement_nodes))
    u1 = np.empty((idx.size, st.nodes))
    place_nodes(u0, pts.branch(idx, I[:, None] * u0, I), w, u1)
    B1 = pts.branch(idx, I[:, None] * u1, I)
    u2 = np.empty((idx.size, st.nodes))
    place_nodes(u1, B1, w, u2)
    narrow = _largest_share(B1) > 0.2
    todo = np.flatnonzero(narrow)
    for _ in range(3):
        if not todo.size:
            break
        B2 = pts.branch(idx[todo], I[todo, None] * u2[todo], I[todo])
        again = _largest_share(B2) > 0.2
        todo, B2 = todo[again], B2[again]
        if todo.size:
            u3 = np.empty((todo.size, st.nodes))
            place_nodes(np.ascontiguousarray(u2[todo]), B2, w, u3)
            u2[todo] = u3
    return u2, narrow


def _largest_share(B):
    """Largest share of a table row's flux swing between neighbouring nodes (0 if none)."""
    hull = np.maximum.accumulate(B, axis=1)
    swing = hull[:, -1] - hull[:, 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        share = (hull[:, 1:] - hull[:, :-1]).max(axis=1) / swing
    # where the swing is positive the share is in [0, 1] or NaN (a NaN or infinite table):
    # fmax makes NaN 0, as nan_to_num would, at a tenth of its cost (it runs every step)
    return np.where(swing > 0, np.fmax(share, 0.0), 0.0)


@functools.lru_cache(maxsize=8)
def _bdf2_response(steps):
    """BDF2's derivative of ``exp(j theta)`` over ``j exp(j theta)`` at the regular step ``pi/steps``.

    The scheme's EMF ``e_n = w BDF2(lam)_n`` is the circuit's ``V sin - R i`` at the
    nodes, so its fundamental is this factor (``1 + 8.9e-5`` at 192 steps) times
    ``j w Lambda_1``: multiplying by it removes BDF2's leading dispersion error.
    """
    h = np.pi / steps
    z = np.exp(-1j * h)
    return (3.0 - 4.0 * z + z * z) / (2.0 * h * 1j)


def _guess(pts, idx, hi):
    """Current amplitude at which a sinusoidal flux of the loop tip's size needs ``V``.

    ``hypot(R a, w B(a; a)) = V`` on the amplitudes ``10^(j/2)`` (integer ``j``, two per
    decade) from 24 decades below ``V/R``, and at ``V/R``: the first crossing,
    log-interpolated. The tips depend only on the law's parameters (and on ``f`` for a
    frequency-dependent law), not on ``V`` or ``R``, so they are evaluated once per distinct
    parameter row on one lattice rather than per point (for Jiles-Atherton every tip is a
    steady-loop solve, so the tips are the law's rough branch). The lattice is absolute, so
    a point's guess does not depend on the other points of the call.
    """
    lo = np.floor(2.0 * np.log10(np.min(hi) * 1e-24))
    top = np.ceil(2.0 * np.log10(np.max(hi))) + 1.0
    grid = 10.0 ** (np.arange(lo, top + 1.0) / 2.0)
    cols = [v[idx] for v in pts.kw.values()]
    if getattr(pts.model, "frequency_dependent", True):
        cols.append(pts.f[idx])
    keys = np.stack(cols, axis=1) if cols else np.zeros((idx.size, 1))
    _, first, owner = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    rep = idx[first]
    kw = {name: v[rep, None] for name, v in pts.kw.items()}
    a = np.broadcast_to(grid, (rep.size, grid.size))
    tips = np.broadcast_to(pts.model.rough_branch(a, a, pts.f[rep, None], **kw), a.shape)
    tip = tips[np.ravel(owner)]
    h = np.hypot(pts.R[idx, None] * grid, pts.w[idx, None] * tip) - pts.V[idx, None]
    # ... and ``V/R`` itself, the end of every point's range (exact for a dead zone, where
    # the current is V/R): the amplitudes in play are the lattice's in [V/R 1e-24, V/R), then V/R
    kw_own = {name: v[idx, None] for name, v in pts.kw.items()}
    own = pts.model.rough_branch(hi[:, None], hi[:, None], pts.f[idx, None], **kw_own)
    h_hi = np.hypot(pts.R[idx] * hi, pts.w[idx] * np.broadcast_to(own, (idx.size, 1))[:, 0])
    a = np.concatenate([np.broadcast_to(grid, h.shape), hi[:, None]], axis=1)
    h = np.concatenate([h, (h_hi - pts.V[idx])[:, None]], axis=1)
    first_in = np.argmax(grid >= hi[:, None] * 1e-24, axis=1)
    last_below = np.sum(grid < hi[:, None], axis=1) - 1
    cols = np.arange(grid.size + 1)
    in_play = ((cols >= first_in[:, None]) & (cols <= last_below[:, None])) | (cols == grid.size)
    above = in_play & (np.nan_to_num(h, nan=1.0) >= 0)
    k = np.argmax(above, axis=1)  # V/R, the last column, is always above (R V/R >= V)
    k0 = np.where(k == grid.size, last_below, k - 1)
    k0 = np.where(k0 >= first_in, k0, k)
    rows = np.arange(idx.size)
    h0, h1 = h[rows, k0], h[rows, k]
    la0, la1 = np.log(a[rows, k0]), np.log(a[rows, k])
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where((k > k0) & (h1 > h0), -h0 / (h1 - h0), 0.0)
    return np.exp(la0 + np.clip(np.nan_to_num(t), 0.0, 1.0) * (la1 - la0))


def _search(
    pts,
    idx,
    x0,
    evaluate,
    tol,
    max_iter,
    slope0=None,
    dslope0=None,
    max_step=np.inf,
    df_tol=2e-4,
    confirm=True,
):
    """Root of ``G`` for the points ``idx`` from ``x0``, and the DF there.

    ``evaluate(sub, x)`` returns ``(G, DF)`` for the subset ``sub`` (positions into
    ``idx``); each step is then :func:`~fitdf.chains._secant.secant_update`, compiled,
    per point. A bracket ``[lo, hi]`` (``G(lo) > 0 >= G(hi)``; ``hi`` starts at ``V/R``
    where ``G <= 0``) is kept with the two newest points on each side.

    Steps: the first is ``-G / slope0`` (``slope0``: a slope known from a previous stage)
    or ``G / 2`` (exact for a linear core behind a small ``R``); until the bracket has both
    ends, steps are at most ``max_step x``.
    Then the secant root of the last two evaluations, if it lies in the bracket and their
    slope agrees within a factor 2 with the other pairs' (the two newest points of each
    side, the pair followed the step before, ``slope0``). Otherwise -- ``G`` jumps between
    them, as where the steady state's peak is a jump onto a saturation flat: ``G`` tends
    to 0 from one side of the edge only -- the
    secant root of the two newest points of the side whose newest ``|G|`` is smaller (it
    extrapolates to the edge), else of the other side; a bisection if these leave the
    bracket; else regula falsi with the Illinois halving, or log-bisection while the
    bracket spans decades. A bisection is forced when the bracket has not halved in three
    steps.

    Converged when the root ``r`` of the pair followed is within ``tol`` (relative) of the
    pair's newer point, the pair spans at most 5 %, the linear DF correction from that
    point to ``r`` is at most ``df_tol`` (the interpolation error, ``DF''/2`` times the
    distances to both points, is then a fraction of it) and, for the last two evaluations
    (if ``confirm``), their slope is confirmed by another pair's (within a factor 2): a
    side's newest two, unless they are these two (both on one side: ``G`` approached from
    one side, where its curvature goes unseen), the pair followed the step before, or
    ``slope0``. One evaluation never suffices: slopes from a coarser stage can be off by
    10x where the DF is sensitive (at the edge of a dead zone). Also when ``G = 0``, or
    the bracket is narrower than ``tol / 8``, or than ``tol`` with DFs at its ends within
    ``2 df_tol`` (DF linear between its ends) and a secant root inside it. (Where no secant
    root falls inside the bracket, ``G`` jumps there -- the edge where the peak is reached
    by a jump into saturation, ``G > 0`` up to it --: ``tol / 8`` puts the peak current, not
    only the DF, near the edge; it took the DF's error at such edges from ~2e-4 to ~5e-5
    against the exact piecewise references.)

    Except where the DF jumps inside the bracket: DFs at its ends that differ by more than
    half the larger. At the edge of a dead zone (``constant_width`` with ``V/R`` just above
    its half-width) the loop closes for every amplitude below the edge and the DF there is
    0; ``G`` jumps at the edge but crosses 0 continuously just beyond it, in a sliver that
    can be 1e-5 of the amplitude wide, and the steady state is that crossing. There a bracket
    is accepted only once narrower than
    :data:`~fitdf.chains._secant.BRACKET_FLOOR` (never an interpolation between a closed
    and an open loop: it gave half the DF), and a secant root only if also the DF's
    quadratic term at the root, from its curvature through the bracket's other end, is at
    most :data:`~fitdf.chains._secant.CURVATURE_SHARE` times ``df_tol`` (beyond the
    edge the DF bends steeply, and two points farther out can have a nearly flat secant).

    Returns ``(root, DF at the root, slope of G, slope of DF, lower end of the bracket)``;
    the slopes are those of the pair followed last (for a following stage).
    """
    m = idx.size
    X = np.full((m, 6), np.nan)
    G = np.full((m, 6), np.nan)
    D = np.full((m, 6), np.nan + 0j)
    F = np.full((m, 9), np.nan)
    F[:, 0] = pts.V[idx] / pts.R[idx]
    F[:, 3] = 0.0
    F[:, 4] = F[:, 0]
    F[:, 5] = np.clip(x0, 1e-300, F[:, 0])
    if slope0 is not None:
        F[:, 7] = slope0
    C = np.full((m, 3), np.nan + 0j)
    if dslope0 is not None:
        C[:, 2] = dslope0
    done = np.zeros(m, bool)
    act = np.arange(m)
    for it in range(max_iter):
        x = F[act, 5]
        g, d = evaluate(act, x)
        secant_update(
            act,
            x,
            np.asarray(g, float),
            np.asarray(d, complex),
            it,
            X,
            G,
            D,
            F,
            C,
            done,
            float(tol),
            float(max_step),
            float(df_tol),
            bool(confirm),
        )
        act = np.flatnonzero(~done)
        if not act.size:
            break
    # not converged within max_iter: the last iterate
    F[act, 6], C[act, 0] = X[act, 0], D[act, 0]
    return F[:, 6], C[:, 0], F[:, 8], C[:, 1], X[:, 2]


def _initial_currents(pts, live, hi, initial, P):
    """Where the coarse search starts at the ``live`` points: ``initial`` (broadcast to the
    ``P`` points) where finite and positive, :func:`_guess` elsewhere, clipped to
    ``(0, V/R]`` (``hi``)."""
    x0 = None
    if initial is not None:
        x0 = np.broadcast_to(np.asarray(initial, float), (P,))[live].copy()
        ok = np.isfinite(x0) & (x0 > 0)
        x0[~ok] = np.nan
    if x0 is None or np.isnan(x0).any():
        g = _guess(pts, live, hi)
        x0 = g if x0 is None else np.where(np.isnan(x0), g, x0)
    return np.clip(x0, hi * 1e-30, hi)


def _solve(model, V, f, R, kw, initial, st: VoltageSettings, rate=None):
    """Peak currents, DFs (without gain), fine nodes ``u`` and the largest current tried
    with ``G > 0`` (NaN: none) for flat point arrays. ``rate``: ``(c_cl, c_ex)`` per point
    of the rate-dependent current (:mod:`fitdf.chains.dynamic`), or None. One function:
    the fine stage re-places nodes inside the search on state (nodes, placements, shares)
    that the stages share, which a split would hand through every call."""
    P = V.size
    pts = _Points(model, V, f, R, kw, st.threads, rate)
    current = np.zeros(P)
    df = np.zeros(P, complex)
    u_fine = np.broadcast_to(np.linspace(-1.0, 1.0, st.nodes), (P, st.nodes)).copy()
    below = np.full(P, np.nan)
    live = np.flatnonzero(V > 0)
    if not live.size:
        return current, df, u_fine, below
    hi = V[live] / R[live]
    x0 = _initial_currents(pts, live, hi, initial, P)
    # 1. coarse root
    u_c = np.linspace(-1.0, 1.0, st.coarse_nodes)

    def coarse(sub, x):
        g, d, _ = pts.run(live[sub], x, u_c, st.coarse_steps, st.refine_factor, rough=True)
        return g, d

    # (a coarse root fooled by a jump of G only costs the fine stage more steps)
    Ic, _, slope_c, dslope_c, _ = _search(
        pts, live, x0, coarse, st.coarse_tol, st.max_iter, df_tol=np.inf, confirm=False
    )
    Ic = np.where(np.isfinite(Ic) & (Ic > 0), Ic, hi)
    # 2. fine stage on nodes placed at the coarse root -- except where the placement had
    # to resolve a step narrower than its node spacing (an almost rectangular loop): such
    # a step moves in u = x / I as I changes, so those points get nodes placed anew at
    # every amplitude tried
    u2, narrow = _place(pts, live, Ic, st)
    u_fine[live] = u2
    placed_at = Ic.copy()
    placed_share = np.full(live.size, np.nan)  # largest flux share of a cell where placed

    def fine(sub, x):
        u = u2[sub].copy()
        B = pts.branch(live[sub], x[:, None] * u, x)
        share = _largest_share(B)
        at_placement = x == placed_at[sub]
        first = at_placement & np.isnan(placed_share[sub])
        placed_share[sub[first]] = share[first]
        # Nodes placed at one amplitude no longer resolve the loop at another when a
        # cell now holds a much larger share of the flux swing than any did where they were
        # placed: the loop changed shape under them (a steep side that opens as ``I``
        # passes a coercive current moves and widens in ``u`` by far more than ``dI/I``;
        # nodes placed at a coarse root inside a dead zone resolve no loop at all). And a
        # step of relative width w in u moves by about u dI/I: re-place beyond 1e-3.
        reference = np.where(np.isnan(placed_share[sub]), 0.0, placed_share[sub])
        stale = ~at_placement & (
            (share > np.maximum(0.2, 1.5 * reference))
            | (narrow[sub] & (np.abs(x / placed_at[sub] - 1) > 1e-3))
        )
        moving = np.flatnonzero(stale)
        if moving.size:
            targets = sub[moving]
            u[moving], narrow[targets] = _place(pts, live[targets], x[moving], st)
            B = B.copy()  # (the branch may hand back a read-only broadcast)
            B[moving] = pts.branch(live[targets], x[moving, None] * u[moving], x[moving])
            u2[targets] = u[moving]
            placed_at[targets] = x[moving]
            placed_share[targets] = _largest_share(B[moving])
        g, d, _ = pts.run(live[sub], x, u, st.steps, st.refine_factor, B=B)
        return g, d

    slope0 = np.where(np.isfinite(slope_c) & (slope_c < 0), slope_c, -2.0)
    root, droot, _, _, lo = _search(
        pts,
        live,
        Ic,
        fine,
        st.tol,
        st.max_iter,
        slope0=slope0,
        dslope0=dslope_c,
        max_step=0.01,
        df_tol=st.df_tol,
    )
    u_fine[live] = u2
    current[live] = root
    df[live] = droot
    below[live] = lo
    return current, df, u_fine, below


class VoltageChain(MeasurementChain):
    """Sinusoidal voltage source, series resistance and the core's winding, solved exactly.

    The periodic steady state of ``V sin(wt) = R i + d lambda/dt`` with the law's loop
    (``R = R_source + r_series``), output ``gain d lambda/dt``; the DF is its first
    harmonic over ``V`` (module docstring: method, accuracy). Parameters are those of the
    ``winding`` chain. ``current`` in :meth:`operating_point` is the *peak* current
    ``I_p`` of the steady state (the loop's amplitude) and ``inductance`` the law's
    ``N(I_p, f)``; ``R = 0`` is replaced by ``R_MIN``; ``V = 0`` gives current and DF 0.
    """

    name = "voltage"
    title = (
        "Winding in series with the source resistance, exact voltage-driven steady state (Fig 5.10)"
    )
    params = WindingChain.params
    settings: VoltageSettings = VoltageSettings()

    @classmethod
    def configured(cls, **changes) -> type[VoltageChain]:
        """A subclass with some :class:`VoltageSettings` changed (convergence studies)."""
        return type(cls.__name__, (cls,), {"settings": replace(cls.settings, **changes)})

    @classmethod
    def _prepare(cls, model, amplitude, frequency, source_impedance, model_theta, chain_theta):
        model = get_model(model)
        V, f, Rs = as_points(amplitude, frequency, source_impedance)
        if np.any(V < 0):
            raise ModelError("amplitude must be >= 0 V")
        if np.any(f <= 0):
            raise ModelError("frequency must be > 0 Hz")
        mkw = split_theta(model.params, model_theta)
        ckw = split_theta(cls.params, chain_theta)
        R = np.maximum(Rs + ckw["r_series"], R_MIN)
        shape = np.broadcast_shapes(
            V.shape, f.shape, R.shape, ckw["gain"].shape, *(np.shape(v) for v in mkw.values())
        )
        flat = {k: np.broadcast_to(v, shape).ravel().copy() for k, v in mkw.items()}
        V, f, R = (np.broadcast_to(a, shape).ravel().copy() for a in (V, f, R))
        return model, shape, V, f, R, flat, mkw, ckw

    @classmethod
    def _rate(cls, ckw, shape):
        """Flat per-point ``(c_cl, c_ex)`` of a rate-dependent current, or None (static core;
        :class:`fitdf.chains.dynamic.DynamicChain` overrides this)."""
        return None

    @classmethod
    def _solve(
        cls,
        model,
        amplitude,
        frequency,
        source_impedance,
        model_theta,
        chain_theta,
        initial_current,
    ):
        model, shape, V, f, R, flat, mkw, ckw = cls._prepare(
            model, amplitude, frequency, source_impedance, model_theta, chain_theta
        )
        initial = None
        if initial_current is not None:
            initial = np.broadcast_to(np.asarray(initial_current, float), shape).ravel()
        current, df, _, _ = _solve(
            model, V, f, R, flat, initial, cls.settings, cls._rate(ckw, shape)
        )
        gain = np.broadcast_to(ckw["gain"], shape)
        return model, current.reshape(shape), gain * df.reshape(shape), mkw, f.reshape(shape)

    @classmethod
    def predict(
        cls,
        model,
        amplitude,
        frequency,
        source_impedance,
        model_theta,
        chain_theta,
        *,
        initial_current=None,
    ):
        """Complex DF of the exact steady state; see :meth:`MeasurementChain.predict`."""
        return cls._solve(
            model, amplitude, frequency, source_impedance, model_theta, chain_theta, initial_current
        )[2]

    @classmethod
    def operating_point(
        cls,
        model,
        amplitude,
        frequency,
        source_impedance,
        model_theta,
        chain_theta,
        *,
        initial_current=None,
    ) -> OperatingPoint:
        model, current, df, mkw, f = cls._solve(
            model, amplitude, frequency, source_impedance, model_theta, chain_theta, initial_current
        )
        N = model.describing_function(current, f, **mkw)
        shape = np.broadcast_shapes(df.shape, np.shape(N))
        return OperatingPoint(*(np.broadcast_to(a, shape).copy() for a in (current, N, df)))


@dataclass(frozen=True)
class SteadyState:
    """One point's periodic steady state over a full period (:func:`steady_state_waveform`).

    ``theta`` (rad) runs from the current minimum ``phi0`` to ``phi0 + 2 pi`` (the steps
    of the integration, shorter where the state moves fast); ``current`` (A), ``flux``
    (V s), ``emf = V sin(theta) - R current`` (V) and ``output = gain emf`` at those
    phases. ``half`` is the index of ``phi0 + pi`` (the end of the rising half; where the
    peak is reached by a jump onto a saturation flat, the next sample has the same phase
    and the peak current). ``peak_current`` and ``df`` are the chain's values.
    """

    theta: np.ndarray
    current: np.ndarray
    flux: np.ndarray
    emf: np.ndarray
    output: np.ndarray
    half: int
    peak_current: float
    df: complex
    resistance: float
    amplitude: float
    frequency: float


def _jump_edge(rising, lo, hi):
    """The edge of a jump of the peak current between ``lo`` (whose rising half reaches its
    own amplitude) and ``hi`` (falls short of it), by bisection to a relative 1e-7;
    ``rising(I)`` is ``(phi0, wave, result)``, ``result[0]`` the largest current reached."""
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        if rising(mid)[2][0] >= mid:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-7 * hi:
            break
    return lo


def steady_state_waveform(
    model, amplitude, frequency, source_impedance, model_theta, chain_theta, *, chain=VoltageChain
) -> SteadyState:
    """The steady state of one point, integrated over a whole period without assuming symmetry.

    The rising half runs on the loop of amplitude ``I_p`` (the chain's solution); the
    falling half starts from where the rising half ended and follows the falling branch of
    the amplitude actually reached, shifted for flux continuity -- the loop operator of a
    time-domain simulation. Half-wave symmetry of the result is therefore a check, not an
    assumption. One function, read as the period runs: both halves use the one point's
    prepared state (nodes, parameters, rate coefficients).
    """
    st = chain.settings
    model, shape, V, f, R, flat, mkw, ckw = chain._prepare(
        model,
        np.atleast_1d(amplitude),
        np.atleast_1d(frequency),
        np.atleast_1d(source_impedance),
        model_theta,
        chain_theta,
    )
    if V.size != 1:
        raise ModelError(
            "steady_state_waveform takes one point (scalar amplitude, frequency, impedance)"
        )
    rate = chain._rate(ckw, shape)
    current, df, u, below = _solve(model, V, f, R, flat, None, st, rate)
    c_cl, c_ex = (0.0, 0.0) if rate is None else (float(c[0]) for c in rate)
    I, V0, R0, w = float(current[0]), float(V[0]), float(R[0]), 2 * np.pi * float(f[0])
    gain = float(np.ravel(ckw["gain"])[0])
    kw = {k: v[:, None] for k, v in flat.items()}
    K = 64 * st.steps + 2
    if V0 == 0:
        th = np.linspace(0.0, 2 * np.pi, 2 * st.steps + 1)
        z = np.zeros_like(th)
        return SteadyState(th, z, z, z, z, st.steps, 0.0, 0j, R0, V0, float(f[0]))

    def rising(I):
        phi0 = -np.arcsin(min(R0 * I / V0, 1.0))
        x = I * u[0]
        B = model.ascending_branch(x[None], np.array([[I]]), f[:, None], **kw)[0]
        up = np.zeros((K, 3))
        r = half_period_wave(
            x,
            kernel_array(B, x.shape),
            V0,
            R0,
            w,
            phi0,
            st.steps,
            st.refine_factor * np.pi / st.steps,
            up,
            c_cl,
            c_ex,
        )
        return phi0, up, r

    phi0, up, r = rising(I)
    if r[0] < I * (1 - 1e-3) and np.isfinite(below[0]) and below[0] > 0:
        # the root sits on the edge of a jump of the peak current (the flux reaches a
        # saturation flat exactly at the half period) and I fell just beyond it: the steady
        # state is the limit from below, where the jump happens; bisect towards the edge
        I = _jump_edge(rising, float(below[0]), I)
        phi0, up, r = rising(I)
    n1 = int(r[3])
    up = up[: n1 + 1]
    i_end, lam_end = up[-1, 1], up[-1, 2]
    # falling half, in j = -i, mu = -lam: the same equation from the turning point, the
    # largest current reached (including a jump inside the last step), on the branch of
    # that amplitude shifted so that it continues the flux
    a2 = max(abs(i_end), r[0])
    x2 = a2 * u[0]
    B2 = np.broadcast_to(
        model.ascending_branch(x2[None], np.array([[a2]]), f[:, None], **kw)[0], x2.shape
    )
    B2 = np.ascontiguousarray(B2 - B2[0] - lam_end, float)
    down = np.zeros((K, 3))
    r2 = half_period_wave(
        x2, B2, V0, R0, w, phi0, st.steps, st.refine_factor * np.pi / st.steps, down, c_cl, c_ex
    )
    n2 = int(r2[3])
    # the turning point is kept twice when the peak is a jump (same phase, both currents)
    down = down[(0 if a2 > abs(i_end) else 1) : n2 + 1]
    theta = np.concatenate([up[:, 0], down[:, 0] + np.pi])
    cur = np.concatenate([up[:, 1], -down[:, 1]])
    flux = np.concatenate([up[:, 2], -down[:, 2]])
    emf = V0 * np.sin(theta) - R0 * cur
    return SteadyState(
        theta, cur, flux, emf, gain * emf, n1, I, complex(gain * df[0]), R0, V0, float(f[0])
    )
