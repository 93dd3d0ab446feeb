"""What a report run costs: each job's expected seconds, from the committed report's timings;
the run's phases as planned before it starts; and the lines that open it.

Expected seconds
    ``committed_costs.json`` (beside this module, read into :data:`COMMITTED`) holds every
    job of the committed report as it ran there (``jobs_s``: the seconds each job took), on
    its machine (``run``), with the settings that set what a job costs (``settings``); a
    posterior job that sampled its prior's sensitivity too is entered at its posterior's
    seconds, its boxes' beside it (``sensitivity_s``; :func:`cost_record`). A job the table lacks -- another law, block or
    cross-impedance direction -- is expected to cost the mean of the table's jobs of its kind
    on its block (or direction), else of its kind. The report's progress display scales these
    by what this machine measures as jobs finish (:mod:`fitdf.report.progress`).
The file, and refreshing it
    Every report run writes the same record of its own jobs into its folder as
    ``costs.json`` (:func:`cost_record`). After the committed report is regenerated, the
    package's copy is refreshed from it with ``python -m fitdf.report.refresh_costs reports``
    (:mod:`fitdf.report.refresh_costs`); tests/test_progress.py says when it is out of date.
Jobs not known yet
    The second phase's jobs depend on the least-squares ranking (posteriors, cross-validation
    and cross-impedance for each block's best laws): :func:`unknown_laws` plans ``n`` of them
    with the committed report's jobs of that kind on that block. Which laws get posteriors
    depends on their AICc gaps too (:func:`fitdf.report.settings.posterior_laws`): the plan
    takes them from the committed report's least-squares AICc (``aicc``: the same rows,
    starts and seed give the same fits), of the laws it ranked.
"""

from __future__ import annotations

import json
import statistics
from pathlib import Path

from fitdf.inference.evidence import SAMPLED_FACTORS
from fitdf.plots.thesis_graphs import THESIS_GRAPHS
from fitdf.report.document import box_factors
from fitdf.report.progress import Phase, duration_text, schedule_length
from fitdf.report.settings import posterior_laws
from fitdf.report.upgrade import upgrade

__all__ = [
    "COMMITTED",
    "COMMITTED_RUN",
    "COMMITTED_SETTINGS",
    "COMMITTED_AICC",
    "COST_SETTINGS",
    "expected_seconds",
    "job_kind",
    "unknown_laws",
    "planned_posteriors",
    "plan",
    "phase_labels",
    "estimate",
    "rough",
    "cost_record",
    "start_line",
]

#: The package's copy of the committed report's ``costs.json`` (:func:`cost_record`).
COMMITTED_FILE = Path(__file__).with_name("committed_costs.json")

#: The settings that set what a job costs (another value: another cost).
COST_SETTINGS = (
    "n_starts",
    "n_steps",
    "max_steps",
    "extend_steps",
    "closed_form_step_factor",
    "n_walkers",
    "cv_starts",
    "chain",
    "approximate_chain",
    "approximate_screen",
    "sampler",
    "nested_live",
    "nested_networks",
    "nested_max_evaluations",
)

#: The committed report's costs: ``{"run": ..., "settings": ..., "jobs_s": ...}``.
COMMITTED = json.loads(COMMITTED_FILE.read_text(encoding="utf-8"))
#: Where the committed report's job times were measured, and what it took in all.
COMMITTED_RUN = COMMITTED["run"]
#: The committed report's settings that set its jobs' costs (:data:`COST_SETTINGS`).
COMMITTED_SETTINGS = COMMITTED["settings"]
#: The committed report's least-squares AICc of each law on each block, best first.
COMMITTED_AICC = COMMITTED.get("aicc") or {}

#: First words of the keys of the jobs that are not least-squares fits.
_KINDS = (
    "mcmc",
    "nested",
    "cv",
    "approx",
    "dynamic",
    "printed",
    "cross",
    "limit",
    "block",
    "thesis",
)
#: Kinds of job the committed report may not have run yet, expected to cost this many times
#: a least-squares fit on their block until it has: a refit with rate-dependent losses (the
#: dynamic chain's 1.3-2.3x a step, from a few starts, and its cross-validation) and a fit to
#: the rows as printed (a least-squares fit like the block's own); an emcee chain and a refit
#: through the approximate chain (as the last report that ran them measured: 21 chains,
#: 39x, and 56 winding refits, 0.38x the least-squares fits of their blocks).
_DERIVED = {"dynamic": 6.0, "printed": 1.0, "nested": 40.0, "mcmc": 39.0, "approx": 0.38}


