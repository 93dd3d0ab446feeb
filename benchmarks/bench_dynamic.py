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

from fitdf.chains import DynamicChain, VoltageChain  # noqa: E402
from fitdf.data.cores import core_geometry  # noqa: E402
from fitdf.inference.api import resolve_data  # noqa: E402
from fitdf.models import get_model  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
import test_dynamic_chain as ref  # noqa: E402  (the reference lives with the tests)

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


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    parser.add_argument("--accuracy", action="store_true", help="also the accuracy grid")
    ns = parser.parse_args(argv)
    cost(5 if ns.quick else 15)
    if ns.accuracy:
        accuracy()


if __name__ == "__main__":
    main()
