"""The small-signal study of a report: the readings' noise law and the laws' low-field
behaviour, each ranked by the evidence beside what the report already holds.

Two questions the report's own posteriors (``printed`` noise) cannot answer:

1. **How were the numbers read?** A block's best least-squares law is sampled by nested
   sampling under each fitted noise law of :data:`NOISE_LAWS`
   (:mod:`fitdf.inference.noise_models`: ``constant`` scales; the ``reading`` law, whose
   error grows as the input falls, from a resolution in volts of output; ``student``, the
   robust alternative). The evidence ranks the noise laws; the law's posterior medians under
   each show which parameters the noise model moves.
2. **Low field.** :data:`LOW_FIELD_LAW` (``preisach_rayleigh``: the Preisach law with a
   Rayleigh population, a density finite at the origin) is fitted by least squares,
   cross-validated and sampled with the report's settings and ``printed`` noise, beside the
   report's own :data:`BASE_LAW` (``preisach``) fit and posterior of the same block: AICc,
   the held-out RMS and the evidence; and the rows every law of the report misses most,
   with the low-field law and against the readings a passive core can give
   (:func:`worst_rows`).

Both use the report's seed, chain, starts and sampler settings (``settings`` of its
``results.json``). The study costs a third of ``fitdf report --full``'s time again
(``timing`` of its record), so it is not part of that run; it is added to a report folder
afterwards, and its record (``small_signal_evidence`` of ``results.json``,
:func:`study_record`) is rendered in the report's small-signal section::

    python -m fitdf.report.small_signal_study reports

The study's jobs are kept in the job cache (:mod:`fitdf.jobcache`) under its own salt: a
stopped run resumes where it stopped.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from fitdf.data.datasets import data_dir
from fitdf.errors import FitdfError, OptionError
from fitdf.executor import Executor
from fitdf.inference.nested import fit_nested
from fitdf.inference.problem import FitProblem
from fitdf.inference.small_signal import passive_distance
from fitdf.jobcache import JobCache, default_cache_folder, run_salt
from fitdf.machine import machine_record
from fitdf.report import jobs as job
from fitdf.report.output import write_outputs
from fitdf.report.settings import BLOCKS
from fitdf.report.upgrade import read_results
from fitdf.report.words import report_words

__all__ = [
    "NOISE_LAWS",
    "LOW_FIELD_LAW",
    "BASE_LAW",
    "StudySettings",
    "posterior_summary",
    "job_noise_posterior",
    "check_study",
    "run_study",
    "study_record",
    "worst_rows",
    "write_study",
    "add_study",
    "main",
]

#: The fitted noise laws compared (``printed`` is the report's own posterior).
NOISE_LAWS = ("constant", "reading", "student")
#: The law with a low-field (Rayleigh) population, and the law it extends.
LOW_FIELD_LAW = "preisach_rayleigh"
BASE_LAW = "preisach"


@dataclass(frozen=True)
class StudySettings:
    """What the study computes; the sampler, chain, starts and seed are the report's.

    Attributes
    ----------
    noise_blocks : tuple of str
        Blocks whose best least-squares law is sampled under each of ``noise_laws``: by
        default the tables where the residuals grow as the input falls, Deltamax at both
        source impedances (Tables B.2 and B.5: one core, one analyser, two dividers) and
        Permalloy at 600 ohm (B.3). B.1 shows no growth, and Supermalloy's one table (B.4)
        has no partner at another source impedance.
    noise_laws : tuple of str
        Fitted noise laws (:data:`NOISE_LAWS`).
    low_field_blocks : tuple of str
        Blocks where :data:`LOW_FIELD_LAW` is fitted, cross-validated and sampled beside the
        report's :data:`BASE_LAW` (its posterior must be in the report): every single table.
    """

    noise_blocks: tuple = ("B.2", "B.5", "B.3")
    noise_laws: tuple = NOISE_LAWS
    low_field_blocks: tuple = ("B.1", "B.2", "B.3", "B.4", "B.5")


def posterior_summary(result) -> dict:
    """A nested-sampling fit as the study keeps it: the evidence and its error, the
    effective draws, the likelihood evaluations, convergence, the RMS at the point estimate,
    each parameter's posterior median and 68 % interval, the noise parameters' medians and
    68 % intervals (a fitted noise law's, or the two scales integrated out), and the
    warnings."""
    d, info = result.diagnostics, result.info
    law = info.get("noise_law")
    if law:
        noise = {k: [v["p16"], v["p50"], v["p84"]] for k, v in law["intervals"].items()}
    else:
        noise = {
            k.removesuffix("_interval"): [v["p16"], v["p50"], v["p84"]]
            for k, v in d.items()
            if k.startswith("sigma_") and k.endswith("_interval")
        }
    return {
        "log_evidence": float(d["log_evidence"]),
        "log_evidence_error": float(d["log_evidence_error"]),
        "n_effective": float(d["n_effective"]),
        "n_likelihood_evaluations": int(d["n_likelihood_evaluations"]),
        "converged": bool(d["converged"]),
        "rms_complex": float(result.metrics["rms_complex"]),
        "parameters": {k: [v["p16"], v["p50"], v["p84"]] for k, v in result.intervals.items()},
        "noise": noise,
        "warnings": list(result.warnings),
    }


def job_noise_posterior(lsq, noise_law, seed, n_live, n_networks, max_evaluations):
    """The posterior and evidence of ``lsq``'s law and rows under the fitted ``noise_law``
    (:func:`posterior_summary`)."""
    p = lsq.problem
    problem = FitProblem(
        p.data, p.model, p.chain, p.noise, p.fixed, p.geometry, noise_law=noise_law
    )
    result = fit_nested(
        problem,
        lsq,
        seed=seed,
        n_live=n_live,
        n_networks=n_networks,
        max_evaluations=max_evaluations,
    )
    return posterior_summary(result)


def _posterior_job(lsq, seed, n_live, n_networks, max_evaluations):
    """The report's posterior job (``printed`` noise), as :func:`posterior_summary`."""
    return posterior_summary(job.job_nested(lsq, seed, n_live, n_networks, max_evaluations))


def _block(key):
    return next(b for b in BLOCKS if b.key == key)


def check_study(results: dict, study: StudySettings) -> None:
    """:class:`~fitdf.errors.OptionError` naming the option when ``study`` asks for a block
    the report does not hold, a noise law that is not fitted, or a low-field block without
    the report's :data:`BASE_LAW` posterior."""
    held = list(results["blocks"])
    for option, keys in (
        ("--noise-blocks", study.noise_blocks),
        ("--low-field-blocks", study.low_field_blocks),
    ):
        for key in keys:
            if key not in held:
                raise OptionError(
                    f"{option}: the report holds no block {key!r} (it holds {', '.join(held)})"
                )
    for name in study.noise_laws:
        if name not in NOISE_LAWS:
            raise OptionError(f"noise law {name!r}: the study samples {', '.join(NOISE_LAWS)}")
    for key in study.low_field_blocks:
        if BASE_LAW not in (results["blocks"][key].get("fits_posterior") or {}):
            raise OptionError(
                f"--low-field-blocks: the report holds no {BASE_LAW} posterior of {key}"
            )


def _best_law(results, key) -> str:
    return results["blocks"][key]["ranking_lsq"][0]["model"]


def run_study(results: dict, study: StudySettings, runner: Executor) -> dict:
    """Run the study's jobs for the report ``results`` on ``runner``; returns
    ``{"lsq": ..., "cv": ..., "noise": ..., "low_field": ...}`` by their keys."""
    s, seed = results["settings"], int(results["seed"])
    sampler = (s["nested_live"], s["nested_networks"], s["nested_max_evaluations"])
    check_study(results, study)
    fits = {(k, _best_law(results, k)) for k in study.noise_blocks}
    fits |= {(k, LOW_FIELD_LAW) for k in study.low_field_blocks}
    lsq = runner.run(
        {
            ("lsq", k, m): (job.job_lsq, (_block(k).data, m, seed, s["n_starts"], s["chain"]))
            for k, m in sorted(fits)
        },
        "small-signal study: least squares",
    )
    # the longest first (a short pool tail): the 600 ohm tables' posteriors, then the rest
    jobs = {}
    for k in reversed(study.low_field_blocks):
        fit = lsq[("lsq", k, LOW_FIELD_LAW)]
        jobs[("low_field", k)] = (_posterior_job, (fit, seed, *sampler))
    for k in reversed(study.noise_blocks):
        fit = lsq[("lsq", k, _best_law(results, k))]
        for n in study.noise_laws:
            jobs[("noise", k, n)] = (job_noise_posterior, (fit, n, seed, *sampler))
    for k in study.low_field_blocks:
        fit = lsq[("lsq", k, LOW_FIELD_LAW)]
        jobs[("cv", k)] = (job.job_cv, (fit, seed, s["cv_starts"]))
    done = runner.run(jobs, "small-signal study: posteriors")
    return {
        "lsq": lsq,
        **{
            kind: {k[1:]: v for k, v in done.items() if k[0] == kind}
            for kind in ("noise", "low_field", "cv")
        },
    }


def study_record(results: dict, study: StudySettings, done: dict) -> dict:
    """The study's record (``small_signal_evidence`` of ``results.json``) from
    :func:`run_study`'s output and the report's own fits.

    ``noise``: per block, its law and one entry per noise law (:func:`posterior_summary`).
    ``low_field``: per block, :data:`LOW_FIELD_LAW`'s least-squares AICc, RMS and held-out
    RMS and its posterior, beside :data:`BASE_LAW`'s from the report (its AICc, RMS,
    cross-validation and its posterior's evidence and RMS), and the block's rows every law of
    the report misses most (:func:`worst_rows`)."""
    noise = []
    for k in study.noise_blocks:
        law = _best_law(results, k)
        noise.append(
            {
                "block": k,
                "law": law,
                "lsq_rms_complex": float(done["lsq"][("lsq", k, law)].metrics["rms_complex"]),
                "runs": {n: done["noise"][(k, n)] for n in study.noise_laws},
            }
        )
    low = []
    for k in study.low_field_blocks:
        fit = done["lsq"][("lsq", k, LOW_FIELD_LAW)]
        block = results["blocks"][k]
        base = next(r for r in block["ranking_lsq"] if r["model"] == BASE_LAW)
        base_post = next(r for r in block["ranking_posterior"] if r["model"] == BASE_LAW)
        low.append(
            {
                "block": k,
                "law": LOW_FIELD_LAW,
                "base": BASE_LAW,
                "n_points": int(base["n_points"]),
                "lsq": {
                    "aicc": float(fit.metrics["aicc"]),
                    "rms_complex": float(fit.metrics["rms_complex"]),
                    "n_params": int(fit.metrics["n_params"]),
                    "cv_rms_complex": float(done["cv"][(k,)]["cv_rms_complex"]),
                },
                "base_lsq": {
                    "aicc": base["aicc"],
                    "rms_complex": base["rms_complex"],
                    "n_params": base["n_params"],
                    "cv_rms_complex": base["cv_rms_complex"],
                },
                "posterior": done["low_field"][(k,)],
                "worst_rows": worst_rows(block, fit),
                "base_posterior": {
                    "log_evidence": base_post["log_evidence"],
                    "log_evidence_error": base_post["log_evidence_error"],
                    "rms_complex": base_post["rms_complex"],
                },
            }
        )
    return {"settings": asdict(study), "noise": noise, "low_field": low}


#: The columns that name a row in the report's ``where_models_fail`` and a fit's residuals.
_ROW = ("table", "source_impedance_ohm", "frequency_hz", "input_v")


def worst_rows(block: dict, fit) -> list[dict]:
    """The rows of the report's block record every law misses most (``where_models_fail``):
    each reading, the smallest miss of the report's laws, ``fit``'s miss, and the reading's
    distance outside the readings a passive core gives behind the fitted circuit
    (:func:`fitdf.inference.small_signal.passive_distance`, at ``fit``'s gain)."""
    misses = {
        tuple(r[c] for c in _ROW): r["complex_residual"]
        for r in fit.residuals.to_dict(orient="records")
    }
    gain = fit.values["gain"]
    out = []
    for row in block["where_models_fail"]["rows"]:
        out.append(
            {
                **{c: row[c] for c in _ROW},
                "df_measured": row["df_measured"],
                "lead_measured_deg": row["phase_lead_measured_deg"],
                "report_miss": row["smallest_complex_residual"],
                "report_law": row["closest_model"],
                "miss": float(misses[tuple(row[c] for c in _ROW)]),
                "passive_distance": float(
                    passive_distance(row["df_measured"], row["phase_lead_measured_deg"], gain)
                ),
            }
        )
    return out


def _cache(results: dict, study: StudySettings) -> JobCache:
    """The study's job cache: its salt names the report's settings and seed, the study's
    settings, the machine, fitdf's code and the bundled data (:func:`fitdf.jobcache.run_salt`)."""
    salt = run_salt(
        {"settings": results["settings"], "seed": results["seed"], "study": asdict(study)},
        (Path(__file__).resolve().parents[1], Path(str(data_dir()))),
        ("arviz", "xarray"),
    )
    return JobCache(default_cache_folder(), salt)


def add_study(
    folder, study: StudySettings | None = None, workers=None, progress=True, cache=True
) -> dict:
    """Run the study on the report in ``folder`` and write it there: ``results.json`` gains
    ``small_signal_evidence`` (with its ``timing``) and the claims made from it, and
    ``README.md``, ``index.html`` and ``costs.json`` are rendered again (nothing is refitted
    but the study's own jobs). Returns the record."""
    folder = Path(folder)
    study = study or StudySettings()
    results = read_results(folder)
    check_study(results, study)
    start = time.perf_counter()
    with Executor(
        workers or os.cpu_count() or 1,
        None,
        progress,
        cache=_cache(results, study) if cache else None,
    ) as runner:
        done = run_study(results, study, runner)
    record = study_record(results, study, done)
    record["timing"] = {
        "jobs_s": dict(runner.seconds),
        "reused_jobs": list(runner.reused),
        "total_s": time.perf_counter() - start,
        "workers": runner.workers,
        "machine": machine_record(),
    }
    write_study(folder, results, record)
    return record


def write_study(folder, results: dict, record: dict) -> None:
    """``record`` into the report ``results`` of ``folder`` as ``small_signal_evidence``, its
    claims made, and the report's files written again (each whole or not at all)."""
    results["small_signal_evidence"] = record
    results.update(report_words(results))
    write_outputs(results, Path(folder))


def main(argv=None) -> int:
    """``python -m fitdf.report.small_signal_study REPORT``: add the small-signal study to the
    report in the folder ``REPORT``."""
    parser = argparse.ArgumentParser(
        prog="python -m fitdf.report.small_signal_study", description=main.__doc__
    )
    parser.add_argument("report", type=Path, help="the report's folder (reports)")
    parser.add_argument("--noise-blocks", nargs="+", default=list(StudySettings.noise_blocks))
    parser.add_argument(
        "--low-field-blocks", nargs="+", default=list(StudySettings.low_field_blocks)
    )
    parser.add_argument(
        "--workers", type=int, default=None, help="worker processes (default: the cores)"
    )
    parser.add_argument("--no-cache", action="store_true", help="compute every job, keep none")
    args = parser.parse_args(argv)
    study = StudySettings(tuple(args.noise_blocks), NOISE_LAWS, tuple(args.low_field_blocks))
    try:
        record = add_study(args.report, study, args.workers, cache=not args.no_cache)
    except (FitdfError, FileNotFoundError) as e:
        print(f"small-signal study: {e}", file=sys.stderr)
        return 2
    print(
        f"{args.report}: small-signal study in {record['timing']['total_s']:.0f} s "
        f"({len(record['noise'])} noise blocks, {len(record['low_field'])} low-field blocks)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
