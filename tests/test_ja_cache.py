"""What ``JilesAtherton.ascending_branch`` keeps between calls (forced responses per parameter
set, the previous call's nodes): bit-identical results, bounded, per process and thread."""

from __future__ import annotations

import multiprocessing
import threading

import numpy as np
import pytest

from fitdf.models._ja_branch import RESPONSE_CACHE, ROW_MEMO, ResponseCache
from fitdf.models._ja_integrate import _COARSE_TOL, _NMIN, _TOL
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
    """Each row alone, with nothing kept."""
    rows = []
    for i in range(A.size):
        forget()
        rows.append(branch(u[i : i + 1], A[i : i + 1], theta[i : i + 1])[0])
    forget()
    return np.array(rows)


def forget():
    RESPONSE_CACHE.clear()
    ROW_MEMO.clear()


@pytest.fixture
def kept():
    """The module cache and memo, emptied before and after, their bounds restored."""
    bounds = RESPONSE_CACHE.max_floats, ROW_MEMO.max_rows
    forget()
    yield RESPONSE_CACHE
    RESPONSE_CACHE.max_floats, ROW_MEMO.max_rows = bounds
    forget()


def test_kept_responses_and_nodes_give_the_bits_of_a_new_solve(kept):
    A, theta = draws(12, 3)
    rng = np.random.default_rng(4)
    m = A.size
    u1, u2, u3 = (rng.uniform(-1.0, 1.0, (m, K)) for K in (32, 64, 64))
    u2[:, 0], u3[:, -1] = -1.0, 1.0  # the tips too
    first = branch(u1, A, theta)
    assert len(kept) == m  # one forced response per (lambda_s, a, k)
    np.testing.assert_array_equal(bits(first), bits(one_by_one(u1, A, theta)))
    # the chain's pattern: the same rows again at new inputs (their nodes from the memo)
    np.testing.assert_array_equal(bits(branch(u2, A, theta)), bits(one_by_one(u2, A, theta)))
    # partly repeated rows, shuffled, beside new ones (new amplitudes; one parameter moved)
    B, phi = draws(6, 5)
    phi[0] = theta[0] * (1 + 1e-15)
    mix = rng.permutation(np.r_[np.arange(0, m, 2), m + np.arange(B.size)])
    A_mix, th_mix = np.r_[A, B][mix], np.vstack([theta, phi])[mix]
    u_mix = rng.uniform(-1.0, 1.0, (mix.size, 64))
    warm = branch(u_mix, A_mix, th_mix)
    np.testing.assert_array_equal(bits(warm), bits(one_by_one(u_mix, A_mix, th_mix)))
    # a subset of the last call's rows, in order (their nodes from the memo)
    subset = branch(u_mix[::3], A_mix[::3], th_mix[::3])
    np.testing.assert_array_equal(bits(subset), bits(warm[::3]))
    # both turned off give the same bits as well
    kept.max_floats, ROW_MEMO.max_rows = 0, 0
    forget()
    np.testing.assert_array_equal(bits(branch(u3, A, theta)), bits(one_by_one(u3, A, theta)))
    assert len(kept) == 0 and ROW_MEMO.calls == {}


def test_kept_branch_broadcast_shapes_and_duplicate_rows(kept):
    A, theta = draws(4, 7)
    kw = {name: theta[:, i, None, None] for i, name in enumerate(NAMES)}  # walkers (W, 1, 1)
    amps = np.array([1e-4, 3e-3, 3e-3, 0.2])[:, None]  # rows repeated within the call
    x = amps * np.linspace(-1.0, 1.0, 9)
    batch = JilesAtherton.ascending_branch(x, amps, **kw)
    assert batch.shape == (A.size, 4, 9) and len(kept) == A.size
    again = JilesAtherton.ascending_branch(x[::-1], amps[::-1], **kw)[:, ::-1]
    np.testing.assert_array_equal(bits(again), bits(batch))
    for w in range(A.size):
        for j in range(4):
            forget()
            row = JilesAtherton.ascending_branch(
                x[j], amps[j, 0], **{name: theta[w, i] for i, name in enumerate(NAMES)}
            )
            np.testing.assert_array_equal(bits(row), bits(batch[w, j]))
    # scalars and a negative amplitude share the row of |A|; x broadcast against the rows
    th = {name: float(theta[1, i]) for i, name in enumerate(NAMES)}
    np.testing.assert_array_equal(
        bits(JilesAtherton.ascending_branch(x[1], -3e-3, **th)), bits(batch[1, 1])
    )
    # rows along the last axis and inputs along the first (a sort, not blocks, per row)
    amps2 = np.array([[3e-3, 1e-4]])
    cols = JilesAtherton.ascending_branch(amps2 * np.linspace(-1.0, 1.0, 9)[:, None], amps2, **th)
    assert cols.shape == (9, 2)
    np.testing.assert_array_equal(bits(cols[:, 0]), bits(batch[1, 1]))
    np.testing.assert_array_equal(bits(cols[:, 1]), bits(batch[1, 0]))


