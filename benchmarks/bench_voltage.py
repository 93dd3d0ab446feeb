"""The ``voltage`` chain: speed against ``winding`` and the time-domain simulation, and accuracy.

Run from the repository root::

    python benchmarks/bench_voltage.py            # about 3 minutes
    python benchmarks/bench_voltage.py --quick    # under a minute

Part 1 (speed) times, on the 73 rows of Tables B.1 + B.3 (Permalloy at 0 and 600 ohm,
3-20 Hz, 0.01-5.25 V), for every law with Permalloy-like parameters: the ``voltage`` chain
for one parameter set and for a batch of 32 walkers (parameters scattered by 5 %, as
emcee's vectorised log-probability evaluates them), on one numba thread and on two; the
``winding`` chain on the same calls; and ``fitdf.loop.simulate.simulated_describing_function``
(a :class:`~fitdf.loop.elements.CoreElement` per source impedance, 1000 steps per period,
8 periods) for the one parameter set. Medians of repeats (``time.perf_counter``); aims
(5 ms, 50 ms) are printed, never asserted. The load average is printed: the two cores are
shared, and wall times scale with the load.

Part 2 (accuracy) compares the chain with independent references (the ones of
``tests/test_voltage_chain.py``: exact piecewise integration for the piecewise-linear laws,
``solve_ivp`` for Rayleigh) on a grid of 40 points per law (V 0.01-5 V, 3-20 Hz, 0 and
600 ohm), and reports the maximum ``|DF - DF_ref|`` per law and impedance, then the same
for a convergence study over the method's knobs. The simulation is compared too.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads BLAS

import numba  # noqa: E402
import numpy as np  # noqa: E402

from fitdf.chains import VoltageChain, WindingChain  # noqa: E402
from fitdf.inference.api import resolve_data  # noqa: E402
from fitdf.loop.elements import CoreElement  # noqa: E402
from fitdf.loop.simulate import simulated_describing_function  # noqa: E402
from fitdf.models import get_model  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
import test_voltage_chain as ref  # noqa: E402  (the references live with the tests)

R_WINDING = 54.0
#: Permalloy-like parameter sets (as in the tests), plus the fitted Rayleigh posterior (an
#: almost rectangular loop).
SETS = {
    "constant_width": ("constant_width", ref.PARAMS["constant_width"]),
    "proportional_width": ("proportional_width", ref.PARAMS["proportional_width"]),
    "proportional_width_fig42": (
        "proportional_width_fig42",
        ref.PARAMS["proportional_width_fig42"],
    ),
    "cubic_hc": ("cubic_hc", ref.PARAMS["cubic_hc"]),
    "rayleigh": ("rayleigh", ref.PARAMS["rayleigh"]),
    "frequency_hc": ("frequency_hc", ref.PARAMS["frequency_hc"]),
    "rayleigh (fitted)": ("rayleigh", [1.1, 4.8e6, 0.0376]),
}


def timed_repeats(doc, argv=None, full=3):
    """The repeats a benchmark's ``main`` times (1 with ``--quick``, else ``full``), after
    parsing its command line (description: ``doc``'s first line) and printing the load."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one timed repeat")
    ns = parser.parse_args(argv)
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    return 1 if ns.quick else full


def median_time(fn, repeats):
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def speed(quick):
    data = resolve_data("permalloy")
    V, f, Rs = data.amplitude, data.frequency, data.source_impedance
    rng = np.random.default_rng(0)
    one = VoltageChain.configured(threads=1)
    two = VoltageChain.configured(threads=2)
    rep1, rep32 = (5, 3) if quick else (15, 7)
    print(
        f"Part 1: {V.size} points of Tables B.1 + B.3; numba {numba.__version__}, "
        f"threading layer {numba.config.THREADING_LAYER}, {numba.config.NUMBA_NUM_THREADS} threads available"
    )
    print(
        f"{'law':26s} {'voltage 1 set':>14s} {'winding':>8s} {'ratio':>6s} {'32 sets 1 thr':>14s} "
        f"{'2 thr':>8s} {'winding':>8s} {'ratio':>6s} {'simulation':>11s} {'sim/volt':>9s}  aims (5 ms, 50 ms)"
    )
    rows = []
    for key, (name, theta) in SETS.items():
        model = get_model(name)
        th = np.array(theta)
        ct = np.array([R_WINDING, 1.0])
        thb = th * np.exp(0.05 * rng.standard_normal((32, th.size)))
        ctb = ct * np.exp(0.05 * rng.standard_normal((32, 2)))
        t_v1 = median_time(lambda: one.predict(model, V, f, Rs, th, ct), rep1)
        t_w1 = median_time(lambda: WindingChain.predict(model, V, f, Rs, th, ct), rep1)
        t_v32 = median_time(lambda: one.predict(model, V, f, Rs, thb, ctb), rep32)
        t_v32b = median_time(lambda: two.predict(model, V, f, Rs, thb, ctb), rep32)
        t_w32 = median_time(lambda: WindingChain.predict(model, V, f, Rs, thb, ctb), rep32)
        kw = dict(zip(model.param_names(), th))
        sim_df = np.empty(V.size, complex)

        def simulate(**kw_sim):
            for rs in np.unique(Rs):
                sel = Rs == rs
                el = CoreElement(
                    model,
                    kw,
                    "winding",
                    resistance=rs + R_WINDING,
                    gain=1.0,
                    source_impedance=rs,
                    chain_theta={"r_series": R_WINDING, "gain": 1.0},
                )
                sim_df[sel] = simulated_describing_function(el, V[sel], f[sel], **kw_sim)

        t0 = time.perf_counter()
        simulate()
        t_sim = time.perf_counter() - t0
        if not quick:  # settled: a high-Q point's transient decays by ~0.6 per half period
            simulate(cycles=28, settle_cycles=24)
        df_v = one.predict(model, V, f, Rs, th, ct)
        ok = (
            ("met" if t_v1 <= 5e-3 else "NOT met")
            + ", "
            + ("met" if min(t_v32, t_v32b) <= 50e-3 else "NOT met")
        )
        print(
            f"{key:26s} {t_v1 * 1e3:11.2f} ms {t_w1 * 1e3:5.2f} ms {t_v1 / t_w1:6.1f} {t_v32 * 1e3:11.1f} ms "
            f"{t_v32b * 1e3:5.1f} ms {t_w32 * 1e3:5.1f} ms {t_v32 / t_w32:6.1f} {t_sim:9.2f} s {t_sim / t_v1:9.0f}  {ok}"
        )
        diff = np.abs(df_v - sim_df)
        rows.append((key, diff[Rs == 0].max(), diff[Rs == 600].max()))
    cycles = "8 periods, 4 to settle" if quick else "28 periods, 24 to settle"
    print(
        f"\nvoltage chain vs simulated_describing_function (1000 steps/period, {cycles}): max |diff|"
    )
    print(f"  {'law':26s} {'0 ohm':>8s} {'600 ohm':>8s}")
    for key, d0, d6 in rows:
        print(f"  {key:26s} {d0:8.1e} {d6:8.1e}")


def grid(quick):
    V = np.array([0.01, 0.05, 0.1, 0.3, 0.5, 1.0, 2.0, 5.0])
    f = np.array([3.0, 20.0])
    if quick:
        V = np.array([0.01, 0.3, 1.0, 5.0])
    VV, FF, RR = (a.ravel() for a in np.meshgrid(V, f, [0.0, 600.0], indexing="ij"))
    if not quick:  # and the middle frequencies
        extra = [
            (0.2, 6.0, 0.0),
            (0.7, 6.0, 600.0),
            (1.5, 6.0, 0.0),
            (3.0, 6.0, 600.0),
            (0.2, 10.0, 0.0),
            (0.7, 10.0, 600.0),
            (1.5, 10.0, 0.0),
            (3.0, 10.0, 600.0),
        ]
        VV = np.concatenate([VV, [e[0] for e in extra]])
        FF = np.concatenate([FF, [e[1] for e in extra]])
        RR = np.concatenate([RR, [e[2] for e in extra]])
    return VV, FF, RR


def references(quick):
    V, f, Rs = grid(quick)
    out = {}
    for key, (name, theta) in SETS.items():
        model = get_model(name)
        if name == "rayleigh":
            I0 = VoltageChain.configured(steps=512, nodes=96, tol=1e-4, df_tol=1e-5).core_current(
                model, V, f, Rs, theta, [R_WINDING, 1.0]
            )
            deep = I0 * (Rs + R_WINDING) / V > 0.8  # deep saturation: Radau (slow), not LSODA
            vals = [
                np.nan
                if quick and deep[k]
                else ref.reference_rayleigh(
                    theta,
                    V[k],
                    f[k],
                    Rs[k] + R_WINDING,
                    I0[k],
                    method="Radau" if deep[k] else "LSODA",
                )[0]
                for k in range(V.size)
            ]
        else:
            vals = [
                ref.reference_piecewise(model, theta, V[k], f[k], Rs[k] + R_WINDING)[0]
                for k in range(V.size)
            ]
        out[key] = np.array(vals)
    return (V, f, Rs), out


def errors(chain, points, refs):
    V, f, Rs = points
    res = {}
    for key, (name, theta) in SETS.items():
        df = chain.predict(get_model(name), V, f, Rs, theta, [R_WINDING, 1.0])
        e = np.abs(df - refs[key])
        res[key] = (np.nanmax(e[Rs == 0]), np.nanmax(e[Rs == 600]))
    return res


def accuracy(quick):
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        points, refs = references(quick)
    print(
        f"\nPart 2: accuracy against the references ({points[0].size} points per law"
        + (", Rayleigh deep in saturation skipped (--quick)" if quick else "")
        + f", references computed in {time.perf_counter() - t0:.0f} s)"
    )
    st = VoltageChain.settings
    print(
        f"defaults: steps {st.steps}, nodes {st.nodes} (refined to {2 * st.nodes - 1}), coarse {st.coarse_steps} "
        f"steps / {st.coarse_nodes} nodes, placement {st.placement_nodes}, refine_factor {st.refine_factor}, "
        f"tol {st.tol}, df_tol {st.df_tol}, coarse_tol {st.coarse_tol}"
    )
    err = errors(VoltageChain, points, refs)
    print(f"{'law':26s} {'max |err| 0 ohm':>16s} {'600 ohm':>10s}")
    for key, (e0, e6) in err.items():
        print(f"{key:26s} {e0:16.1e} {e6:10.1e}")
    print(f"{'all':26s} {max(e for v in err.values() for e in v):16.1e}")
    studies = [
        dict(steps=64),
        dict(steps=96),
        dict(steps=128),
        dict(steps=256),
        dict(steps=384),
        dict(nodes=32),
        dict(nodes=48),
        dict(nodes=96),
        dict(coarse_steps=16, coarse_nodes=16),
        dict(coarse_steps=64, coarse_nodes=32),
        dict(tol=1e-2, df_tol=1e-3),
        dict(tol=5e-4, df_tol=5e-5),
        dict(refine_factor=1e9),
        dict(placement_nodes=16),
    ]
    if quick:
        studies = [dict(steps=96), dict(steps=256), dict(nodes=32), dict(tol=5e-4, df_tol=5e-5)]
    print(
        "\nconvergence study: one knob changed from the defaults; max |err| over all laws, "
        "time per 73-point parameter set (constant_width, proportional_width_fig42, rayleigh)"
    )
    data = resolve_data("permalloy")
    D = (data.amplitude, data.frequency, data.source_impedance)
    for change in [dict()] + studies:
        ch = VoltageChain.configured(**change)
        e = errors(ch, points, refs)
        worst = max(e.values(), key=max)
        key = max(e, key=lambda k: max(e[k]))
        times = [
            median_time(lambda: ch.predict(get_model(n), *D, SETS[n][1], [R_WINDING, 1.0]), 3)
            for n in ("constant_width", "proportional_width_fig42", "rayleigh")
        ]
        label = ", ".join(f"{k}={v}" for k, v in change.items()) or "defaults"
        print(
            f"  {label:45s} max |err| {max(worst):.1e} ({key})   "
            + " ".join(f"{t * 1e3:5.1f}" for t in times)
            + " ms"
        )


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="fewer points, repeats and knobs")
    args = p.parse_args()
    t0 = time.perf_counter()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"numpy {np.__version__}, load average {load:.1f} on {os.cpu_count()} CPUs\n")
    speed(args.quick)
    accuracy(args.quick)
    print(f"\ntotal {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
