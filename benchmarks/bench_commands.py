"""Wall time of the commands a user runs, against their time aims.

    python benchmarks/bench_commands.py                 # fit, fit-b3, quick, posterior
    python benchmarks/bench_commands.py --only report   # any of the names in COMMANDS
    python benchmarks/bench_commands.py --only full     # the full report

Each command runs in a subprocess from the repository root (``python -m fitdf ... --no-cache``
into a temporary folder, so nothing is read from kept jobs; ``tests`` is ``python -m pytest
-q``, the default suite); the load average before and after is printed because the wall time
scales with it. One row per command: wall time, exit code, the aim on 2 cores, whether it was
met, and the figure last measured on the CI machine before the aims (2 AMD EPYC cores; "-"
for a command that did not exist), kept in ``COMMANDS`` (not measured by this run). Nothing is
asserted.
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

#: name -> (command, aim in s on 2 cores, the figure last measured on the CI machine)
COMMANDS = {
    "fit": (["fit", "permalloy", "--method", "lsq", "--quiet", "--no-cache"], 50.0, "108.8 s"),
    "fit-b3": (
        ["fit", "B.3", "--method", "lsq", "--no-cv", "--quiet", "--no-cache"],
        None,
        "43.8 s",
    ),
    # a converged posterior (and its evidence) of the hardest law on a 600 ohm table
    "posterior": (
        ["fit", "B.3", "--models", "preisach", "--method", "nested", "--no-cv", "--quiet"]
        + ["--no-cache"],
        300.0,
        "-",
    ),
    "quick": (
        ["report", "--quick", "--quiet", "--no-cache", "--out", "{tmp}/quick"],
        240.0,
        "502.0 s",
    ),
    "report": (
        ["report", "--quiet", "--no-cache", "--out", "{tmp}/report"],
        900.0,
        "7028 s (the report of every top-3 posterior by emcee)",
    ),
    "full": (
        ["report", "--full", "--quiet", "--no-cache", "--out", "{tmp}/full"],
        3600.0,
        "7028 s (emcee: 12 of 21 posteriors converged)",
    ),
    "tests": (None, 240.0, "4 min 15 s"),
}
DEFAULT = ("fit", "fit-b3", "posterior", "quick")


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
        f"{'command':9s} {'wall':>9s} {'exit':>5s} {'aim':>8s}  {'met':8s} last on the CI machine"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for name in ns.only:
            wall, code = run(name, tmp)
            _, aim, before = COMMANDS[name]
            met = "-" if aim is None else ("met" if wall <= aim and code == 0 else "NOT met")
            aim_text = "-" if aim is None else f"{aim:.0f} s"
            print(f"{name:9s} {wall:8.1f}s {code:5d} {aim_text:>8s}  {met:8s} {before}", flush=True)
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    sys.exit(main())
