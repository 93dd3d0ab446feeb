"""Ranking models against each other, and cross-validation.

Ranking
    One row per (model, chain, method) fitted to the same rows: parameter count, RMS
    complex / magnitude / phase residuals, reduced chi-square, AICc, BIC (see
    :mod:`fitdf.inference.metrics`), PSIS-LOO and WAIC for posteriors (emcee MCMC or
    nested sampling), the evidence for nested sampling, and a cross-validated RMS complex
    residual (leave one frequency out, fit the rest by least squares, predict it). Default order: AICc, the criterion of the rule that calls a law best
    (:mod:`fitdf.inference.selection`: a law is ranked when AICc is defined on its rows,
    ``2 n >= k + 2``, and the lowest AICc is best). Two models are called *indistinguishable*
    when their AICc differ by less than 2 (least squares), their elpd_loo difference is
    smaller than twice its standard error ``dse`` (emcee MCMC: :func:`arviz.compare` on the
    pair; identical pointwise elpd counts as a tie), or their Bayes factor is not worth more
    than a bare mention (nested sampling).

    Least squares: ``delta_aicc`` is the AICc above the lowest, ``aicc_weight`` the Akaike
    weight ``exp(-delta_aicc / 2)`` normalised over all rows.
    Posterior rows, compared among themselves with :func:`arviz.compare` (PSIS-LOO, log
    scale, rebuilt exactly from each fit's stored pointwise elpd): ``elpd_loo_diff`` and
    ``elpd_loo_dse``, the elpd below the best posterior row and its standard error, and
    ``loo_weight``, the stacking weight. NaN on least-squares rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
import xarray as xr

from fitdf._arviz import arviz
from fitdf.errors import DataError, OptionError
from fitdf.inference.api import DEFAULT_CHAIN, fit, resolve_data, resolve_geometry
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.metrics import residual_metrics
from fitdf.inference.presentation import comparison_text, summary_record
from fitdf.inference.problem import FitProblem, error_components
from fitdf.inference.selection import (
    TIE_TWO_LN_B,
    aicc_tie,
    best_result,
    evidence_tie,
    loo_tie,
    not_ranked_record,
    rank_reason,
    select,
    too_few_rows_message,
)
from fitdf.models import get_model, model_names

__all__ = [
    "compare",
    "KASS_RAFTERY",
    "Comparison",
    "compare_fits",
    "fit_all",
    "ranking_table",
    "best_by_aicc",
    "rankable_laws",
    "cross_validate",
    "RANK_COLUMNS",
    "METHOD_CHOICES",
    "POSTERIOR_METHODS",
    "bayes_factor_scale",
    "log_bayes_factor",
]

#: Columns a ranking can be ordered by, and whether larger is better.
RANK_COLUMNS = {
    "rms_complex": False,
    "rms_magnitude": False,
    "rms_phase_deg": False,
    "redchi": False,
    "aicc": False,
    "bic": False,
    "looic": False,
    "waic": False,
    "cv_rms_complex": False,
    "n_params": False,
    "log_evidence": True,
}
#: ``method`` choices of :func:`compare` and the fits each one runs.
METHOD_CHOICES = {
    "lsq": ("lsq",),
    "mcmc": ("mcmc",),
    "nested": ("nested",),
    "both": ("lsq", "nested"),
}
#: Methods whose results are posteriors (PSIS-LOO; the evidence for nested sampling).
POSTERIOR_METHODS = ("mcmc", "nested")

#: Kass and Raftery (J. Am. Stat. Assoc. 90 (1995) 773) on ``2 ln B``: the evidence a Bayes
#: factor ``B`` gives for the better model, by its upper bounds.
KASS_RAFTERY = (
    (TIE_TWO_LN_B, "not worth more than a bare mention"),
    (6.0, "positive"),
    (10.0, "strong"),
)


def log_bayes_factor(a, b) -> tuple[float, float]:
    """``ln B`` of ``a`` over ``b``, ``ln Z(a) - ln Z(b)``, and its error, the two evidences'
    errors added in quadrature (``a``, ``b``: records with ``log_evidence`` and
    ``log_evidence_error``)."""
    return (
        float(a["log_evidence"] - b["log_evidence"]),
        float(np.hypot(a["log_evidence_error"], b["log_evidence_error"])),
    )


def bayes_factor_scale(log_bayes_factor: float) -> str:
    """The Kass-Raftery verdict on a Bayes factor given as ``ln B`` (of the better model over
    the other, so ``>= 0``): ``2 ln B`` below 2 "not worth more than a bare mention", 2-6
    "positive", 6-10 "strong", above 10 "very strong" (Kass & Raftery 1995, after Jeffreys
    1961)."""
    two = 2.0 * abs(float(log_bayes_factor))
    return next((label for bound, label in KASS_RAFTERY if two < bound), "very strong")


def best_by_aicc(results):
    """The best of ``results`` by the selection rule:
    :func:`fitdf.inference.selection.best_result` (the name kept for its callers)."""
    return best_result(results)


def rankable_laws(data, models=None, chains=(DEFAULT_CHAIN,), fixed=None, geometry="auto"):
    """The ``(model, chain)`` pairs the rows of ``data`` can rank, and the others' records
    (:func:`~fitdf.inference.selection.not_ranked_record`), before any fit: the parameter
    count is that of the fit's problem (per-table gains, chain parameters, ``fixed``)."""
    fd = resolve_data(data)
    geo = resolve_geometry(geometry, fd)
    ok, out = [], []
    for model in list(models or model_names()):
        for chain in chains:
            k = FitProblem(fd, model, chain, None, fixed, geo).ndim
            record = not_ranked_record(model, chain, fd.n, k)
            if record is None:
                ok.append((model, chain))
            else:
                out.append(record)
    return ok, out