def _words(key) -> tuple:
    return tuple(str(k) for k in (key if isinstance(key, tuple) else str(key).split()))


def job_kind(key) -> str:
    """The kind of a report job: ``lsq``, ``nested`` or ``mcmc`` (a posterior by nested sampling
    or emcee), ``cv``, ``approx``, ``dynamic``, ``printed``, ``cross``, ``limit`` or
    ``figures`` (a block's, a cross-impedance direction's or the thesis graphs')."""
    w = _words(key)
    if w[0] in ("block", "thesis") or (w[0] == "cross" and len(w) == 4):
        return "figures"
    return w[0] if w[0] in _KINDS else "lsq"


def _group(key) -> str:
    """The block (or cross-impedance direction) of a job; empty for the others."""
    w = _words(key)
    kind = job_kind(w)
    if kind == "lsq":
        return w[0]
    if kind in ("mcmc", "nested", "cv", "approx", "dynamic", "printed"):
        return w[1]
    if kind == "cross":
        return " ".join(w[1:4])
    return ""


#: Seconds of each job of the committed report, by its key joined by spaces.
_SECONDS = {key: float(s) for key, s in COMMITTED["jobs_s"].items()}


def _mean(kind: str, group: str) -> float:
    """Mean seconds of the table's jobs of ``kind`` on ``group``, else of ``kind``, else 1."""
    same = [s for k, s in _SECONDS.items() if job_kind(k) == kind]
    closer = [s for k, s in _SECONDS.items() if job_kind(k) == kind and _group(k) == group]
    if not same and kind in _DERIVED:
        return _DERIVED[kind] * _mean("lsq", group)
    return statistics.fmean(closer or same or [1.0])


#: Seconds the committed report's posterior jobs spent sampling their prior's boxes again.
_SENSITIVITY_SECONDS = {key: float(s) for key, s in (COMMITTED.get("sensitivity_s") or {}).items()}


def _box_seconds(name: str | None, posterior_s: float) -> float:
    """Seconds a posterior's prior boxes are expected to take beside its own ``posterior_s``:
    the committed report's for that job, else its posteriors' ratio of the two, else one more
    posterior per sampled box."""
    if name in _SENSITIVITY_SECONDS:
        return _SENSITIVITY_SECONDS[name]
    pairs = [(s, _SECONDS[k]) for k, s in _SENSITIVITY_SECONDS.items() if _SECONDS.get(k)]
    if pairs:
        return posterior_s * sum(b for b, _ in pairs) / sum(p for _, p in pairs)
    return posterior_s * len(SAMPLED_FACTORS)


def expected_seconds(key) -> float:
    """Seconds a job is expected to take on the committed report's machine.

    Parameters
    ----------
    key : tuple or str
        The job's key as the report runs it (``("B.1", "preisach")``, ``("mcmc", "B.5",
        "cubic_hc")``, ``("block", "B.1")``, ...) or joined by spaces.

    Examples
    --------
    >>> expected_seconds(("mcmc", "B.5", "preisach")) > expected_seconds(("B.5", "preisach"))
    True
    """
    name = " ".join(_words(key))
    if name in _SECONDS:
        return _SECONDS[name]
    return _mean(job_kind(key), _group(key))


def unknown_laws(kind: str, group: str, n: int) -> list[tuple[str, float]]:
    """``(kind, seconds)`` of ``n`` jobs of ``kind`` on ``group`` whose laws are not known yet:
    the committed report's own jobs there when it ran ``n`` of them, else ``n`` times their mean
    (longest first, as the report submits them)."""
    own = sorted(
        (s for k, s in _SECONDS.items() if job_kind(k) == kind and _group(k) == group),
        reverse=True,
    )
    seconds = own if len(own) == n else [_mean(kind, group)] * n
    return [(kind, s) for s in seconds]


def phase_labels(settings) -> tuple[str, str, str]:
    """What each phase of a run computes, naming only what ``settings`` compute: least
    squares; then MCMC, cross-validation, the refits through the approximate chain,
    cross-impedance and limit cycles, as far as they run; then the figures.

    ``settings``: a :class:`~fitdf.report.settings.ReportSettings` or its record in
    ``results.json`` (``results["settings"]``).
    """

    def get(name):
        return settings.get(name) if isinstance(settings, dict) else getattr(settings, name)

    approx = get("approximate_chain")
    second = [
        name
        for name, runs in (
            (
                "nested sampling" if get("sampler") == "nested" else "MCMC",
                "posterior" in (get("methods") or ()) and get("posterior_top") != 0,
            ),
            ("cross-validation", get("cv_top") != 0),
            (f"{approx} refits", bool(approx)),
            ("rate-dependent refits", bool(get("dynamic_chain")) and get("dynamic_top") != 0),
            ("cross-impedance", bool(get("cross")) and get("cross_top") != 0),
            ("limit cycles", bool(get("limit_cycles"))),
        )
        if runs
    ]
    return "least squares", ", ".join(second) or "nothing more", "figures"


