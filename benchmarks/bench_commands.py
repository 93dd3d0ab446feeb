"""Wall time of the commands a user runs, against the aims of issue #12 and the figures before it.

    python benchmarks/bench_commands.py                 # fit + quick report (~10 min on 2 cores)
    python benchmarks/bench_commands.py --only fit      # one of: fit, fit-b3, quick, full, tests
    python benchmarks/bench_commands.py --only full     # the full report (tens of minutes)

Each command runs in a subprocess from the repository root (``python -m fitdf ...``, into
a temporary folder); the load average before and after is printed because the wall time
scales with it. Nothing is asserted: the table says whether each aim was met.
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

#: name -> (command, aim in s, the figure measured before the work of issue #12)
COMMANDS = {
    "fit": (["fit", "permalloy", "--method", "lsq", "--quiet", "--no-cache"], 30.0, "166 s"),
    "fit-b3": (["fit", "B.3", "--method", "lsq", "--no-cv", "--quiet", "--no-cache"], None, "35 s"),
    "quick": (["report", "--quick", "--quiet", "--no-cache", "--out", "{tmp}/quick"], 90.0, "n/a"),
    "full": (
        ["report", "--quiet", "--no-cache", "--out", "{tmp}/full"],
        600.0,
        "519 s (winding chain, 6 laws)",
    ),
    "tests": (None, 240.0, "12 min"),
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
    print(f"{'command':8s} {'wall':>9s} {'exit':>5s} {'aim':>8s}  {'met':8s} before")
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