def _fit_job(fd, model, chain, method, seed, kw, cross_validation=False):
    """One fit; with ``cross_validation`` (least squares only) ``(fit, its folds)``: a law's
    folds follow its fit in the same job, so no pool waits at a barrier between the
    fits and the folds while the dearest law is still fitting."""
    result = fit(fd, model, chain=chain, method=method, seed=seed, **kw)
    if not cross_validation:
        return result
    return result, (cross_validate(result, seed) if method == "lsq" else None)


def fit_all(
    data,
    models=None,
    chains=(DEFAULT_CHAIN,),
    methods=("lsq",),
    seed=0,
    progress=None,
    runner=None,
    **kw,
) -> list:
    """Fit every model x chain x method on the same rows; returns the results in that order.

    ``runner``, if given, runs the fits: a callable ``runner(jobs, desc) -> results`` on
    ``{key: (function, args)}`` such as :meth:`fitdf.executor.Executor.run` (worker
    processes or a Dask cluster; the same numbers as in this process).
    """
    return _fit_jobs(data, models, chains, methods, seed, progress, runner, False, kw)[0]


def _fit_jobs(
    data, models, chains, methods, seed, progress, runner, cross_validation, kw, rankable=False
):
    """``(results, not_ranked)``: with ``rankable`` (:func:`compare_fits`) only the laws the
    rows can rank are fitted and the others listed (a DataError when none is left);
    :func:`fit_all` fits every law."""
    models = list(models or model_names())
    fd = resolve_data(data, kw.pop("policy", "default"), kw.pop("source_impedance", None))
    pairs, not_ranked = [(m, c) for m in models for c in chains], []
    if rankable:
        pairs, not_ranked = rankable_laws(
            fd, models, chains, kw.get("fixed"), kw.get("geometry", "auto")
        )
        if not pairs:
            raise DataError(too_few_rows_message(fd.label, fd.n, not_ranked))
    combos = [(m, c, k) for m, c in pairs for k in methods]
    # keyed by position too: a model may be listed twice (and must then be fitted twice)
    jobs = {
        (i, *combo): (_fit_job, (fd, *combo, seed, kw, cross_validation))
        for i, combo in enumerate(combos)
    }
    desc = "fitting and cross-validating" if cross_validation else "fitting"
    done = _run_jobs(jobs, runner, desc, {key: key[1] for key in jobs}, progress)
    return list(done.values()), not_ranked