#: The order in which the report submits its second phase's kinds of job (long ones first).
SECOND_PHASE_ORDER = ("limit", "nested", "mcmc", "dynamic", "approx", "cv", "printed", "cross")


def _top(n, count: int) -> int:
    """How many of ``count`` laws "the best ``n``" takes (None: all)."""
    return count if n is None else min(max(int(n), 0), count)


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def plan(settings, models, blocks, lsq_keys, folds, labels, printed=()) -> tuple[list, list]:
    """The phases of a report run as planned before it starts, and what it computes.

    Parameters
    ----------
    settings : ReportSettings
        The run's settings (:class:`fitdf.report.settings.ReportSettings`).
    models, blocks : list of str
        The laws and the block keys fitted.
    lsq_keys : list of tuple
        The least-squares jobs in the order they are submitted.
    folds : dict
        Block key -> its cross-validation folds (frequencies per source impedance).
    labels : sequence of str
        The labels of the three phases (:func:`phase_labels`); a second phase without jobs
        is left out.
    printed : sequence of str
        The blocks whose rows as printed differ from the default rows (a reversed column):
        their best ``printed_top`` laws are fitted to those too.

    Returns
    -------
    phases : list of Phase
    what : list of str
        What the run computes, for :func:`start_line`.
    """
    n = _counts(settings, models)
    kind = "nested" if settings.sampler == "nested" else "mcmc"
    posterior = [
        b
        for b in blocks
        if settings.posterior_blocks in (None, ()) or b in settings.posterior_blocks
    ]
    n["sens"] = min(settings.sensitivity_top, n["sampled"]) if kind == "nested" else 0
    n["laws"] = {b: planned_posteriors(settings, models, b) for b in posterior}
    cross = list(settings.cross) if n["cross"] else []
    second = _second_phase_jobs(settings, models, blocks, n, kind, posterior, printed, cross)
    cross_figures = [("cross", c, tr, te) for c, tr, te, train, _ in cross if train in blocks]
    figures = [("block", b) for b in blocks] + cross_figures + [("thesis",)]
    phases = [Phase(labels[0], tuple((job_kind(k), expected_seconds(k)) for k in lsq_keys))]
    if second:
        phases.append(Phase(labels[1], tuple(second)))
    phases.append(Phase(labels[2], tuple((job_kind(k), expected_seconds(k)) for k in figures)))
    what = _what(settings, models, blocks, lsq_keys, folds, n, kind, posterior, cross)
    n_figures = (
        3 * len(blocks)  # DF fits, loci, residuals
        + (len(posterior) if n["sampled"] else 0)  # a corner plot of a converged posterior
        + len(cross_figures)
        + len(THESIS_GRAPHS)
        + int(settings.limit_cycles)
        + 1  # the summary
    )
    what.append(f"{'up to ' if n['sampled'] and posterior else ''}{n_figures} figures")
    return phases, what


def _counts(settings, models) -> dict:
    """How many laws of each block :func:`plan` gives each kind of job: ``sampled``
    (posteriors), ``cv``, ``cross`` (per direction), ``dynamic`` and ``printed``."""
    sampled = [m for m in models if m not in settings.posterior_skip]
    dynamic = [m for m in models if m not in settings.dynamic_skip]
    return {
        "sampled": _top(
            settings.posterior_top if "posterior" in settings.methods else 0, len(sampled)
        ),
        "cv": _top(settings.cv_top, len(models)),
        "cross": _top(settings.cross_top, len(models)),
        "dynamic": _top(settings.dynamic_top, len(dynamic)) if settings.dynamic_chain else 0,
        "printed": _top(settings.printed_top, len(models)),
    }


def planned_posteriors(settings, models, block: str) -> list[str] | int:
    """The laws whose posteriors a run of ``settings`` is planned to sample on ``block``: those
    :func:`~fitdf.report.settings.posterior_laws` picks from the committed report's AICc
    (:data:`COMMITTED_AICC`) of the laws of ``models`` it ranked; where it ranked none of
    them, the number of laws ``posterior_top`` takes.

    Examples
    --------
    >>> from fitdf.report.settings import ReportSettings
    >>> laws = ["preisach", "jiles_atherton", "cubic_hc", "rayleigh"]
    >>> planned_posteriors(ReportSettings.for_run(full=True), laws, "B.4")
    ['preisach', 'jiles_atherton', 'cubic_hc']
    >>> planned_posteriors(ReportSettings.for_run(), laws, "deltamax-joint")
    ['preisach']
    """
    known = {m: a for m, a in COMMITTED_AICC.get(block, {}).items() if m in models}
    if not known:
        return _counts(settings, models)["sampled"]
    return posterior_laws(settings, block, known)


