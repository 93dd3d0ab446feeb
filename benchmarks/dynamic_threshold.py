"""The ``dynamic`` chain just above the loop's threshold, against a whole-period reference.

Run from the repository root::

    python benchmarks/dynamic_threshold.py                  # about 5 minutes
    python benchmarks/dynamic_threshold.py --quick          # steps of 0.01: under 3 minutes
    python benchmarks/dynamic_threshold.py --before d4d6ad0 # and the root search of d4d6ad0

``constant_width`` has a threshold: below ``V/R = b`` (the half-width) the loop never opens
and the DF is 0. Just above it the loop opens a little, the DF is small and changes fast
with the amplitude, and the root search's trial amplitudes fall on both sides of the
loop's closing. The scan: V/(R b) from 1 to 1.2 in steps of 0.005, 3, 10, 30 and 50 c/s,
0 and 600 ohm, three laws (Deltamax-like, 100 H and 0.25 mA; Supermalloy-like, 50 H and
0.05 mA; Permalloy-like, 20 H and 0.03 mA) and five coefficient sets (none, classical,
excess small and large, both), against :class:`PlayReference` of
``tests/test_dynamic_chain.py`` (the loop as a play, whole periods time-stepped by
``solve_ivp``, the periodic state the whole-period map's fixed point). Per law and
coefficient set: the largest ``|DF - DF_ref|``, where, the chain's DF over the reference's
there, and how many points are beyond 2e-4 or beyond a quarter of the reference's DF plus
2e-5. With ``--before REV`` the same for the root search of that revision
(``benchmarks/_revision.py``), in the same process.
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

from fitdf.chains import DynamicChain  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
import test_dynamic_chain as ref  # noqa: E402  (the reference lives with the tests)

LAWS = {
    "Deltamax-like": ref.DELTAMAX_CW,
    "Supermalloy-like": [50.0, 5e-5, 0.035],
    "Permalloy-like": ref.PERMALLOY_CW,
}


def scan(step):
    x, f, Rs = (
        a.ravel()
        for a in np.meshgrid(
            np.round(np.arange(1.0, 1.2 + step / 2, step), 6),
            [3.0, 10.0, 30.0, 50.0],
            [0.0, 600.0],
            indexing="ij",
        )
    )
    return x, f, Rs


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="steps of 0.01 in V/(R b)")
    parser.add_argument("--before", metavar="REV", help="also the root search of this revision")
    ns = parser.parse_args(argv)
    x, f, Rs = scan(0.01 if ns.quick else 0.005)
    searches = {"this checkout": None}
    if ns.before:
        searches[ns.before] = secant_update_at(ns.before)
    print(f"{x.size} points per law and coefficient set; load {os.getloadavg()[0]:.1f}")
    totals = {name: [0, 0.0] for name in searches}
    for law, theta in LAWS.items():
        V = x * (Rs + ref.R_WINDING) * theta[1]
        for c_cl, c_ex in ref.THRESHOLD_COEFFICIENTS:
            t0 = time.perf_counter()
            refs = [ref.play_reference(theta, *p, c_cl, c_ex) for p in zip(V, f, Rs)]
            df_ref = np.array([r[0] for r in refs])
            asym = max(abs(r[2]) for r in refs)
            t_ref = time.perf_counter() - t0
            for name, step in searches.items():
                ct = [ref.R_WINDING, 1.0, c_cl, c_ex]
                if step is None:
                    df = DynamicChain.predict("constant_width", V, f, Rs, theta, ct)
                else:
                    with root_search(step):
                        df = DynamicChain.predict("constant_width", V, f, Rs, theta, ct)
                err = np.abs(df - df_ref)
                bad = (err > 2e-4) | (err > 0.25 * np.abs(df_ref) + 2e-5)
                q = np.argmax(err)
                ratio = abs(df[q]) / abs(df_ref[q]) if df_ref[q] != 0 else np.nan
                totals[name][0] += int(bad.sum())
                totals[name][1] = max(totals[name][1], err.max())
                print(
                    f"{law:16s} c_cl {c_cl:.0e} c_ex {c_ex:.0e} [{name}]: largest {err[q]:.1e} "
                    f"at V/(R b) {x[q]:.3f}, {f[q]:.0f} c/s, {Rs[q]:.0f} ohm (DF {abs(df[q]):.2e}, "
                    f"{ratio:.2f} x the reference's); beyond the tolerance {bad.sum()} "
                    f"(> 2e-4: {(err > 2e-4).sum()})",
                    flush=True,
                )
            print(f"  reference {t_ref:.0f} s, its largest asymmetry {asym:.1e}")
    for name, (bad, worst) in totals.items():
        print(f"[{name}] largest |DF - DF_ref| {worst:.1e}; points beyond the tolerance {bad}")


if __name__ == "__main__":
    main()
