"""One Preisach evaluation on Table B.3 through the ``voltage`` chain, beside its floor.

Run:  python benchmarks/preisach_floor.py [--repeats 5] [--sets near|prior] [--profile]

The evaluation is :meth:`FitProblem.predict` on internal vectors ``(n, P)``, as nested
sampling calls it, for the Preisach law on the 36 rows of Table B.3 (the report's problem:
``voltage`` chain, the Appendix A geometry's bounds) at batch sizes 1, 32, 100 and 300
(nautilus calls it with 100 by default). The parameter sets are drawn around the report's
least-squares optimum (``reports/results.json``) with its standard errors (``near``: the
sampling phase) or from the whole prior box (``prior``: the exploration).

The **floor** is the compiled work the search did, with nothing between: every call of
the compiled kernels made during one evaluation -- the Preisach branch (two of Genz's
bivariate normals per table node, :func:`fitdf.models._preisach_everett._branch_loop`),
the half period of the circuit (``_half_periods_rows``), the root search's update
(``secant_update``) and node placement (``place_nodes``) -- is recorded with its inputs and
replayed back to back. The replay does exactly the iterations the search took (each
point's coarse and fine secant steps, its re-placements), so it is the time of the
evaluation if all the Python and NumPy between the kernels (the search's bookkeeping, the
reversible arctangent, broadcasting, the initial guess's lattice) cost nothing. The
measured time over the floor is what a search compiled end to end could at most save.

Prints, per batch size, ms per call and per parameter set, the floor, their ratio, the
numbers of kernel calls by kind and the share of the floor each takes; with ``--profile``,
cProfile's largest self-times of one call at batch 100. Timings are medians of
``--repeats`` interleaved runs in one process. Numbers only, no thresholds.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import fitdf.chains.voltage as voltage
import fitdf.models._preisach_everett as everett_mod
import fitdf.models.preisach as preisach_mod
from fitdf.chains import _periodic
from fitdf.data.resolve import resolve_data
from fitdf.inference.api import resolve_geometry
from fitdf.inference.problem import FitProblem

ROOT = Path(__file__).resolve().parents[1]
BATCHES = (1, 32, 100, 300)


def best_point(block: str, law: str) -> dict:
    """The report's least-squares values and standard errors of ``law`` on ``block``."""
    res = json.loads((ROOT / "reports" / "results.json").read_text())
    fit = res["blocks"][block]["fits_lsq"][law]
    return {p["parameter"]: (p["value"], p["stderr"]) for p in fit["parameters"]}


def problem_at(block: str, law: str = "preisach"):
    """The report's problem of ``law`` on ``block`` and its optimum (internal coordinates)."""
    rows = resolve_data(block)
    problem = FitProblem(rows, law, "voltage", None, None, resolve_geometry("auto", rows))
    best = best_point(block, law)
    x = problem.to_internal({n: best[n][0] for n in problem.names})
    return problem, x, best


def parameter_sets(problem, x, best, n: int, kind: str, seed: int = 1) -> np.ndarray:
    """``n`` internal vectors: around ``x`` with the standard errors (``near``) or uniform
    on the prior box (``prior``)."""
    rng = np.random.default_rng(seed)
    lo, hi = problem.internal_bounds().T
    if kind == "prior":
        return lo + rng.random((n, lo.size)) * (hi - lo)
    sd = np.array(
        [
            best[s.name][1] / (best[s.name][0] * np.log(10.0)) if s.log else best[s.name][1]
            for s in problem.specs
        ]
    )
    return np.clip(x + rng.standard_normal((n, x.size)) * sd, lo, hi)


class Recorder:
    """Records every compiled kernel call of the chain (copies of its inputs) while on."""

    KINDS = ("branch", "half_period", "secant", "place")

    def __init__(self):
        self.calls = []
        self.on = False
        self._saved = {}

    def _wrap(self, kind, fn, target=None):
        target = target or fn

        def wrapper(*args):
            if self.on:
                self.calls.append((kind, target, self._copy(kind, args)))
            return fn(*args)

        return wrapper

    @staticmethod
    def _copy(kind, args):
        return tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args)

    def install(self):
        self._saved = {
            "branch": everett_mod._branch_loop,
            "rows": everett_mod._flux_rows,
            "half": voltage.half_periods,
            "secant": voltage.secant_update,
            "place": voltage.place_nodes,
        }
        everett_mod._branch_loop = self._wrap("branch", self._saved["branch"])
        everett_mod._flux_rows = self._wrap("branch", self._saved["rows"])
        rows = _periodic._half_periods_rows

        def half(x, B, V, R, w, phi0, n, dsig, out, threads=1, c_cl=None, c_ex=None):
            P = x.shape[0]
            cc = np.zeros(P) if c_cl is None else _periodic.kernel_array(c_cl, (P,))
            ce = np.zeros(P) if c_ex is None else _periodic.kernel_array(c_ex, (P,))
            if self.on:
                args = (x, B, V, R, w, phi0, n, dsig, out, 0, P, cc, ce)
                self.calls.append(("half_period", rows, self._copy("half_period", args)))
            return self._saved["half"](x, B, V, R, w, phi0, n, dsig, out, threads, c_cl, c_ex)

        voltage.half_periods = half
        voltage.secant_update = self._wrap("secant", self._saved["secant"])
        voltage.place_nodes = self._wrap("place", self._saved["place"])

    def uninstall(self):
        everett_mod._branch_loop = self._saved["branch"]
        everett_mod._flux_rows = self._saved["rows"]
        voltage.half_periods = self._saved["half"]
        voltage.secant_update = self._saved["secant"]
        voltage.place_nodes = self._saved["place"]

    def record(self, fn):
        self.calls, self.on = [], True
        try:
            fn()
        finally:
            self.on = False
        return list(self.calls)


