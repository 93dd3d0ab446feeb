"""How often the least-squares starts beyond the first few change the optimum.

For every law on every block of the report (:data:`fitdf.report.settings.BLOCKS`, the exact
chain, seed 0, the report's ``n_starts``), the multi-start search of
:func:`fitdf.inference.lsq.fit_lsq` is run with every start polished (no early stop), and
each start's polish recorded in order: its chi-square, whether it merged into a basin an
earlier start reached, its evaluations and CPU seconds. Because the screen's ``k`` best
points are the first ``k`` of its ``n`` best (one Sobol sequence, a stable sort) and a
start's polish depends only on the starts before it, the fit ``fit_lsq`` returns with ``k``
starts is reproduced exactly from the first ``k`` of these polishes (their restarts near
the floor of those ``k``, :func:`fitdf.inference.lsq._polish_further`, included). The
table gives, for k = 1..n, whether the best of the first ``k`` is the best of all: within
0.1 in both chi-square and AICc ("."), within 1e-3 relative in chi-square only ("r"), "x"
where neither; ``k_0.1`` is the first ``k`` from which every prefix is ".", ``k_exact``
where the best start is (its fit the fit of all the starts, within 1e-6 relative), and
``after_best`` the CPU seconds of the starts after it. The summary below it: how often the
first start is the best, and what each early stop of :data:`RULES` (once ``A`` starts have
ended within ``D`` of the lowest chi-square so far) would save and which fits it would change.

``--check`` compares each fit with ``reports/results.json`` (the committed report's chi-square,
relative difference). Writes ``benchmarks/lsq_starts.json``. ~11 min on two shared Xeon
cores (``--workers 2``). ``--verify`` runs the report's least-squares jobs as this checkout
runs them (:func:`fitdf.inference.api.fit`) and compares their chi-square with the report's.

    python benchmarks/lsq_starts.py [--blocks B.1 ...] [--models ...] [--seed 0] [--workers 2]
    python benchmarks/lsq_starts.py --table benchmarks/lsq_starts.json --check   # no fit
"""

from __future__ import annotations

import argparse
import json
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
REL_TOL = 1e-3
ABS_TOL = 0.1


def _problem(data, model):
    from fitdf.data.resolve import resolve_data
    from fitdf.inference.api import DEFAULT_CHAIN, resolve_geometry
    from fitdf.inference.problem import FitProblem

    rows = resolve_data(data, "default", None)
    return FitProblem(rows, model, DEFAULT_CHAIN, None, None, resolve_geometry("auto", rows))


def _criteria(problem, x) -> tuple[float, float]:
    """The result's chi-square and AICc at ``x`` (as :func:`fit_lsq`'s ``metrics``)."""
    from fitdf.inference.metrics import information_criteria

    ic = information_criteria(problem.weighted_residuals(x), problem.ndim)
    return float(ic["chi2"]), float(ic["aicc"])


def study(key, data, model, seed, n_starts):
    """Every start of one fit polished in order, and the fit of each prefix of them."""
    from fitdf.inference import lsq

    problem = _problem(data, model)
    t0 = time.process_time()
    starts, _ = lsq._starts(problem, seed, n_starts, 256, None, 0)
    screen_s = time.process_time() - t0
    polished, known, per_start = [], [], []
    for s in starts:
        t = time.process_time()
        out, x, cost = lsq._polish(problem, s, 400, known)
        if not out.merged:
            known.append(lsq._Basin(problem, x, cost))
        polished.append((out, x, cost))
        per_start.append(
            {
                "chi2": cost,
                "merged": bool(out.merged),
                "nfev": int(out.nfev),
                "cpu_s": time.process_time() - t,
            }
        )
    further = {}  # start -> (out, x, cost) restarted, computed once
    prefixes = []
    for k in range(1, len(starts) + 1):
        floor = min(p[2] for p in polished[:k])
        final, nfev, cpu = [], sum(p["nfev"] for p in per_start[:k]), 0.0
        for j, p in enumerate(polished[:k]):
            if p[2] <= floor + lsq.RESTART_WINDOW and not p[0].merged:
                if j not in further:
                    t = time.process_time()
                    further[j] = (lsq._polish_further(problem, p, 400), time.process_time() - t)
                (out, x, cost), secs = further[j]
                nfev += out.nfev - p[0].nfev
                cpu += secs
                final.append((x, cost))
            else:
                final.append((p[1], p[2]))
        costs = np.array([c for _, c in final])
        best = int(np.argmin(costs))
        chi2, aicc = _criteria(problem, final[best][0])
        prefixes.append(
            {
                "k": k,
                "objective": float(costs[best]),
                "best_start": best,
                "chi2": chi2,
                "aicc": aicc,
                "nfev": int(nfev),
                "polish_cpu_s": sum(p["cpu_s"] for p in per_start[:k]) + cpu,
            }
        )
    return {
        "block": key,
        "model": model,
        "n_params": problem.ndim,
        "screen_cpu_s": screen_s,
        "starts": per_start,
        "prefixes": prefixes,
    }