def _run_jobs(jobs: dict, runner, desc: str, models: dict, progress=None) -> dict:
    """``{key: fn(*args)}`` of ``{key: (fn, args)}`` (keys start with the job's position), in
    the jobs' order; ``runner`` (:func:`fit_all`), if given, runs them, the dearest first:
    laws without a closed form (their branch is integrated or summed numerically), so that a
    pool is not left waiting on one long job at the end. ``models``: key -> law name."""
    if runner is None:
        out = {}
        for key, (fn, args) in jobs.items():
            out[key] = fn(*args)
            if progress is not None:
                progress.update(1)
        return out
    order = sorted(jobs, key=lambda key: (get_model(models[key]).closed_form, -key[0]))
    done = runner({key: jobs[key] for key in order}, desc)
    return {key: done[key] for key in jobs}


def cross_validate(result, seed=0, n_starts=None) -> dict:
    """Leave one frequency (per source impedance) out: fit the rest, predict the held-out rows.

    Each fold is polished from the full data's optimum (``result.internal``), not searched
    anew: it measures how far *this* fit moves, and predicts, without the fold's rows. (A
    fold's optimum in another basin of the box is not looked for; ``n_starts``, if given,
    screens the box instead with that many starts, at ~5x the cost.)
    """
    problem = result.problem
    d = problem.data
    keys = list(dict.fromkeys(zip(d.source_impedance.tolist(), d.frequency.tolist())))
    if len(keys) < 2:
        return {"cv_rms_complex": float("nan"), "cv_folds": 0}
    errors, per_fold = [], []
    law = problem.noise_law
    ctx = None if law is None else law.context(d)  # the output gains of the whole tables
    for rs, f in keys:
        held = (d.source_impedance == rs) & (d.frequency == f)
        train = FitProblem(
            d.subset(~held),
            problem.model,
            problem.chain,
            problem.noise,
            problem.fixed,
            problem.geometry,
            noise_law=problem.noise_law,
        )
        if train.data.n <= train.ndim:
            continue
        if n_starts is None:
            r = fit_lsq(train, seed=seed, starts=result.internal, uncertainties=False)
        else:
            r = fit_lsq(train, seed=seed, n_starts=n_starts, uncertainties=False)
        held_rows = d.subset(held)
        pred = r.predict(
            held_rows.amplitude,
            held_rows.frequency,
            held_rows.source_impedance,
            table=held_rows.group[0] if held_rows.group[0] in train.data.groups else None,
        )
        errors.append(np.abs(pred - held_rows.measured))
        fold = {
            "source_impedance_ohm": rs,
            "frequency_hz": f,
            **residual_metrics(pred, held_rows.measured),
        }
        if law is not None:
            errors_held = error_components(pred, held_rows.measured)
            sub = {key: value[held] for key, value in ctx.items()}
            theta = r.info["noise_law"]["log10"]
            # the held rows' log density under the law and noise fitted without them
            fold["log_score"] = float(np.sum(law.pointwise(theta, *errors_held, sub)))
        per_fold.append(fold)
    allerr = np.concatenate(errors) if errors else np.array([np.nan])
    out = {
        "cv_rms_complex": float(np.sqrt(np.mean(allerr**2))),
        "cv_folds": len(per_fold),
        "cv_per_fold": per_fold,
    }
    if law is not None:
        out["cv_log_score"] = float(sum(fold["log_score"] for fold in per_fold))
    return out


