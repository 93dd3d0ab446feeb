"""Wall time of the commands a user runs, against their time aims.

    python benchmarks/bench_commands.py                 # fit, fit-b3, quick (~11 min, 2 EPYC cores)
    python benchmarks/bench_commands.py --only fit      # any of: fit, fit-b3, quick, full, tests
    python benchmarks/bench_commands.py --only full     # the full report (~2 h on 2 EPYC cores)

Each command runs in a subprocess from the repository root (``python -m fitdf ... --no-cache``
into a temporary folder, so nothing is read from kept jobs; ``tests`` is ``python -m pytest
-q``, the default suite); the load average before and after is printed because the wall time
scales with it. One row per command: wall time, exit code, the aim (``fit`` 30 s, ``quick``
90 s, ``full`` 600 s, ``tests`` 240 s), whether it was met, and the figure last measured on the
CI machine, kept in ``COMMANDS`` (not measured by this run). Nothing is asserted.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: name -> (command, aim in s, the figure last measured on the CI machine: 2 AMD EPYC cores)
COMMANDS = {
    "fit": (["fit", "permalloy", "--method", "lsq", "--quiet", "--no-cache"], 30.0, "108.8 s"),
    "fit-b3": (
        ["fit", "B.3", "--method", "lsq", "--no-cv", "--quiet", "--no-cache"],
        None,
        "43.8 s",
    ),
    "quick": (
        ["report", "--quick", "--quiet", "--no-cache", "--out", "{tmp}/quick"],
        90.0,
        "502.0 s",
    ),
    "full": (
        ["report", "--quiet", "--no-cache", "--out", "{tmp}/full"],
        600.0,
        "7028 s",
    ),
    "tests": (None, 240.0, "4 min 15 s"),
}
DEFAULT = ("fit", "fit-b3", "quick")


def run(name: str, tmp: str) -> tuple[float, int]:
    args, _, _ = COMMANDS[name]
    if args is None:
        cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"]
    else:
        cmd = [sys.executable, "-m", "fitdf", *(a.format(tmp=tmp) for a in args)]
    start = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    return time.perf_counter() - start, proc.returncode


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=sorted(COMMANDS), default=list(DEFAULT))
    ns = parser.parse_args(argv)
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    print(
        f"{'command':8s} {'wall':>9s} {'exit':>5s} {'aim':>8s}  {'met':8s} last on the CI machine"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for name in ns.only:
            wall, code = run(name, tmp)
            _, aim, before = COMMANDS[name]
            met = "-" if aim is None else ("met" if wall <= aim and code == 0 else "NOT met")
            aim_text = "-" if aim is None else f"{aim:.0f} s"
            print(f"{name:8s} {wall:8.1f}s {code:5d} {aim_text:>8s}  {met:8s} {before}", flush=True)
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    sys.exit(main())