def replay(calls) -> dict:
    """Seconds of each kind of kernel, the recorded calls run back to back on fresh copies."""
    fresh = [(k, fn, Recorder._copy(k, a)) for k, fn, a in calls]
    spent = dict.fromkeys(Recorder.KINDS, 0.0)
    for kind, fn, args in fresh:
        t0 = time.process_time()
        fn(*args)
        spent[kind] += time.process_time() - t0
    return spent


def replay_total(calls) -> float:
    """The floor: the recorded calls back to back, one timer around them all."""
    fresh = [(fn, Recorder._copy(k, a)) for k, fn, a in calls]
    t0 = time.process_time()
    for fn, args in fresh:
        fn(*args)
    return time.process_time() - t0


def measure(problem, X, repeats: int, rec: Recorder) -> dict:
    """Median seconds of ``problem.predict(X)`` and of its floor (interleaved), the calls."""
    problem.predict(X)  # compiled code loaded
    calls = rec.record(lambda: problem.predict(X))
    t_eval, t_floor = [], []
    for _ in range(repeats):
        t0 = time.process_time()
        problem.predict(X)
        t_eval.append(time.process_time() - t0)
        t_floor.append(replay_total(calls))
    parts = replay(calls)
    counts = {k: sum(1 for c in calls if c[0] == k) for k in Recorder.KINDS}
    steps = [int(a[6]) for k, _, a in calls if k == "half_period"]
    return {
        "eval": float(np.median(t_eval)),
        "floor": float(np.median(t_floor)),
        "parts": parts,
        "counts": counts,
        "coarse_iterations": steps.count(voltage.VoltageChain.settings.coarse_steps),
        "fine_iterations": steps.count(voltage.VoltageChain.settings.steps),
    }


class Path_:
    """The law's branch on the chain's tables: ``rows`` (one compiled loop per table,
    :func:`~fitdf.models._preisach_everett.preisach_flux_rows`) or ``elementwise`` (the
    relay part broadcast to every node and the arctangent in NumPy, as before the row loop)."""

    def __init__(self, name):
        self.name = name

    def __enter__(self):
        self.saved = preisach_mod.preisach_flux_rows
        if self.name == "elementwise":
            preisach_mod.preisach_flux_rows = lambda *a, **k: None

    def __exit__(self, *exc):
        preisach_mod.preisach_flux_rows = self.saved


def evaluation(problem, x, best, n, kind, repeats, rec) -> dict:
    """:func:`measure` at batch size ``n`` (``n = 1``: the mean over ten sets, one a call)."""
    if n > 1:
        return measure(problem, parameter_sets(problem, x, best, n, kind), repeats, rec)
    ms = [
        measure(problem, s[None], repeats, rec) for s in parameter_sets(problem, x, best, 10, kind)
    ]
    return {
        "eval": float(np.mean([m["eval"] for m in ms])),
        "floor": float(np.mean([m["floor"] for m in ms])),
        "parts": {k: np.mean([m["parts"][k] for m in ms]) for k in Recorder.KINDS},
        "counts": {k: np.mean([m["counts"][k] for m in ms]) for k in Recorder.KINDS},
        "coarse_iterations": np.mean([m["coarse_iterations"] for m in ms]),
        "fine_iterations": np.mean([m["fine_iterations"] for m in ms]),
    }


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--sets", choices=("near", "prior"), default="near")
    ap.add_argument("--batches", type=int, nargs="+", default=list(BATCHES))
    ap.add_argument("--paths", nargs="+", choices=("rows", "elementwise"), default=["rows"])
    ap.add_argument("--profile", action="store_true")
    args = ap.parse_args(argv)
    problem, x, best = problem_at("B.3")
    rec = Recorder()
    rec.install()
    print(f"B.3 preisach, {problem.data.amplitude.size} rows, sets {args.sets}; CPU ms")
    print(
        "batch branch        ms/call  ms/set  floor/set  ratio  iter(c,f)  kernel calls "
        "(branch half secant place)  floor shares (branch half secant place)"
    )
    try:
        for n in args.batches:
            for name in args.paths:
                with Path_(name):
                    r = evaluation(problem, x, best, n, args.sets, args.repeats, rec)
                total = sum(r["parts"].values())
                shares = " ".join(f"{100 * r['parts'][k] / total:4.0f}%" for k in Recorder.KINDS)
                counts = " ".join(f"{r['counts'][k]:5.0f}" for k in Recorder.KINDS)
                print(
                    f"{n:5d} {name:11s} {1e3 * r['eval']:9.2f} {1e3 * r['eval'] / n:7.2f} "
                    f"{1e3 * r['floor'] / n:9.2f} {r['eval'] / r['floor']:6.2f}  "
                    f"{r['coarse_iterations']:4.1f},{r['fine_iterations']:4.1f}  {counts}"
                    f"     {shares}",
                    flush=True,
                )
        if args.profile:
            X = parameter_sets(problem, x, best, 100, args.sets)
            prof = cProfile.Profile(time.process_time)
            prof.enable()
            problem.predict(X)
            prof.disable()
            pstats.Stats(prof).sort_stats("tottime").print_stats(18)
    finally:
        rec.uninstall()


if __name__ == "__main__":
    main()