def ranking_table(results, rank_by: str = "aicc", cv: dict | None = None) -> pd.DataFrame:
    """The ranking of fitted results (all fitted to the same rows), ordered by ``rank_by``
    (default AICc, the selection rule's criterion; the first of equals first).

    Results whose rows cannot rank them (:func:`~fitdf.inference.selection.rank_reason`)
    are left out (a DataError when none is left); ``cv`` maps a result's
    position in ``results`` to its :func:`cross_validate` record.
    """
    if rank_by not in RANK_COLUMNS:
        raise OptionError(f"cannot rank by {rank_by!r}; choose one of {', '.join(RANK_COLUMNS)}")
    keep = [
        i
        for i, r in enumerate(results)
        if rank_reason(r.metrics["n_points"], r.metrics["n_params"]) is None
    ]
    if results and not keep:
        m = results[0].metrics
        records = [
            not_ranked_record(r.model, r.chain, r.metrics["n_points"], r.metrics["n_params"])
            for r in results
        ]
        raise DataError(too_few_rows_message(results[0].label, m["n_points"], records))
    cv = {keep.index(i): c for i, c in (cv or {}).items() if i in keep}
    results = [results[i] for i in keep]
    rows = []
    for i, r in enumerate(results):
        m = r.metrics
        row = {
            "model": r.model,
            "chain": r.chain,
            "method": r.method,
            "n_params": m["n_params"],
            "n_points": m["n_points"],
            "rms_complex": m["rms_complex"],
            "rms_magnitude": m["rms_magnitude"],
            "rms_phase_deg": m["rms_phase_deg"],
            "redchi": m["redchi"],
            "aicc": m["aicc"],
            "bic": m["bic"],
            "looic": m.get("looic", np.nan),
            "looic_se": m.get("looic_se", np.nan),
            "waic": m.get("waic", np.nan),
            "cv_rms_complex": np.nan,
            "log_evidence": getattr(r, "diagnostics", {}).get("log_evidence", np.nan),
            "log_evidence_error": getattr(r, "diagnostics", {}).get("log_evidence_error", np.nan),
            "warnings": len(r.warnings),
        }
        if i in cv:
            row["cv_rms_complex"] = cv[i]["cv_rms_complex"]
        rows.append(row)
    table = pd.DataFrame(rows)
    table["delta_aicc"] = table["aicc"] - table["aicc"].min()
    weights = np.exp(-0.5 * table["delta_aicc"])
    table["aicc_weight"] = weights / weights.sum()
    table["indistinguishable_from"] = _ties(results, table)
    for col, values in _loo_comparison(results).items():
        table[col] = values
    if rank_by in ("looic", "waic") and table[rank_by].isna().all():
        raise OptionError(f"--rank-by {rank_by} needs posteriors (--method nested, mcmc or both)")
    if rank_by == "log_evidence" and table[rank_by].isna().all():
        raise OptionError("--rank-by log_evidence needs nested-sampling fits (--method nested)")
    key = -table[rank_by] if RANK_COLUMNS[rank_by] else table[rank_by]
    order = np.lexsort((table["aicc"].to_numpy(), np.nan_to_num(key.to_numpy(), nan=np.inf)))
    table = table.iloc[order].reset_index(drop=True)
    table = _bayes_factors(table)
    table.insert(0, "rank", np.arange(1, len(table) + 1))
    return table


