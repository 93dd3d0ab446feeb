"""What a report run costs: each job's expected seconds, from the committed report's timings;
the run's phases as planned before it starts; and the lines that open it.

Expected seconds
    :data:`_TABLE` holds every job of the committed report (``reports/results.json``,
    ``timing.jobs_s``: the seconds each job took) as it ran there, on
    :data:`COMMITTED_RUN`'s machine; a posterior job that sampled its prior's sensitivity
    too is entered as one of the runs it sampled (:func:`table_text`). A job the table lacks --
    another law, block or cross-impedance direction -- is expected to cost the mean of the table's jobs of its kind on
    its block (or direction), else of its kind. The report's progress display scales these by
    what this machine measures as jobs finish (:mod:`fitdf.report.progress`). After the
    committed report is regenerated, refresh the table and :data:`COMMITTED_RUN` with
    :func:`table_text` (tests/test_progress.py says when they are out of date).
Jobs not known yet
    The second phase's jobs depend on the least-squares ranking (MCMC, cross-validation and
    cross-impedance for each block's best laws): :func:`unknown_laws` plans ``n`` of them
    with the committed report's jobs of that kind on that block.
"""

from __future__ import annotations

import statistics

from fitdf.inference.evidence import SAMPLED_FACTORS
from fitdf.plots.thesis import THESIS_GRAPHS
from fitdf.report.progress import Phase, duration_text, schedule_length

__all__ = [
    "COMMITTED_RUN",
    "COMMITTED_SETTINGS",
    "expected_seconds",
    "job_kind",
    "unknown_laws",
    "plan",
    "phase_labels",
    "estimate",
    "rough",
    "table_text",
    "start_line",
]

#: The committed report's run: where its job times were measured, and what it took in all.
COMMITTED_RUN = {
    "cpu": "Intel(R) Xeon(R) Processor",
    "cores": 2,
    "workers": 2,
    "total_s": 4446,
    "command": "fitdf report --full",
}

#: The committed report's settings that set its jobs' costs (another value: another cost).
COMMITTED_SETTINGS = {
    "n_starts": 6,
    "n_steps": 300,
    "max_steps": 4000,
    "extend_steps": 6000,
    "closed_form_step_factor": 3,
    "n_walkers": None,
    "cv_starts": None,
    "chain": "voltage",
    "approximate_chain": None,
    "approximate_screen": 1,
    "sampler": "nested",
    "nested_live": 300,
    "nested_networks": 1,
    "nested_max_evaluations": 100000,
}

