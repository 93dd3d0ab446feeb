"""The steady-loop cache of ``JilesAtherton.ascending_branch``: bit-identical, bounded, per process."""

from __future__ import annotations

import multiprocessing

import numpy as np
import pytest

from fitdf.models._ja_branch import STEADY_CACHE, SteadyCache
from fitdf.models._ja_integrate import _NMIN, _TOL, coupling
from fitdf.models.jiles_atherton import JilesAtherton

NAMES = ("lambda_s", "a", "k", "c", "zeta")


def bits(values):
    """The exact bits (NaN payloads included) of a float array, for ``array_equal``."""
    return np.ascontiguousarray(values, dtype=float).view(np.uint64)


def draws(n, seed):
    """Rows ``(A, theta)``: half realistic fitted values, half over the parameter box."""
    rng = np.random.default_rng(seed)
    fitted = np.column_stack(
        [
            10 ** rng.uniform(-2, -1, n),
            10 ** rng.uniform(-4, -2, n),
            10 ** rng.uniform(-4, -2, n),
            rng.uniform(0.05, 0.5, n),
            rng.uniform(0.1, 1.0, n),  # zeta, up to its bound
        ]
    )
    lo = np.array([p.internal_bounds[0] for p in JilesAtherton.params])
    hi = np.array([p.internal_bounds[1] for p in JilesAtherton.params])
    internal = rng.uniform(lo, hi, (n, 5))
    box = np.column_stack(
        [p.from_internal(internal[:, i]) for i, p in enumerate(JilesAtherton.params)]
    )
    theta = np.vstack([fitted, box])
    A = 10 ** rng.uniform(-5, 0, 2 * n)
    return A, theta


def branch(u, A, theta):
    """``B(u A; A)`` of the rows, ``u`` of shape ``(m, K)``, as the voltage chain calls it."""
    kw = {name: theta[:, i, None] for i, name in enumerate(NAMES)}
    return JilesAtherton.ascending_branch(A[:, None] * u, A[:, None], **kw)


def one_by_one(u, A, theta):
    """The uncached path: each row alone, solved on an empty cache."""
    rows = []
    for i in range(A.size):
        STEADY_CACHE.clear()
        rows.append(branch(u[i : i + 1], A[i : i + 1], theta[i : i + 1])[0])
    STEADY_CACHE.clear()
    return np.array(rows)


@pytest.fixture
def cache():
    """The module cache, emptied before and after, its bounds restored."""
    bounds = STEADY_CACHE.max_rows, STEADY_CACHE.max_floats
    STEADY_CACHE.clear()
    yield STEADY_CACHE
    STEADY_CACHE.max_rows, STEADY_CACHE.max_floats = bounds
    STEADY_CACHE.clear()


def test_cached_branch_is_bit_identical_for_repeated_partial_and_new_rows(cache):
    A, theta = draws(12, 3)
    rng = np.random.default_rng(4)
    m = A.size
    u1, u2, u3 = (rng.uniform(-1.0, 1.0, (m, K)) for K in (32, 64, 64))
    u2[:, 0], u3[:, -1] = -1.0, 1.0  # the tips too
    first = branch(u1, A, theta)
    assert len(cache) == m
    np.testing.assert_array_equal(bits(first), bits(one_by_one(u1, A, theta)))
    # the chain's pattern: the same rows again at new inputs, from the cache
    np.testing.assert_array_equal(bits(branch(u2, A, theta)), bits(one_by_one(u2, A, theta)))
    # partly repeated rows, shuffled, beside new ones (new amplitudes; one parameter moved)
    B, phi = draws(6, 5)
    phi[0] = theta[0] * (1 + 1e-15)
    mix = rng.permutation(np.r_[np.arange(0, m, 2), m + np.arange(B.size)])
    A_mix, th_mix = np.r_[A, B][mix], np.vstack([theta, phi])[mix]
    u_mix = rng.uniform(-1.0, 1.0, (mix.size, 64))
    warm = branch(u_mix, A_mix, th_mix)
    np.testing.assert_array_equal(bits(warm), bits(one_by_one(u_mix, A_mix, th_mix)))
    # the cache disabled gives the same bits as well
    cache.max_rows = 0
    np.testing.assert_array_equal(bits(branch(u3, A, theta)), bits(one_by_one(u3, A, theta)))
    assert len(cache) == 0