def _second_phase_jobs(settings, models, blocks, n, kind, posterior, printed, cross) -> list:
    """The second phase's ``(kind, expected seconds)`` jobs of :func:`plan`, in the order the
    run submits them (``n``: :func:`_counts` with ``sens`` and the posteriors' ``laws`` by
    block, :func:`planned_posteriors`)."""
    second = [("limit", expected_seconds(("limit",)))] if settings.limit_cycles else []
    for b in blocks:
        laws = n["laws"].get(b, 0)
        posteriors = (
            [(kind, expected_seconds((kind, b, m))) for m in laws]
            if isinstance(laws, list)
            else unknown_laws(kind, b, laws)
        )
        # a posterior with the prior's sensitivity samples once more (the box doubled; the
        # halved box is restricted from its draws) in the same job
        keys = [" ".join((kind, b, m)) for m in laws] if isinstance(laws, list) else []
        posteriors = [
            (k, s + (i < n["sens"]) * _box_seconds(keys[i] if keys else None, s))
            for i, (k, s) in enumerate(posteriors)
        ]
        second += posteriors + unknown_laws("cv", b, n["cv"])
        if settings.approximate_chain:
            second += [("approx", expected_seconds(("approx", b, m))) for m in models]
        second += unknown_laws("dynamic", b, n["dynamic"])
    for b in printed:
        second += unknown_laws("printed", b, n["printed"])
    for core, train, test, *_ in cross:
        second += unknown_laws("cross", f"{core} {train} {test}", n["cross"])
    second.sort(key=lambda job: (SECOND_PHASE_ORDER.index(job[0]), -job[1]))
    return second


def _what(settings, models, blocks, lsq_keys, folds, n, kind, posterior, cross) -> list:
    """What :func:`plan`'s run computes, but for its figures (``n``: :func:`_counts`)."""
    what = [
        f"{_plural(len(lsq_keys), 'least-squares fit')} ({_plural(len(models), 'law')} on "
        f"{_plural(len(blocks), 'block')})"
    ]
    counts = [len(v) if isinstance(v, list) else v for v in n["laws"].values()]
    if n["sampled"] and sum(counts):
        n_sens = sum(min(settings.sensitivity_top, c) for c in counts)
        below = settings.posterior_runner_up_below
        what.append(
            _plural(sum(counts), "posterior")
            + (" and evidence (nested sampling" if kind == "nested" else " (MCMC")
            + (
                f"; a runner-up's only where its AICc is within {below:g} of the best's)"
                if below is not None and n["sampled"] > 1
                else ")"
            )
            + (
                f", {_plural(n_sens, 'evidence')} again with the prior box {box_factors()}"
                if kind == "nested" and settings.sensitivity_top
                else ""
            )
        )
    if n["cv"]:
        n_folds = n["cv"] * sum(folds.get(b, 0) for b in blocks)
        what.append(
            f"{_plural(n['cv'] * len(blocks), 'cross-validation')} "
            f"({_plural(n_folds, 'leave-one-frequency-out fold')})"
        )
    if settings.approximate_chain:
        what.append(
            f"{_plural(len(models) * len(blocks), 'refit')} through the "
            f"{settings.approximate_chain} chain"
        )
    if n["dynamic"]:
        what.append(
            f"{_plural(n['dynamic'] * len(blocks), 'refit')} with rate-dependent losses "
            f"(the {settings.dynamic_chain} chain)"
        )
    if cross:
        what.append(_plural(n["cross"] * len(cross), "cross-impedance prediction"))
    if settings.limit_cycles:
        what.append("the limit-cycle comparison (Tables 5.1, 5.2)")
    return what


def estimate(phases, workers: int) -> float:
    """Seconds the ``phases`` take on ``workers`` workers at the committed machine's speed."""
    return sum(schedule_length((s for _, s in p.planned), workers) for p in phases)


def rough(settings) -> bool:
    """Whether ``settings`` change what a job costs from the committed report's."""
    return any(getattr(settings, k) != COMMITTED_SETTINGS.get(k) for k in COST_SETTINGS)