def agreement(rec) -> list[str]:
    """Per k: "." within ABS_TOL in chi-square and AICc of the best of all, "r" within REL_TOL
    relative only, "x" neither."""
    last = rec["prefixes"][-1]
    marks = []
    for p in rec["prefixes"]:
        d_chi2, d_aicc = p["chi2"] - last["chi2"], p["aicc"] - last["aicc"]
        if d_chi2 <= ABS_TOL and d_aicc <= ABS_TOL:
            marks.append(".")
        elif d_chi2 <= REL_TOL * abs(last["chi2"]):
            marks.append("r")
        else:
            marks.append("x")
    return marks


def enough(marks) -> int:
    """The smallest k from which every prefix is within ABS_TOL."""
    k = len(marks)
    while k > 1 and marks[k - 2] == ".":
        k -= 1
    return k


def exact(rec) -> int:
    """The smallest k whose fit is the fit of all the starts (chi-square within 1e-6
    relative): where the best start is."""
    last = rec["prefixes"][-1]["chi2"]
    return next(p["k"] for p in rec["prefixes"] if p["chi2"] <= last * (1 + 1e-6))


def cpu(rec, k) -> float:
    """CPU seconds of the fit with the first ``k`` starts (the screen included)."""
    return rec["screen_cpu_s"] + rec["prefixes"][k - 1]["polish_cpu_s"]


def agree_stop(rec, n_agree, window) -> int:
    """Where an early stop would end the search: after the first start at which ``n_agree``
    of the starts polished so far ended within ``window`` of the lowest chi-square so far."""
    costs = [s["chi2"] for s in rec["starts"]]
    for k in range(1, len(costs) + 1):
        low = min(costs[:k])
        if sum(c <= low + window for c in costs[:k]) >= n_agree:
            return k
    return len(costs)


#: The early stops tried: (starts that agree, chi-square window).
RULES = ((2, 0.1), (2, 1.0), (3, 0.1), (3, 1.0), (4, 0.1), (4, 1.0))


def table(records, reference=None) -> str:
    lines = [
        f"{'block':16s} {'law':25s} {'n':>3s} {'k_0.1':>5s} {'k_exact':>7s} {'cpu_s':>6s} "
        f"{'after_best':>10s}" + (f" {'rel_vs_report':>13s}" if reference else "") + "  k=1..n"
    ]
    for rec in records:
        marks, n = agreement(rec), len(rec["starts"])
        ref = ""
        if reference is not None:
            chi2 = reference.get((rec["block"], rec["model"]))
            last = rec["prefixes"][-1]["chi2"]
            ref = f" {(last - chi2) / chi2:+13.1e}" if chi2 else f" {'-':>13s}"
        lines.append(
            f"{rec['block']:16s} {rec['model']:25s} {n:3d} {enough(marks):5d} "
            f"{exact(rec):7d} {cpu(rec, n):6.1f} {cpu(rec, n) - cpu(rec, exact(rec)):10.1f}"
            f"{ref}  " + "".join(marks)
        )
    return "\n".join(lines)


def summary(records) -> str:
    """How often the first start is the best, what the starts after the best cost, and what
    each early stop of :data:`RULES` would save and change."""
    total = sum(cpu(r, len(r["starts"])) for r in records)
    after = sum(cpu(r, len(r["starts"])) - cpu(r, exact(r)) for r in records)
    starts = [s for r in records for s in r["starts"]]
    merged = [s for s in starts if s["merged"]]
    laws = {}
    for r in records:
        laws[r["model"]] = max(laws.get(r["model"], 0), exact(r))
    lines = [
        f"{len(records)} fits: the first start is the best in "
        f"{sum(exact(r) == 1 for r in records)}, the last in "
        f"{sum(exact(r) == len(r['starts']) for r in records)}",
        "the start that reaches the best, at most, per law (of n): "
        + ", ".join(f"{m} {k}" for m, k in laws.items()),
        f"CPU {total:.0f} s, the screens {sum(r['screen_cpu_s'] for r in records):.0f} s; "
        f"the starts after the best {after:.0f} s (what stopping at the best, known in "
        "hindsight, would save)",
        f"{len(merged)} of {len(starts)} starts merged into a basin found before: "
        f"{sum(s['cpu_s'] for s in merged):.0f} s",
        "early stop after A starts within D of the lowest chi-square so far:",
    ]
    for n_agree, window in RULES:
        stops = [agree_stop(r, n_agree, window) for r in records]
        saved = sum(cpu(r, len(r["starts"])) - cpu(r, k) for r, k in zip(records, stops))
        changed = [
            f"{r['block']} {r['model']} AICc "
            f"{r['prefixes'][k - 1]['aicc'] - r['prefixes'][-1]['aicc']:+.2g}"
            for r, k in zip(records, stops)
            if k < exact(r)
        ]
        lines.append(
            f"  A={n_agree} D={window:g}: saves {saved:.0f} s, changes {len(changed)} fits"
            + (f" ({', '.join(changed)})" if changed else "")
        )
    return "\n".join(lines)


