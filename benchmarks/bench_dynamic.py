"""The ``dynamic`` chain's cost against the ``voltage`` chain, side by side; and its accuracy.

Run from the repository root::

    python benchmarks/bench_dynamic.py             # about 2 minutes
    python benchmarks/bench_dynamic.py --quick     # under a minute
    python benchmarks/bench_dynamic.py --accuracy  # and the accuracy grid (about 4 minutes more)

Part 1 (cost) times, in one process, the same law's DF on the 63 rows of Table B.4
(Supermalloy, 600 ohm, 3-50 c/s) through ``voltage`` and through ``dynamic`` for the same
fresh parameter sets: each repeat draws a new set (the law's parameters scattered by 5 %
about a Supermalloy-like set, the coefficients by 20 % about their level) and times both
chains on it, in alternating order; one set per call (least squares) and a batch of 32 (MCMC
walkers). Laws: Preisach (the B.4 voltage fit, ``benchmarks/dynamic_supermalloy.py``) and
Rayleigh (closed form). Coefficient levels: the material "typical" values
(:data:`fitdf.data.cores.MATERIAL_LIMITS`: ``k_cl`` 1e-4 S m, ``k_ex`` 0.1) and the B.4
dynamic fit's. Medians of repeats (``time.perf_counter``) and the median of the per-set
ratios; the aim (``dynamic`` at most 3x ``voltage``) is printed, never asserted.

Part 2 (``--accuracy``) compares the chain with the time-stepping reference of
``tests/test_dynamic_chain.py`` on a grid of 24 points (0.01-16 V, 3, 10, 50 Hz, 0 and 600
ohm) at the test's coefficients, and the ``voltage`` chain with the same reference without
losses, and prints the largest ``|DF - DF_ref|`` per impedance.

Part 3 (``--before REV``, about 3 minutes more) sets the root search of the git revision
``REV`` (``benchmarks/_revision.py``) beside this checkout's, in this process: the time per
evaluation of both chains with each, on Part 1's rows and sets (medians and the median of
the per-set ratios, after over before) and on the threshold scan of
``benchmarks/dynamic_threshold.py`` (``constant_width``, V/(R b) 1-1.2, 328 points); and the
largest change of the DF between the two over every law, at its defaults and at the
parameters of ``tests/test_voltage_chain.py``, on 0.003-16 V, 3, 10, 30, 50 c/s, 0 and 600
ohm, through ``voltage`` and through ``dynamic`` with the test's coefficients and the B.4
fit's.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads BLAS

import numpy as np  # noqa: E402
from _revision import root_search, secant_update_at  # noqa: E402

from fitdf.chains import DynamicChain, VoltageChain  # noqa: E402
from fitdf.data.cores import core_geometry  # noqa: E402
from fitdf.inference.api import resolve_data  # noqa: E402
from fitdf.models import MODELS, get_model  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
import test_dynamic_chain as ref  # noqa: E402  (the reference lives with the tests)
import test_voltage_chain as vref  # noqa: E402

R_WINDING = 53.8  # Supermalloy's (Appendix A estimate)
#: Supermalloy-like laws: Preisach from the B.4 voltage fit, Rayleigh with ~20k initial
#: permeability (15 H) and the saturation flux of ~0.7 T
LAWS = {
    "preisach": [0.0471, 1.70e-4, 0.371, 2.02e-4, 5.87, 0.206],
    "rayleigh": [15.0, 3e4, 0.05],
}
_GEO = core_geometry("supermalloy")
#: (c_cl, c_ex) levels: the material "typical" values on Supermalloy's geometry, and the
#: B.4 dynamic fit's
LEVELS = {
    "typical": (
        1e-4 * _GEO.winding_scale("conductance"),
        0.1 * _GEO.winding_scale("current_per_root_voltage"),
    ),
    "B.4 fit": (2.3e-4, 4.9e-5),
}


def timed_pair(fn_a, fn_b, order):
    """Times of ``fn_a`` and ``fn_b`` run back to back (``order`` 0: a first)."""
    out = [0.0, 0.0]
    for k in (0, 1) if order == 0 else (1, 0):
        t0 = time.perf_counter()
        (fn_a, fn_b)[k]()
        out[k] = time.perf_counter() - t0
    return out


def cost(repeats):
    data = resolve_data("B.4")
    V, f, Rs = data.amplitude, data.frequency, data.source_impedance
    rng = np.random.default_rng(0)
    print(f"Part 1: {V.size} rows of Table B.4; load average {os.getloadavg()[0]:.1f}")
    print(
        f"{'law':9s} {'coefficients':12s} {'batch':>5s} {'voltage':>10s} {'dynamic':>10s} "
        f"{'ratio':>6s} {'median per-set ratio':>21s}  aim (<= 3x)"
    )
    worst = 0.0
    for name, theta in LAWS.items():
        model = get_model(name)
        th0 = np.array(theta)
        for level, (c_cl, c_ex) in LEVELS.items():
            for batch in (1, 32):
                # compile and warm (not timed)
                VoltageChain.predict(model, V, f, Rs, th0, [R_WINDING, 1.0])
                DynamicChain.predict(model, V, f, Rs, th0, [R_WINDING, 1.0, c_cl, c_ex])
                tv, td = [], []
                for k in range(repeats):
                    shape = (batch, th0.size) if batch > 1 else th0.shape
                    th = th0 * np.exp(0.05 * rng.standard_normal(shape))
                    cshape = (batch, 1) if batch > 1 else (1,)
                    cc = c_cl * np.exp(0.2 * rng.standard_normal(cshape))
                    ce = c_ex * np.exp(0.2 * rng.standard_normal(cshape))
                    rw = np.full(cshape, R_WINDING)
                    gain = np.ones(cshape)
                    cv = np.concatenate([rw, gain], axis=-1)
                    cd = np.concatenate([rw, gain, cc, ce], axis=-1)
                    a, b = timed_pair(
                        lambda th=th, cv=cv: VoltageChain.predict(model, V, f, Rs, th, cv),
                        lambda th=th, cd=cd: DynamicChain.predict(model, V, f, Rs, th, cd),
                        k % 2,
                    )
                    tv.append(a)
                    td.append(b)
                tv, td = np.array(tv), np.array(td)
                ratio = np.median(td) / np.median(tv)
                worst = max(worst, ratio)
                print(
                    f"{name:9s} {level:12s} {batch:5d} {np.median(tv) * 1e3:7.1f} ms "
                    f"{np.median(td) * 1e3:7.1f} ms {ratio:6.2f} {np.median(td / tv):21.2f}  "
                    f"{'met' if ratio <= 3 else 'NOT met'}"
                )
    print(f"largest ratio of medians: {worst:.2f}")


def accuracy():
    V, f, Rs = (
        a.ravel() for a in np.meshgrid([0.01, 0.1, 0.5, 2.0, 8.0, 16.0], [3.0, 50.0], [0.0, 600.0])
    )
    keep = ~((f == 3.0) & (V > 5.0))  # 3 c/s: 8 and 16 V are far beyond the knee
    extra = np.array([(0.3, 10.0, 0.0), (3.0, 10.0, 0.0), (0.3, 10.0, 600.0), (3.0, 10.0, 600.0)])
    V, f, Rs = (np.concatenate([a[keep], extra[:, j]]) for j, a in enumerate((V, f, Rs)))
    ct = [ref.R_WINDING, 1.0, ref.C_CL, ref.C_EX]
    op = DynamicChain.operating_point("rayleigh", V, f, Rs, ref.THETA, ct)
    st = VoltageChain.operating_point("rayleigh", V, f, Rs, ref.THETA, [ref.R_WINDING, 1.0])
    print(f"\nPart 2: {V.size} points, Rayleigh {ref.THETA}, c_cl {ref.C_CL}, c_ex {ref.C_EX}")
    print(
        f"  {'V':>5s} {'f':>4s} {'R_s':>4s} {'dynamic err':>11s} {'voltage err':>11s} {'move':>6s}"
    )
    errs = []
    for k in range(V.size):
        p = (V[k], f[k], Rs[k])
        d, _, _, _ = ref.reference_at(p, a_guess=op.current[k])
        s, _, _, _ = ref.reference_at(p, c_cl=0.0, c_ex=0.0, a_guess=st.current[k])
        errs.append((Rs[k], abs(op.df[k] - d), abs(st.df[k] - s)))
        print(
            f"  {V[k]:5.2f} {f[k]:4.0f} {Rs[k]:4.0f} {errs[-1][1]:11.1e} {errs[-1][2]:11.1e} "
            f"{abs(d - s):6.3f}",
            flush=True,
        )
    errs = np.array(errs)
    for r in (0.0, 600.0):
        sel = errs[:, 0] == r
        print(
            f"  {r:.0f} ohm: largest |DF - ref| dynamic {errs[sel, 1].max():.1e}, "
            f"voltage {errs[sel, 2].max():.1e}"
        )


def against(rev, repeats):
    """Part 3: the root search of ``rev`` beside this checkout's (module docstring)."""
    before = secant_update_at(rev)

    def timed(step, fn):
        t0 = time.perf_counter()
        if step is None:
            out = fn()
        else:
            with root_search(step):
                out = fn()
        return time.perf_counter() - t0, out

    data = resolve_data("B.4")
    V, f, Rs = data.amplitude, data.frequency, data.source_impedance
    rng = np.random.default_rng(1)
    print(f"\nPart 3: the root search of {rev} (before) beside this checkout's (after)")
    print(f"{'law':9s} {'chain':8s} {'batch':>5s} {'before':>10s} {'after':>10s} {'ratio':>6s}")
    c_cl, c_ex = LEVELS["B.4 fit"]
    for name, theta in LAWS.items():
        model = get_model(name)
        th0 = np.array(theta)
        for chain, extra in ((VoltageChain, []), (DynamicChain, [c_cl, c_ex])):
            for batch in (1, 32):
                shape = (batch, th0.size) if batch > 1 else th0.shape
                ct = np.broadcast_to([R_WINDING, 1.0, *extra], (batch, 2 + len(extra)))
                ct = ct if batch > 1 else ct[0]
                for step in (before, None):  # compile and warm (not timed)
                    timed(step, lambda: chain.predict(model, V, f, Rs, th0, ct))
                tb, ta = [], []
                for k in range(repeats):
                    th = th0 * np.exp(0.05 * rng.standard_normal(shape))
                    order = (before, None) if k % 2 == 0 else (None, before)
                    for step in order:
                        t, _ = timed(step, lambda th=th: chain.predict(model, V, f, Rs, th, ct))
                        (tb if step is before else ta).append(t)
                tb, ta = np.array(tb), np.array(ta)
                print(
                    f"{name:9s} {chain.name:8s} {batch:5d} {np.median(tb) * 1e3:7.1f} ms "
                    f"{np.median(ta) * 1e3:7.1f} ms {np.median(ta / tb):6.2f}"
                )
    x, f3, R3 = (
        a.ravel()
        for a in np.meshgrid(np.linspace(1.0, 1.2, 41), [3.0, 10.0, 30.0, 50.0], [0.0, 600.0])
    )
    theta = ref.DELTAMAX_CW
    V3 = x * (R3 + R_WINDING) * theta[1]
    ct = [R_WINDING, 1.0, 1e-4, 1e-4]
    tb, ta = [], []
    for k in range(repeats):
        order = (before, None) if k % 2 == 0 else (None, before)
        for step in order:
            t, _ = timed(
                step, lambda: DynamicChain.predict("constant_width", V3, f3, R3, theta, ct)
            )
            (tb if step is before else ta).append(t)
    print(
        f"threshold scan ({V3.size} points, constant_width): {np.median(tb) * 1e3:.1f} ms before, "
        f"{np.median(ta) * 1e3:.1f} ms after, ratio {np.median(np.array(ta) / np.array(tb)):.2f}"
    )
    V, f, Rs = (
        a.ravel()
        for a in np.meshgrid(
            np.logspace(-2.5, np.log10(16), 24), [3.0, 10.0, 30.0, 50.0], [0.0, 600.0]
        )
    )
    coefficients = ([], [ref.C_CL, ref.C_EX], list(LEVELS["B.4 fit"]))
    print(f"DF change, after - before, on {V.size} points per law, set and chain:")
    worst = 0.0
    for name in MODELS:
        model = get_model(name)
        sets = [[p.default for p in model.params]]
        if name in vref.PARAMS:
            sets.append(vref.PARAMS[name])
        big, where = 0.0, ""
        for theta in sets:
            for extra in coefficients:
                chain = DynamicChain if extra else VoltageChain
                ct = [R_WINDING, 1.0, *extra]
                _, d0 = timed(before, lambda: chain.predict(model, V, f, Rs, theta, ct))
                _, d1 = timed(None, lambda: chain.predict(model, V, f, Rs, theta, ct))
                d = np.abs(d1 - d0)
                q = int(np.argmax(d))
                if d[q] > big:
                    big = d[q]
                    where = f"{V[q]:.3g} V, {f[q]:.0f} c/s, {Rs[q]:.0f} ohm, {chain.name}"
        worst = max(worst, big)
        print(f"  {name:24s} largest {big:.1e}" + (f" ({where})" if big > 0 else ""))
    print(f"  largest over every law {worst:.1e}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    parser.add_argument("--accuracy", action="store_true", help="also the accuracy grid")
    parser.add_argument(
        "--before", metavar="REV", help="also the root search of this revision beside this one's"
    )
    ns = parser.parse_args(argv)
    cost(5 if ns.quick else 15)
    if ns.accuracy:
        accuracy()
    if ns.before:
        against(ns.before, 5 if ns.quick else 15)


if __name__ == "__main__":
    main()