def _sampled_boxes(results: dict, key: str) -> list[dict]:
    """The prior boxes a report's posterior job sampled again (not those restricted from its
    draws); none for another job."""
    w = key.split()
    if w[0] != "nested":
        return []
    fits = results["blocks"].get(w[1], {}).get("fits_posterior", {})
    fit = fits.get(" ".join(w[2:]), {})
    boxes = ((fit.get("diagnostics") or {}).get("prior_sensitivity") or {}).get("boxes") or []
    return [b for b in boxes if b.get("estimate", "sampled") != "restricted"]


def _split_seconds(results: dict, key: str, seconds: float) -> tuple[float, float | None]:
    """A job's seconds as ``(posterior's, its prior boxes')``: the boxes' from their runs'
    recorded seconds; for a record without them, the job's seconds shared equally among its
    runs (the boxes' then None)."""
    boxes = _sampled_boxes(results, key)
    if not boxes:
        return seconds, None
    if all(b.get("seconds") is not None for b in boxes):
        sens = sum(float(b["seconds"]) for b in boxes)
        return max(seconds - sens, 0.0), sens
    return seconds / (1 + len(boxes)), None


def cost_record(results: dict, known: dict | None = None) -> dict:
    """What a report's jobs cost, from its results record (``results.json``): the record
    ``costs.json`` holds and :data:`COMMITTED` is.

    ``run``: the CPU, its cores (``timing.cores``), the workers, the total seconds and the
    command that made the report (``run.command``); a record written before one of these
    fields existed takes it from ``known`` (a ``run`` record, such as :data:`COMMITTED_RUN`),
    else None. ``settings``: those of
    :data:`COST_SETTINGS`; ``jobs_s``: the seconds of each job (``timing.jobs_s``), a
    posterior job that also sampled its prior's box again (doubled, and halved where the
    posterior's draws could not give it) at its seconds less its boxes' runs, so that every
    ``nested`` entry is one posterior's seconds; ``sensitivity_s``: those boxes' seconds, by
    job (a record whose boxes lack their seconds shares the job's equally among its runs
    and has none: the plan then counts each box as one more posterior);
    ``aicc``: each block's least-squares AICc of each law, best first (``ranking_lsq``), from
    which the plan tells which laws a run samples (:func:`planned_posteriors`).
    """
    results = upgrade(results)
    timing = results["timing"]
    jobs = timing["jobs_s"]
    split = {k: _split_seconds(results, k, s) for k, s in jobs.items()}
    run = {
        "cpu": timing["machine"]["cpu"],
        "cores": timing.get("cores"),
        "workers": timing["workers"],
        "total_s": round(timing["total_s"]),
        "command": (results.get("run") or {}).get("command"),
    }
    return {
        "run": {k: (known or {}).get(k) if v is None else v for k, v in run.items()},
        "settings": {k: results["settings"].get(k) for k in COST_SETTINGS},
        "jobs_s": {k: round(split[k][0], 2) for k in jobs},
        "sensitivity_s": {k: round(b, 2) for k, (_, b) in split.items() if b is not None},
        "aicc": {
            key: {row["model"]: row["aicc"] for row in block.get("ranking_lsq") or []}
            for key, block in results["blocks"].items()
        },
    }


def start_line(what: list[str], estimate_s: float, workers: int, *, rough=False, cached=False):
    """The lines that open a run: what it computes, and about how long it takes.

    Parameters
    ----------
    what : list of str
        What the run computes, in order (``"56 least-squares fits (8 laws on 7 blocks)"``).
    estimate_s : float
        Its length at the committed machine's speed with ``workers`` workers.
    rough : bool
        The settings differ from the committed report's: its job times are a rough guide.
    cached : bool
        A job cache is in use: jobs an earlier run kept are read, not run.
    """
    run = COMMITTED_RUN
    listed = f"{', '.join(what[:-1])} and {what[-1]}" if len(what) > 1 else what[0]
    text = f"fitdf report: {listed}.\n"
    text += (
        f"About {duration_text(estimate_s)} with {workers} worker"
        f"{'s' if workers != 1 else ''} at the speed of the machine the committed report was "
        f"made on ({run['workers']} workers on {run['cores']} {run['cpu']} cores, "
        f"{duration_text(run['total_s'])} for `{run['command']}`)"
    )
    if rough:
        text += (
            "; these settings differ from that report's, so its job times are a rough guide "
            "until jobs of each kind have run here"
        )
    if cached:
        text += "; less for the jobs an earlier run kept in the cache"
    return text + ". This machine's estimate follows as the first jobs finish."