#: Seconds of each job of the committed report, under its key joined by spaces
#: (:func:`table_text` of its results.json).
_TABLE = """
deltamax-joint jiles_atherton            7.8
B.5 jiles_atherton                       9.47
permalloy-joint jiles_atherton           4.51
B.4 jiles_atherton                       3.72
deltamax-joint preisach                  16.81
B.5 preisach                             15.29
deltamax-joint cubic_hc                  26.35
B.1 jiles_atherton                       2.34
permalloy-joint preisach                 7.93
B.3 jiles_atherton                       2.46
B.4 preisach                             6.49
B.2 jiles_atherton                       3.21
B.5 cubic_hc                             27.8
deltamax-joint rayleigh                  4.35
permalloy-joint cubic_hc                 19.08
B.4 cubic_hc                             18.13
deltamax-joint constant_width            3.27
B.5 rayleigh                             3.07
B.1 preisach                             6.43
B.3 preisach                             3.53
permalloy-joint rayleigh                 2.18
B.2 preisach                             9.33
deltamax-joint frequency_hc              5.22
B.5 constant_width                       4.98
B.4 rayleigh                             1.99
B.1 cubic_hc                             11.46
permalloy-joint constant_width           1.6
B.3 cubic_hc                             12.27
B.5 frequency_hc                         3.59
B.4 constant_width                       2.84
B.2 cubic_hc                             11.93
deltamax-joint proportional_width        5.15
deltamax-joint proportional_width_fig42  6.17
permalloy-joint frequency_hc             3.82
B.4 frequency_hc                         2.52
B.1 rayleigh                             0.89
B.3 rayleigh                             1.29
B.5 proportional_width                   3.37
B.5 proportional_width_fig42             3.99
B.2 rayleigh                             0.89
B.1 constant_width                       0.96
permalloy-joint proportional_width       3.15
permalloy-joint proportional_width_fig42 3.11
B.3 constant_width                       1.74
B.4 proportional_width                   2.37
B.4 proportional_width_fig42             3.5
B.2 constant_width                       1.55
B.1 frequency_hc                         1.63
B.3 frequency_hc                         1.8
B.2 frequency_hc                         2.21
B.1 proportional_width                   2.32
B.1 proportional_width_fig42             2.15
B.3 proportional_width                   1.62
B.3 proportional_width_fig42             2.37
B.2 proportional_width                   1.9
B.2 proportional_width_fig42             1.15
limit                                    41.04
nested permalloy-joint jiles_atherton    215.64
nested B.4 jiles_atherton                165.31
nested deltamax-joint preisach           618.36
nested B.5 preisach                      444.9
nested deltamax-joint cubic_hc           455.85
nested B.1 jiles_atherton                108.67
nested permalloy-joint preisach          362.98
nested B.3 jiles_atherton                93.21
nested B.4 preisach                      270
nested B.2 jiles_atherton                93.31
nested B.5 cubic_hc                      320.62
nested B.4 cubic_hc                      113.76
nested deltamax-joint constant_width     99.6
nested B.1 preisach                      208.22
nested B.3 preisach                      172.79
nested B.2 preisach                      180.53
nested B.5 constant_width                63.74
nested permalloy-joint constant_width    102.51
nested B.2 cubic_hc                      120.38
nested B.1 rayleigh                      42.37
nested B.3 constant_width                37.64
dynamic permalloy-joint jiles_atherton   12.7
dynamic B.4 jiles_atherton               9.57
dynamic deltamax-joint preisach          45.4
dynamic B.5 preisach                     25.54
dynamic deltamax-joint cubic_hc          26.75
dynamic B.1 jiles_atherton               4.81
dynamic permalloy-joint preisach         19.48
dynamic B.3 jiles_atherton               4.12
dynamic B.4 preisach                     12.19
dynamic B.2 jiles_atherton               4.06
dynamic B.5 cubic_hc                     13.07
dynamic B.1 preisach                     8.04
dynamic B.3 preisach                     5.63
dynamic B.2 preisach                     5.2
cv permalloy-joint jiles_atherton        4.14
cv B.4 jiles_atherton                    2.33
cv deltamax-joint preisach               13.1
cv B.5 preisach                          9.58
cv deltamax-joint cubic_hc               5.87
cv B.1 jiles_atherton                    1.4
cv permalloy-joint preisach              7.66
cv B.3 jiles_atherton                    0.95
cv B.4 preisach                          3.7
cv B.2 jiles_atherton                    1.29
cv B.5 cubic_hc                          4.75
cv B.1 preisach                          4.76
cv B.3 preisach                          1.41
cv B.2 preisach                          2.01
printed B.5 preisach                     12.44
printed B.5 cubic_hc                     24.08
printed deltamax-joint preisach          14.51
printed deltamax-joint cubic_hc          25.93
cross permalloy 0.0 600.0 preisach       9.56
cross permalloy 0.0 600.0 jiles_atherton 4.74
cross permalloy 600.0 0.0 preisach       8.07
cross permalloy 600.0 0.0 jiles_atherton 5.15
cross deltamax 0.0 600.0 preisach        14.92
cross deltamax 0.0 600.0 jiles_atherton  9.75
cross deltamax 600.0 0.0 preisach        13.6
cross deltamax 600.0 0.0 cubic_hc        21.48
block B.1                                7.25
block B.3                                5.68
block B.2                                6.85
block B.5                                9.69
block B.4                                7.84
block permalloy-joint                    10.59
block deltamax-joint                     13.11
cross permalloy 0.0 600.0                1.32
cross permalloy 600.0 0.0                1.69
cross deltamax 0.0 600.0                 1.89
cross deltamax 600.0 0.0                 1.97
thesis                                   1.47
"""

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
    """The kind of a report job: ``lsq``, ``mcmc``, ``cv``, ``approx``, ``cross``, ``limit`` or
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


def _parse(text: str) -> dict:
    rows = (line.rsplit(None, 1) for line in text.strip().splitlines())
    return {key.strip(): float(s) for key, s in rows}


_SECONDS = _parse(_TABLE)


def _mean(kind: str, group: str) -> float:
    """Mean seconds of the table's jobs of ``kind`` on ``group``, else of ``kind``, else 1."""
    same = [s for k, s in _SECONDS.items() if job_kind(k) == kind]
    closer = [s for k, s in _SECONDS.items() if job_kind(k) == kind and _group(k) == group]
    if not same and kind in _DERIVED:
        return _DERIVED[kind] * _mean("lsq", group)
    return statistics.fmean(closer or same or [1.0])


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

    ``settings``: a :class:`~fitdf.report.build.ReportSettings` or its record in
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
                "mcmc" in (get("methods") or ()) and get("mcmc_top") != 0,
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
        The run's settings (:class:`fitdf.report.build.ReportSettings`).
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
    sampled = [m for m in models if m not in settings.mcmc_skip]
    n_mcmc = _top(settings.mcmc_top if "mcmc" in settings.methods else 0, len(sampled))
    n_cv, n_cross = _top(settings.cv_top, len(models)), _top(settings.cross_top, len(models))
    dynamic = [m for m in models if m not in settings.dynamic_skip]
    n_dynamic = _top(settings.dynamic_top, len(dynamic)) if settings.dynamic_chain else 0
    cross = list(settings.cross) if n_cross else []
    second = [("limit", expected_seconds(("limit",)))] if settings.limit_cycles else []
    kind = "nested" if settings.sampler == "nested" else "mcmc"
    posterior = [
        b
        for b in blocks
        if settings.posterior_blocks in (None, ()) or b in settings.posterior_blocks
    ]
    n_sens = min(settings.sensitivity_top, n_mcmc) if kind == "nested" else 0
    for b in blocks:
        n_post = n_mcmc if b in posterior else 0
        posteriors = unknown_laws(kind, b, n_post)
        # a posterior with the prior's sensitivity samples once more (the box doubled; the
        # halved box is restricted from its draws) in the same job
        posteriors = [(k, s * (1 + len(SAMPLED_FACTORS) * (i < n_sens))) for i, (k, s) in
                      enumerate(posteriors)]  # fmt: skip
        second += posteriors + unknown_laws("cv", b, n_cv)
        if settings.approximate_chain:
            second += [("approx", expected_seconds(("approx", b, m))) for m in models]
        second += unknown_laws("dynamic", b, n_dynamic)
    n_printed = _top(settings.printed_top, len(models))
    for b in printed:
        second += unknown_laws("printed", b, n_printed)
    for core, train, test, *_ in cross:
        second += unknown_laws("cross", f"{core} {train} {test}", n_cross)
    second.sort(key=lambda job: (SECOND_PHASE_ORDER.index(job[0]), -job[1]))
    cross_figures = [("cross", c, tr, te) for c, tr, te, train, _ in cross if train in blocks]
    figures = [("block", b) for b in blocks] + cross_figures + [("thesis",)]
    phases = [Phase(labels[0], tuple((job_kind(k), expected_seconds(k)) for k in lsq_keys))]
    if second:
        phases.append(Phase(labels[1], tuple(second)))
    phases.append(Phase(labels[2], tuple((job_kind(k), expected_seconds(k)) for k in figures)))

    what = [
        f"{_plural(len(lsq_keys), 'least-squares fit')} ({_plural(len(models), 'law')} on "
        f"{_plural(len(blocks), 'block')})"
    ]
    if n_mcmc and posterior:
        what.append(
            _plural(n_mcmc * len(posterior), "posterior")
            + (" and evidence (nested sampling)" if kind == "nested" else " (MCMC)")
            + (
                f", {_plural(min(settings.sensitivity_top, n_mcmc) * len(posterior), 'evidence')}"
                " again with the prior box halved and doubled"
                if kind == "nested" and settings.sensitivity_top
                else ""
            )
        )
    if n_cv:
        n_folds = n_cv * sum(folds.get(b, 0) for b in blocks)
        what.append(
            f"{_plural(n_cv * len(blocks), 'cross-validation')} "
            f"({_plural(n_folds, 'leave-one-frequency-out fold')})"
        )
    if settings.approximate_chain:
        what.append(
            f"{_plural(len(models) * len(blocks), 'refit')} through the "
            f"{settings.approximate_chain} chain"
        )
    if n_dynamic:
        what.append(
            f"{_plural(n_dynamic * len(blocks), 'refit')} with rate-dependent losses "
            f"(the {settings.dynamic_chain} chain)"
        )
    if cross:
        what.append(_plural(n_cross * len(cross), "cross-impedance prediction"))
    if settings.limit_cycles:
        what.append("the limit-cycle comparison (Tables 5.1, 5.2)")
    n_figures = (
        3 * len(blocks)  # DF fits, loci, residuals
        + (len(posterior) if n_mcmc else 0)  # a corner plot of a converged posterior
        + len(cross_figures)
        + len(THESIS_GRAPHS)
        + int(settings.limit_cycles)
        + 1  # the summary
    )
    what.append(f"{'up to ' if n_mcmc and posterior else ''}{n_figures} figures")
    return phases, what


