"""Where the critical gains of Tables 5.1/5.2 are decided (docs/user-guide/limit-cycles.rst).

Per block: the die-out bracket; the critical gain the Appendix B rows imply with no law
fitted, at each measured frequency (:mod:`fitdf.limit_cycle_tables.data_bound`); and, for
each law given, the unscaled predicted critical gain and its critical point's frequency
(:func:`fitdf.limit_cycle_tables.thesis_limit_cycle_comparison`, least squares through the
``voltage`` chain, seed 0).

    python benchmarks/critical_gains.py                                # preisach, preisach_rayleigh
    python benchmarks/critical_gains.py --laws preisach jiles_atherton
"""

from __future__ import annotations

import argparse
import math
import time

from fitdf.limit_cycle_tables import thesis_limit_cycle_comparison


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--laws", nargs="+", default=["preisach", "preisach_rayleigh"])
    args = parser.parse_args(argv)
    predicted, attrs = {}, None
    for law in args.laws:
        t0 = time.perf_counter()
        df = thesis_limit_cycle_comparison(seed=0, models=law)
        attrs = df.attrs
        for c in attrs["critical_gains"]:
            u = c["predicted"]["unscaled"]
            predicted[(law, c["table"])] = (u["critical_gain"], u["critical_omega_rad_s"])
        print(f"{law}: {time.perf_counter() - t0:.0f} s")
    print("\nblock  died out  oscillated  rows' gain by frequency (c/s: gain)")
    for c in attrs["critical_gains"]:
        implied = attrs["data_implied"][c["table"]]
        by_f = ", ".join(
            f"{r['frequency_hz']:g}: {r['critical_gain']:.1f}" for r in implied["by_frequency"]
        )
        print(
            f"{c['table']:5s}  {c['measured_dies_out_at']:8.0f}  "
            f"{c['measured_lowest_oscillating']:10.0f}  {by_f}  "
            f"(die-out / lowest frequency's: {c['measured_dies_out_at'] / implied['critical_gain']:.1f})"
        )
    print("\nlaw                 block  critical gain  die-out / it  critical point rad/s (c/s)")
    for (law, table), (gain, omega) in predicted.items():
        dead = next(
            c["measured_dies_out_at"] for c in attrs["critical_gains"] if c["table"] == table
        )
        print(
            f"{law:18s}  {table:5s}  {gain:13.1f}  {dead / gain:12.2f}  "
            f"{omega:.2f} ({omega / (2 * math.pi):.2f})"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