def test_cached_branch_broadcast_shapes_and_duplicate_rows(cache):
    A, theta = draws(4, 7)
    kw = {name: theta[:, i, None, None] for i, name in enumerate(NAMES)}  # walkers (W, 1, 1)
    amps = np.array([1e-4, 3e-3, 3e-3, 0.2])[:, None]  # rows repeated within the call
    x = amps * np.linspace(-1.0, 1.0, 9)
    batch = JilesAtherton.ascending_branch(x, amps, **kw)
    assert batch.shape == (A.size, 4, 9) and len(cache) == 3 * A.size
    again = JilesAtherton.ascending_branch(x[::-1], amps[::-1], **kw)[:, ::-1]
    np.testing.assert_array_equal(bits(again), bits(batch))
    for w in range(A.size):
        for j in range(4):
            cache.clear()
            row = JilesAtherton.ascending_branch(
                x[j], amps[j, 0], **{name: theta[w, i] for i, name in enumerate(NAMES)}
            )
            np.testing.assert_array_equal(bits(row), bits(batch[w, j]))
    # scalars and a negative amplitude share the cached row of |A|
    th = {name: float(theta[1, i]) for i, name in enumerate(NAMES)}
    np.testing.assert_array_equal(
        bits(JilesAtherton.ascending_branch(x[1], -3e-3, **th)), bits(batch[1, 1])
    )


def test_cached_branch_with_jumps_beyond_the_bounds(cache):
    # zeta >= 1: the realised branch has a vertical jump; cached pieces are rebuilt exactly
    th = dict(lambda_s=0.03, a=1e-3, k=3e-4, c=0.1, zeta=1.5)
    A = 3e-3
    x1, x2 = np.linspace(-A, A, 201), np.linspace(-A, A, 77) ** 3 / A**2
    cold = [JilesAtherton.ascending_branch(x, A, **th) for x in (x1, x2)]
    assert np.any(np.diff(cold[0]) > 0.2 * th["lambda_s"])  # the jump is there
    cache.clear()
    JilesAtherton.ascending_branch(x2, A, **th)
    warm = [JilesAtherton.ascending_branch(x, A, **th) for x in (x1, x2)]
    for c, w in zip(cold, warm):
        np.testing.assert_array_equal(bits(w), bits(c))


def test_cache_is_bounded_and_keyed_by_every_kernel_input(cache):
    A, theta = draws(10, 11)
    u = np.tile(np.linspace(-1.0, 1.0, 16), (A.size, 1))
    reference = branch(u, A, theta)
    kap = coupling(lambda_s=theta[:, 0], a=theta[:, 1], zeta=theta[:, 4])
    raw = np.column_stack([A, *theta[:, :4].T, kap, np.full(A.size, _TOL), np.full(A.size, _NMIN)])
    keys = [row.tobytes() for row in raw]
    assert list(cache._rows) == keys
    # a call beyond the bounds keeps its first rows (repeating it hits on them), whatever came
    # before; the results never change
    for max_rows, max_floats in ((7, 1 << 21), (8192, 4000), (0, 1 << 21)):
        cache.max_rows, cache.max_floats = max_rows, max_floats
        for _ in range(2):
            np.testing.assert_array_equal(bits(branch(u, A, theta)), bits(reference))
            kept = list(cache._rows)
            assert len(kept) <= max_rows and cache._floats <= max_floats
            assert kept == keys[: len(kept)]
            assert cache._floats == sum(row.size for row in cache._rows.values())
    assert len(kept) == 0
    cache.max_rows = 7
    branch(u, A, theta)
    assert list(cache._rows) == keys[:7]
    # older calls' rows make room for a new call's
    cache.max_rows = 12
    branch(u[:10], A[:10], theta[:10])
    branch(u[10:], A[10:], theta[10:])
    assert list(cache._rows) == keys[8:10] + keys[10:]
    # the step control is part of the key: another tol is solved, not taken from the cache
    store = SteadyCache()
    args = (A[:3], *theta[:3, :4].T, kap[:3])
    fine = store.branches(*args, _TOL, _NMIN)
    coarse = store.branches(*args, 1e-5, 8)
    assert len(store) == 6 and coarse[0].size < fine[0].size
    np.testing.assert_array_equal(bits(store.branches(*args, _TOL, _NMIN)[0]), bits(fine[0]))


def _child_branch(u, A, theta):
    """In a worker: the cache it starts with (forked: emptied) and the branch it computes."""
    start = len(STEADY_CACHE)
    return start, branch(u, A, theta)


@pytest.mark.parametrize("method", ["fork", "spawn"])
def test_cache_in_worker_processes(cache, method):
    if method not in multiprocessing.get_all_start_methods():
        pytest.skip(f"no {method} start method here")
    A, theta = draws(3, 13)
    u = np.tile(np.linspace(-1.0, 1.0, 8), (A.size, 1))
    here = branch(u, A, theta)
    assert len(cache) == A.size
    with multiprocessing.get_context(method).Pool(1) as pool:
        start, there = pool.apply(_child_branch, (u, A, theta))
    assert start == 0
    np.testing.assert_array_equal(bits(there), bits(here))
