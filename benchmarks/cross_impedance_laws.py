"""Prediction across source impedance with and without the low-field Rayleigh population
(docs/method/low-field.rst, "Across source impedance").

For Deltamax and Permalloy, both directions (fitted at 0 ohm, predicting 600 ohm, and back),
each law given is fitted at one impedance and predicts the other
(:func:`fitdf.inference.cross_impedance.cross_impedance`, ``voltage`` chain, seed 0): the
training RMS, the prediction's RMS averaged over the series resistance's prior, and at each of
its three nodes (:data:`~fitdf.inference.cross_impedance.PRIOR_NODES`).

    python benchmarks/cross_impedance_laws.py                     # preisach, preisach_rayleigh
    python benchmarks/cross_impedance_laws.py --laws preisach jiles_atherton
"""

from __future__ import annotations

import argparse
import time

from fitdf.inference.cross_impedance import cross_impedance

DIRECTIONS = ((0.0, 600.0), (600.0, 0.0))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--laws", nargs="+", default=["preisach", "preisach_rayleigh"])
    parser.add_argument("--cores", nargs="+", default=["deltamax", "permalloy"])
    args = parser.parse_args(argv)
    print("core       ohm        law                 train   predict  at the prior's nodes")
    for core in args.cores:
        for train, test in DIRECTIONS:
            t0 = time.perf_counter()
            df = cross_impedance(core, models=args.laws, train_ohm=train, test_ohm=test, seed=0)
            for _, r in df.iterrows():
                nodes = " ".join(f"{x:.4f}" for x in r["predict_rms_complex_nodes"])
                print(
                    f"{core:9s}  {train:3.0f}->{test:3.0f}  {r['model']:18s}  "
                    f"{r['train_rms_complex']:.4f}  {r['predict_rms_complex']:.4f}   {nodes}"
                )
            print(f"  ({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