def _bayes_factors(table: pd.DataFrame) -> pd.DataFrame:
    """``log_bayes_factor_next``: ``ln B`` of each row with an evidence over the next row with one
    in evidence order (its error from the two evidences' errors, added in quadrature), and its
    Kass-Raftery verdict (:func:`bayes_factor_scale`); NaN and "" elsewhere."""
    table = table.copy()
    table["log_bayes_factor_next"] = np.nan
    table["log_bayes_factor_next_error"] = np.nan
    table["bayes_factor_verdict"] = ""
    has = table["log_evidence"].notna()
    if has.sum() < 2:
        return table
    ordered = table[has].sort_values("log_evidence", ascending=False)
    for (i, a), (_, b) in zip(ordered.iterrows(), list(ordered.iterrows())[1:]):
        ln_b, error = log_bayes_factor(a, b)
        table.loc[i, "log_bayes_factor_next"] = ln_b
        table.loc[i, "log_bayes_factor_next_error"] = error
        table.loc[i, "bayes_factor_verdict"] = bayes_factor_scale(ln_b)
    return table


def _elpd_data(result):
    """A posterior's PSIS-LOO as :class:`arviz.ELPDData` (log scale), or None.

    Rebuilt from ``diagnostics["pointwise_elpd_loo"]``: ``elpd_loo`` and ``se`` are the sum and
    ``sqrt(n var)`` of the pointwise values, as :func:`arviz.loo` computes them; these, the
    pointwise values, ``p_loo`` and ``warning`` are all :func:`arviz.compare` reads.
    """
    if result.method not in POSTERIOR_METHODS:
        return None
    loo_i = np.asarray(result.diagnostics.get("pointwise_elpd_loo", []), float)
    if not loo_i.size:
        return None
    return arviz().ELPDData(
        data=[
            float(np.sum(loo_i)),
            float(np.sqrt(loo_i.size * np.var(loo_i))),
            float(result.diagnostics.get("p_loo", np.nan)),
            bool(result.diagnostics.get("n_pareto_k_bad", 0)),
            xr.DataArray(loo_i, dims=["observation"]),
            "log",
        ],
        index=["elpd_loo", "se", "p_loo", "warning", "loo_i", "scale"],
    )


def _loo_comparison(results) -> dict:
    """``elpd_loo_diff``, ``elpd_loo_dse`` and ``loo_weight`` (stacking) of :func:`arviz.compare`
    over the posterior rows with pointwise elpd on the same number of rows; NaN elsewhere."""
    out = {
        c: np.full(len(results), np.nan) for c in ("elpd_loo_diff", "elpd_loo_dse", "loo_weight")
    }
    elpd = {i: e for i, r in enumerate(results) if (e := _elpd_data(r)) is not None}
    if not elpd or len({e["loo_i"].size for e in elpd.values()}) != 1:
        return out
    cmp = arviz().compare(elpd, ic="loo", method="stacking", scale="log")
    for i in elpd:
        out["elpd_loo_diff"][i] = cmp.loc[i, "elpd_diff"]
        out["elpd_loo_dse"][i] = cmp.loc[i, "dse"]
        out["loo_weight"][i] = cmp.loc[i, "weight"]
    return out


def _loo_tie(a, b) -> bool:
    """Whether two posteriors' elpd_loo differ by less than twice the difference's standard error
    (:func:`arviz.compare` on the pair); identical pointwise elpd is a tie."""
    if a is None or b is None or a["loo_i"].size != b["loo_i"].size:
        return False
    row = arviz().compare({0: a, 1: b}, ic="loo", method="stacking", scale="log").iloc[1]
    return loo_tie(row["elpd_diff"], row["dse"])


def _ties(results, table) -> list[str]:
    """For each row, the other models it cannot be told apart from."""
    elpd = [_elpd_data(r) for r in results]
    loo_ties = {}
    out = []
    for i, r in enumerate(results):
        ties = []
        for j, s in enumerate(results):
            if i == j or r.method != s.method:
                continue
            if r.method == "nested" and np.isfinite(table.loc[i, "log_evidence"]):
                # by the evidence: a Bayes factor not worth more than a bare mention
                if evidence_tie(table.loc[i, "log_evidence"], table.loc[j, "log_evidence"]):
                    ties.append(f"{s.model}/{s.chain}")
            elif r.method in POSTERIOR_METHODS:
                pair = (min(i, j), max(i, j))
                if pair not in loo_ties:
                    loo_ties[pair] = _loo_tie(elpd[i], elpd[j])
                if loo_ties[pair]:
                    ties.append(f"{s.model}/{s.chain}")
            elif aicc_tie(table.loc[i, "aicc"], table.loc[j, "aicc"]):
                ties.append(f"{s.model}/{s.chain}")
        out.append(", ".join(ties))
    return out


