"""What a report was computed on: the CPU and the numerical stack.

The same seed gives the same numbers only on the same CPU with the same libraries. NumPy picks
its SIMD kernels (exp, log, sums) by the CPU it runs on and numba compiles for the host CPU,
so another processor rounds a few last bits differently. The least-squares optimiser then
stops at another point of a flat valley: on AMD EPYC against the machine that made the
committed report, RMS residuals moved by up to 2e-3 relative and AICc by up to 2, with
the same rankings (``tests/test_report.py``). The record below lets a comparison know which
of the two it is looking at.
"""

from __future__ import annotations

import platform
import sys
from importlib import metadata

import llvmlite.binding as llvm

# The libraries whose rounding reaches a fitted number.
_STACK = ("numpy", "scipy", "numba", "lmfit", "emcee", "nautilus-sampler", "scikit-learn")


def _cpu_model() -> str:
    """The processor's model name (``/proc/cpuinfo`` on Linux, else :func:`platform.processor`)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def versions(names) -> dict:
    """The installed version of each distribution in ``names`` (None where it is missing)."""
    found = {}
    for name in names:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = None
    return found


def machine_record() -> dict:
    """The CPU, LLVM's name for it (numba's target; llvmlite comes with numba), the Python
    version and the numerical libraries' versions."""
    return {
        "cpu": _cpu_model(),
        "architecture": platform.machine(),
        "llvm_cpu": llvm.get_host_cpu_name(),  # what numba compiles for
        "python": sys.version.split()[0],
        "libraries": versions(_STACK),
    }


def same_machine(a: dict | None, b: dict | None) -> bool:
    """True when two machine records name the same CPU and the same numerical stack."""
    return bool(a) and bool(b) and a == b
