"""Speed and accuracy of describing-function evaluation, and of the winding chain.

Run from the repository root::

    python benchmarks/bench_models.py

Part 1 compares, for 1000 amplitudes, three ways to get the DF of a backlash and of a
saturation: python-control's numerical ``control.describing_function`` (its default
100 samples per period, one Python call per sample), fitdf's numerical engine
(:func:`fitdf.numerical_df.numerical_describing_function` on the ascending branch, at the
smallest power-of-two ``n_points`` that is at least as accurate), and fitdf's closed
forms (:class:`~fitdf.models.constant_width.ConstantWidth` with ``c = inf`` for the
backlash, ``b = 0`` for the saturation). Errors are against the exact DF.

python-control's ``friction_backlash_nonlinearity(b)`` has dead band ``b`` in all, i.e.
half-width ``b/2`` (``ConstantWidth.b = b/2``, ``k = 1``); its sign convention is
fitdf's (``N = (a1 + j b1)/A``, a lag has ``Im N < 0``); both are checked below.

Part 2 times the winding chain (self-consistent current, section V.5) on a 300-point
dataset, for one parameter set and for a batch of 64 walkers, for every model.

Timings are medians of repeats (``time.perf_counter``); aims are printed, never asserted.
BLAS is pinned to one thread unless ``OPENBLAS_NUM_THREADS`` is already set: the
engine's matrix-vector products are too small to gain from threads, and on a busy
machine idle-spinning BLAS threads make it up to 15x slower (python-control is
single-threaded anyway).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads BLAS

import time  # noqa: E402
import warnings  # noqa: E402

import control  # noqa: E402
import numpy as np  # noqa: E402

from fitdf.chains import WindingChain  # noqa: E402
from fitdf.models import get_model, model_names  # noqa: E402
from fitdf.models.constant_width import ConstantWidth  # noqa: E402
from fitdf.numerical_df import numerical_describing_function  # noqa: E402

N_AMPLITUDES = 1000
BACKLASH_WIDTH = 1.0  # python-control's b: total dead band
SATURATION = 1.0


def median_time(fn, repeats=5, min_time=0.2):
    """Median wall time of ``fn()`` over ``repeats`` runs (each run repeated to last >= min_time/repeats)."""
    t0 = time.perf_counter()
    fn()
    once = time.perf_counter() - t0
    inner = max(1, int(min_time / repeats / max(once, 1e-9)))
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(inner):
            fn()
        times.append((time.perf_counter() - t0) / inner)
    return float(np.median(times))


def errors(N, exact):
    """Largest and median ``|N - N_exact|``."""
    e = np.abs(N - exact)
    return np.array([e.max(), np.median(e)])


def backlash_branch(x, amplitude, frequency, *, half_width):
    # rising branch of the play: output held at the bottom -(A - b) until x - b catches up
    return np.maximum(x - half_width, -np.maximum(amplitude - half_width, 0.0))


def saturation_branch(x, amplitude, frequency, *, level):
    return np.clip(x, -level, level)


def part1():
    A_back = np.linspace(0.3, 10.0, N_AMPLITUDES)  # includes the dead band A <= b/2
    A_sat = np.linspace(0.1, 10.0, N_AMPLITUDES)
    cases = [
        (
            "backlash",
            A_back,
            lambda: control.friction_backlash_nonlinearity(BACKLASH_WIDTH),
            lambda A: ConstantWidth.describing_function(A, k=1.0, b=BACKLASH_WIDTH / 2, c=np.inf),
            lambda A, n: numerical_describing_function(
                backlash_branch, A, n_points=n, half_width=BACKLASH_WIDTH / 2
            ),
        ),
        (
            "saturation",
            A_sat,
            lambda: control.saturation_nonlinearity(SATURATION),
            lambda A: ConstantWidth.describing_function(A, k=1.0, b=0.0, c=SATURATION),
            lambda A, n: numerical_describing_function(
                saturation_branch, A, n_points=n, level=SATURATION
            ),
        ),
    ]
    rows, ratios = [], []
    for name, A, make_pc, closed, engine in cases:
        exact = closed(A)
        pc_obj = make_pc()
        analytic = np.array([pc_obj.describing_function(a) for a in A], dtype=complex)
        convention = np.max(np.abs(analytic - exact))  # python-control's own closed form vs ours
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            pc_num = control.describing_function(make_pc(), A, try_method=False)
        err_pc = errors(pc_num, exact)
        t_pc = median_time(
            lambda: control.describing_function(make_pc(), A, try_method=False), repeats=3
        )
        n = 16  # smallest power of two at least as accurate, in the worst case and typically
        while np.any(errors(engine(A, n), exact) > err_pc) and n < 2**16:
            n *= 2
        err_engine = errors(engine(A, n), exact)
        t_engine = median_time(lambda: engine(A, n))
        t_closed = median_time(lambda: closed(A))
        rows += [
            (name, "python-control numerical (100 pts)", t_pc, err_pc),
            (name, f"fitdf numerical engine ({n} pts)", t_engine, err_engine),
            (name, "fitdf closed form", t_closed, (0.0, 0.0)),
        ]
        ratios.append(
            (name, t_pc / t_engine, t_pc / t_closed, convention, np.all(err_engine <= err_pc))
        )
    print(
        f"Part 1: describing function of {N_AMPLITUDES} amplitudes (errors |N - N_exact|, slope 1)"
    )
    print(
        f"{'nonlinearity':12s} {'method':38s} {'time':>11s} {'per amplitude':>14s} {'max error':>10s} "
        f"{'median':>8s}"
    )
    for name, method, t, err in rows:
        print(
            f"{name:12s} {method:38s} {t * 1e3:8.3f} ms {t / N_AMPLITUDES * 1e6:11.3f} us {err[0]:10.1e} "
            f"{err[1]:8.1e}"
        )
    print()
    for name, r_engine, r_closed, convention, accurate in ratios:
        print(
            f"{name:12s} speed-up over python-control: engine {r_engine:7.0f}x "
            f"(aim >= 50x at equal or better accuracy: {'met' if r_engine >= 50 and accurate else 'NOT met'}), "
            f"closed form {r_closed:7.0f}x (aim >= 1000x: {'met' if r_closed >= 1000 else 'NOT met'})"
        )
        print(
            f"{'':12s} python-control's analytic DF vs fitdf closed form: max |diff| = {convention:.1e} "
            f"(same sign convention, b_control = 2 b_fitdf)"
        )


def dataset():
    V = np.tile(np.logspace(np.log10(0.01), np.log10(16.0), 25), 12)
    f = np.repeat(np.tile([3.0, 6.0, 10.0, 20.0, 30.0, 50.0], 2), 25)
    R = np.repeat([0.0, 600.0], 150)
    return V, f, R


def walkers(model, rng, size):
    """Walkers scattered around the defaults, as in an MCMC run near a fit (inside the bounds)."""
    out = []
    for p in model.params:
        lo, hi = p.internal_bounds
        centre = float(p.to_internal(p.default))
        out.append(
            p.from_internal(np.clip(centre + 0.02 * (hi - lo) * rng.standard_normal(size), lo, hi))
        )
    return np.column_stack(out)


def part2():
    V, f, R = dataset()
    ct = np.array([p.default for p in WindingChain.params])
    rng = np.random.default_rng(0)
    print(
        f"Part 2: winding chain, {V.size}-point dataset (V 0.01-16 V, f 3-50 Hz, R_source 0 and 600 ohm)"
    )
    print("('warm': started from the currents at parameters 1e-6 away, as in a Jacobian column)")
    print(
        f"{'model':26s} {'1 set':>10s} {'per point':>11s} {'1 set warm':>11s} {'64 walkers':>11s} "
        f"{'per point':>10s}  aim (1 set < 1 ms)"
    )
    for name in model_names():
        model = get_model(name)
        theta = np.array([p.default for p in model.params])
        batch = walkers(model, rng, 64)
        near = WindingChain.core_current(model, V, f, R, theta * (1 + 1e-6), ct)
        t1 = median_time(lambda: WindingChain.predict(model, V, f, R, theta, ct), repeats=5)
        tw = median_time(
            lambda: WindingChain.predict(model, V, f, R, theta, ct, initial_current=near), repeats=5
        )
        t64 = median_time(
            lambda: WindingChain.predict(model, V, f, R, batch, ct), repeats=3, min_time=0.0
        )
        print(
            f"{name:26s} {t1 * 1e3:7.2f} ms {t1 / V.size * 1e6:8.2f} us {tw * 1e3:8.2f} ms {t64 * 1e3:8.1f} ms "
            f"{t64 / (64 * V.size) * 1e6:7.2f} us  {'met' if min(t1, tw) < 1e-3 else 'NOT met'}"
        )


def main():
    t0 = time.perf_counter()
    print(
        f"numpy {np.__version__}, python-control {control.__version__}, "
        f"OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}, load average {os.getloadavg()[0]:.1f} "
        f"on {os.cpu_count()} CPUs\n"
    )
    part1()
    print()
    part2()
    print(f"\ntotal {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