@dataclass(frozen=True)
class Comparison:
    """Fitted results, their ranking (:func:`compare_fits`; ``table``, ordered by
    ``rank_by``) and the laws the rows could not rank (``not_ranked``:
    :func:`~fitdf.inference.selection.not_ranked_record`)."""

    table: pd.DataFrame
    results: tuple
    not_ranked: tuple = ()
    rank_by: str = "aicc"

    def text(self, wide: bool = False, brief: bool = False) -> str:
        """The ranking, what the selection rule calls best, the best fit (unless ``brief``)
        and the posteriors' checks, within 100 columns unless ``wide``
        (:func:`fitdf.inference.presentation.comparison_text`)."""
        return comparison_text(self, wide=wide, brief=brief)

    def __str__(self):
        return self.text()

    def summary_record(self, data) -> dict:
        """The best law of these rows (``data``: their name) and how well it fits: one row of
        a batch summary (:func:`fitdf.inference.presentation.summary_record`)."""
        return summary_record(self, data)

    @property
    def selection(self):
        """The selection rule on the ranking (:func:`fitdf.inference.selection.select`)."""
        return select(self.table.to_dict(orient="records"), self.not_ranked)

    @property
    def best(self):
        """The result the selection rule calls best (whatever order the table is in)."""
        b = self.selection.best
        key = (b["model"], b["chain"], b["method"])
        return next(r for r in self.results if (r.model, r.chain, r.method) == key)


def compare_fits(
    data,
    models=None,
    chains=(DEFAULT_CHAIN,),
    method="lsq",
    seed=0,
    rank_by="aicc",
    cross_validation=True,
    progress=None,
    runner=None,
    **kw,
) -> Comparison:
    """Fit every model the rows can rank (:func:`rankable_laws`), cross-validate the
    least-squares fits, rank them; a DataError if the rows can rank no law.

    ``method`` is a key of :data:`METHOD_CHOICES`: "lsq", "mcmc" (emcee), "nested" (nested
    sampling: the posterior and the evidence) or "both" (least squares and nested sampling);
    ``runner`` runs the fits and cross-validations
    (:func:`fit_all`); other keywords go to :func:`fitdf.fit`.
    """
    methods = METHOD_CHOICES.get(method)
    if methods is None:
        raise OptionError(f"unknown method {method!r}; choose {', '.join(METHOD_CHOICES)}")
    done, not_ranked = _fit_jobs(
        data, models, chains, methods, seed, progress, runner, cross_validation, kw, True
    )
    if not cross_validation:
        table = ranking_table(done, rank_by, None)
        return Comparison(table, tuple(done), tuple(not_ranked), rank_by)
    results = [r for r, _ in done]
    cv = {i: folds for i, (_, folds) in enumerate(done) if folds is not None}
    table = ranking_table(results, rank_by, cv)
    return Comparison(table, tuple(results), tuple(not_ranked), rank_by)


def compare(
    data,
    models=None,
    chains=(DEFAULT_CHAIN,),
    method="lsq",
    seed=0,
    rank_by="aicc",
    cross_validation=True,
    progress=None,
    **kw,
) -> pd.DataFrame:
    """The ranking table of :func:`compare_fits` (see the module docstring).

    For the fitted results as well, call :func:`compare_fits`, or :func:`fit_all` and
    :func:`ranking_table`.
    """
    return compare_fits(
        data, models, chains, method, seed, rank_by, cross_validation, progress, **kw
    ).table