def _reference():
    path = ROOT / "reports" / "results.json"
    res = json.loads(path.read_text())
    return {
        (key, m): f["metrics"]["chi2"]
        for key, b in res["blocks"].items()
        for m, f in b["fits_lsq"].items()
    }


def _run(args):
    return study(*args)


def verify(key, data, model, seed, n_starts):
    """The report's least-squares job as this checkout runs it: chi-square, AICc, CPU."""
    from fitdf.inference.api import fit

    t = time.process_time()
    r = fit(data, model, method="lsq", seed=seed, n_starts=n_starts)
    return {
        "block": key,
        "model": model,
        "chi2": r.metrics["chi2"],
        "aicc": r.metrics["aicc"],
        "nfev_total": r.info["nfev_total"],
        "cpu_s": time.process_time() - t,
    }


def _run_verify(args):
    return verify(*args)


def verify_table(records, reference) -> str:
    lines = [f"{'block':16s} {'law':25s} {'chi2':>10s} {'rel_vs_report':>13s} {'cpu_s':>6s}"]
    worst = 0.0
    for rec in records:
        chi2 = reference[(rec["block"], rec["model"])]
        rel = (rec["chi2"] - chi2) / chi2
        worst = max(worst, rel)
        lines.append(
            f"{rec['block']:16s} {rec['model']:25s} {rec['chi2']:10.3f} {rel:+13.1e} "
            f"{rec['cpu_s']:6.1f}"
        )
    total = sum(rec["cpu_s"] for rec in records)
    lines.append(f"largest rise in chi-square over the report's: {worst:+.1e} (relative)")
    lines.append(f"CPU of the {len(records)} fits: {total:.0f} s")
    return "\n".join(lines)


def main(argv=None):
    from fitdf.models import get_model, model_names
    from fitdf.report.settings import BLOCKS, ReportSettings

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--blocks", nargs="*", default=[b.key for b in BLOCKS])
    ap.add_argument("--models", nargs="*", default=list(model_names()))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--check", action="store_true", help="compare with reports/results.json")
    ap.add_argument("--out", default=str(Path(__file__).with_suffix(".json")))
    ap.add_argument("--table", help="print the table of a json written before, compute nothing")
    ap.add_argument(
        "--verify",
        action="store_true",
        help="run each fit as the report does and compare it with reports/results.json",
    )
    args = ap.parse_args(argv)
    reference = _reference() if args.check or args.verify else None
    if args.table:
        records = json.loads(Path(args.table).read_text())["records"]
        print(table(records, reference))
        print("\n" + summary(records))
        return 0
    n_starts = ReportSettings().n_starts
    data = {b.key: b.data for b in BLOCKS}
    jobs = [(k, data[k], m, args.seed, n_starts) for k in args.blocks for m in args.models]
    # the dearest first (laws with more starts, without a closed form): a short pool tail
    order = sorted(
        jobs,
        key=lambda j: (-get_model(j[2]).start_multiple, get_model(j[2]).closed_form),
    )
    t0 = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        done = dict(zip(map(tuple, order), pool.map(_run_verify if args.verify else _run, order)))
    records = [done[tuple(j)] for j in jobs]
    wall = time.perf_counter() - t0
    if args.verify:
        print(verify_table(records, reference))
        print(f"\n{wall:.0f} s wall, {os.getloadavg()[0]:.1f} load average")
        return 0
    print(table(records, reference))
    print("\n" + summary(records))
    print(f"\n{len(records)} fits, {wall:.0f} s wall, {os.getloadavg()[0]:.1f} load average")
    Path(args.out).write_text(
        json.dumps(
            {"seed": args.seed, "n_starts": n_starts, "wall_s": wall, "records": records},
            indent=1,
        )
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