def estimate(phases, workers: int) -> float:
    """Seconds the ``phases`` take on ``workers`` workers at the committed machine's speed."""
    return sum(schedule_length((s for _, s in p.planned), workers) for p in phases)


def rough(settings) -> bool:
    """Whether ``settings`` change what a job costs from the committed report's."""
    return any(getattr(settings, k) != v for k, v in COMMITTED_SETTINGS.items())


def _sampler_runs(results: dict, key: str) -> int:
    """How many times a report job sampled: 1, or for a posterior with its prior's
    sensitivity 1 plus the boxes it sampled again (not those restricted from its draws)."""
    w = key.split()
    if w[0] != "nested":
        return 1
    fit = results["blocks"].get(w[1], {}).get("fits_mcmc", {}).get(" ".join(w[2:]), {})
    boxes = ((fit.get("diagnostics") or {}).get("prior_sensitivity") or {}).get("boxes") or []
    return 1 + sum(b.get("estimate", "sampled") != "restricted" for b in boxes)


def table_text(results: dict) -> str:
    """The text of :data:`_TABLE` for a report's results record (``results.json``).

    A posterior job that also sampled its prior's box again (doubled, and halved where the
    posterior's draws could not give it) is entered at its seconds over its runs (the plan
    multiplies them back for such a job), so that the table holds one posterior's seconds in
    every ``nested`` row.
    """
    jobs = results["timing"]["jobs_s"]
    width = max(map(len, jobs))
    return (
        "\n".join(
            f"{k:<{width}} {round(s / _sampler_runs(results, k), 2):g}" for k, s in jobs.items()
        )
        + "\n"
    )


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