def test_kept_branch_with_jumps_beyond_the_bounds(kept):
    # zeta >= 1: the realised branch has a vertical jump; kept nodes are rebuilt exactly
    th = dict(lambda_s=0.03, a=1e-3, k=3e-4, c=0.1, zeta=1.5)
    A = 3e-3
    x1, x2 = np.linspace(-A, A, 201), np.linspace(-A, A, 77) ** 3 / A**2
    cold = []
    for x in (x1, x2):
        forget()
        cold.append(JilesAtherton.ascending_branch(x, A, **th))
    assert np.any(np.diff(cold[0]) > 0.2 * th["lambda_s"])  # the jump is there
    forget()
    JilesAtherton.ascending_branch(x2, A, **th)
    warm = [JilesAtherton.ascending_branch(x, A, **th) for x in (x1, x2)]
    for c, w in zip(cold, warm):
        np.testing.assert_array_equal(bits(w), bits(c))


def test_cache_is_bounded_and_keyed_by_the_forced_response(kept):
    A, theta = draws(10, 11)
    u = np.tile(np.linspace(-1.0, 1.0, 16), (A.size, 1))
    reference = branch(u, A, theta)
    size = next(iter(kept._sets.values())).size
    keys = [np.array([*row[:3], _TOL]).tobytes() for row in theta]
    assert list(kept._sets) == keys
    # c and zeta do not change the forced response: the same tables, no new ones
    other = theta.copy()
    other[:, 3:] = other[::-1, 3:]
    branch(u, A, other)
    assert list(kept._sets) == keys
    # a call beyond the bound keeps its first tables (repeating it hits on them), whatever
    # came before; the results never change
    for max_floats in (7 * size, 0):
        kept.max_floats = max_floats
        for _ in range(2):
            ROW_MEMO.clear()
            np.testing.assert_array_equal(bits(branch(u, A, theta)), bits(reference))
            held = list(kept._sets)
            assert kept._floats <= max_floats and held == keys[: len(held)]
            assert kept._floats == sum(t.size for t in kept._sets.values())
    assert len(held) == 0
    # older calls' tables make room for a new call's
    kept.max_floats = 12 * size
    branch(u[:10], A[:10], theta[:10])
    branch(u[10:], A[10:], theta[10:])
    assert list(kept._sets) == keys[8:10] + keys[10:]
    # the tolerance is part of the key: the rough branch's tables are others
    store = ResponseCache()
    args = tuple(np.ascontiguousarray(v) for v in theta[:3, :3].T)
    fine = store.tables(*args, _TOL)
    coarse = store.tables(*args, _COARSE_TOL)
    assert len(store) == 6 and coarse[0].shape[1] < fine[0].shape[1]
    np.testing.assert_array_equal(bits(store.tables(*args, _TOL)[0]), bits(fine[0]))
    np.testing.assert_array_equal(fine[1], [0, 1, 2])


def test_row_memo_holds_the_last_call_per_tabulation_and_thread(kept):
    A, theta = draws(3, 17)
    u = np.tile(np.linspace(-1.0, 1.0, 8), (A.size, 1))
    exact = branch(u, A, theta)
    kw = {name: theta[:, i, None] for i, name in enumerate(NAMES)}
    rough = JilesAtherton.rough_branch(A[:, None] * u, A[:, None], **kw)
    assert set(ROW_MEMO.calls) == {(_TOL, _NMIN), (_COARSE_TOL, 8)}
    assert ROW_MEMO.calls[(_TOL, _NMIN)][0].shape == (A.size, 6)
    # another thread has its own (empty) memo and computes the same bits
    seen = {}

    def work():
        seen["start"] = dict(ROW_MEMO.calls)
        seen["branch"] = branch(u, A, theta)

    t = threading.Thread(target=work)
    t.start()
    t.join()
    assert seen["start"] == {}
    np.testing.assert_array_equal(bits(seen["branch"]), bits(exact))
    # calls beyond max_rows are not kept (the previous memo stays)
    ROW_MEMO.max_rows = 2
    branch(u, A * 1.1, theta)
    np.testing.assert_array_equal(ROW_MEMO.calls[(_TOL, _NMIN)][0][:, 0].view(float), A)
    assert np.all(np.isfinite(rough))


def _child_branch(u, A, theta):
    """In a worker: what it starts with (forked: emptied) and the branch it computes."""
    start = len(RESPONSE_CACHE), len(ROW_MEMO.calls)
    return start, branch(u, A, theta)


@pytest.mark.parametrize("method", ["fork", "spawn"])
def test_cache_in_worker_processes(kept, method):
    if method not in multiprocessing.get_all_start_methods():
        pytest.skip(f"no {method} start method here")
    A, theta = draws(3, 13)
    u = np.tile(np.linspace(-1.0, 1.0, 8), (A.size, 1))
    here = branch(u, A, theta)
    assert len(kept) == A.size and ROW_MEMO.calls
    with multiprocessing.get_context(method).Pool(1) as pool:
        start, there = pool.apply(_child_branch, (u, A, theta))
    assert start == (0, 0)
    np.testing.assert_array_equal(bits(there), bits(here))
