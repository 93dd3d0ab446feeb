"""What a report computes: its blocks, its settings, and which run of ``fitdf report`` made it.

:class:`ReportSettings` holds every choice of a run (the laws, the blocks, how many of each
block's best laws get a posterior, cross-validation and the rest); :meth:`ReportSettings.for_run`
gives the three runs of ``fitdf report`` (``--quick``, the default, ``--full``), and
:func:`run_record` names the run a report's settings came from. :func:`settings_record` is
the settings as ``results.json`` keeps them.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from fitdf.errors import OptionError
from fitdf.inference.api import DEFAULT_CHAIN
from fitdf.inference.nested import DEFAULT_LIVE, DEFAULT_NETWORKS
from fitdf.models import get_model, model_names

__all__ = [
    "Block",
    "BLOCKS",
    "CROSS_DIRECTIONS",
    "LIMIT_CYCLE_BLOCKS",
    "CORE_BLOCKS",
    "EVIDENCE_SHORTFALL",
    "RUNNER_UP_AICC_GAP",
    "ReportSettings",
    "posterior_laws",
    "RUNS",
    "run_record",
    "settings_record",
    "lost_by",
]


@dataclass(frozen=True)
class Block:
    """One set of rows fitted together."""

    key: str
    data: str  # name for fitdf.datasets.load / fitdf.fit
    core: str
    title: str


#: The blocks of the report: each table alone, and each core at 0 + 600 ohm jointly.
BLOCKS = (
    Block("B.1", "B.1", "permalloy", "Permalloy at 0 ohm (Table B.1)"),
    Block("B.3", "B.3", "permalloy", "Permalloy at 600 ohm (Table B.3)"),
    Block("B.2", "B.2", "deltamax", "Deltamax at 0 ohm (Table B.2)"),
    Block("B.5", "B.5", "deltamax", "Deltamax at 600 ohm (Table B.5)"),
    Block("B.4", "B.4", "supermalloy", "Supermalloy at 600 ohm (Table B.4)"),
    Block(
        "permalloy-joint",
        "permalloy",
        "permalloy",
        "Permalloy at 0 and 600 ohm jointly (Tables B.1 + B.3)",
    ),
    Block(
        "deltamax-joint",
        "deltamax",
        "deltamax",
        "Deltamax at 0 and 600 ohm jointly (Tables B.2 + B.5)",
    ),
)
#: Cross-impedance predictions: (core, train ohm, test ohm, train block, test block).
CROSS_DIRECTIONS = (
    ("permalloy", 0.0, 600.0, "B.1", "B.3"),
    ("permalloy", 600.0, 0.0, "B.3", "B.1"),
    ("deltamax", 0.0, 600.0, "B.2", "B.5"),
    ("deltamax", 600.0, 0.0, "B.5", "B.2"),
)
#: Blocks whose fits the limit-cycle comparison uses (thesis Tables 5.1, 5.2).
LIMIT_CYCLE_BLOCKS = ("B.1", "B.3", "B.2", "B.5")
#: The blocks whose best law the default report samples, one per core: each core measured at
#: both source impedances jointly (Permalloy, Deltamax), and Supermalloy's one table.
CORE_BLOCKS = ("permalloy-joint", "deltamax-joint", "B.4")

#: The most the evidence has favoured the better of two laws *less* than AICc does, in ln
#: units: the largest ``Delta-AICc / 2 - ln B`` over every pair of laws sampled on a block of
#: the committed ``fitdf report --full`` (``reports/results.json``: 21 pairs on 7 blocks,
#: Delta-AICc 23-217, ``ln B`` the difference of their nested-sampling ``log_evidence``),
#: rounded up; it is Permalloy B.3's preisach over constant_width (Delta-AICc 112.9, ln B
#: 41.6). No pair's evidence reversed AICc's order. AICc's ``-AICc / 2`` estimates
#: ``ln Z`` up to the Occam factor, which charges each parameter ``ln(prior width / posterior
#: width)`` where AICc charges it about one: to Laplace's approximation the shortfall is the
#: difference of those charges between the two laws (tests/test_posterior_choice.py
#: recomputes it from the committed report).
EVIDENCE_SHORTFALL = 14.83

#: Delta-AICc (runner-up minus best) below which the default report samples a block's
#: runner-up too: least squares leave the order open there. The evidence reverses AICc's order
#: only where its shortfall (:data:`EVIDENCE_SHORTFALL`) exceeds ``Delta-AICc / 2``, that is
#: below ``2 * EVIDENCE_SHORTFALL`` = 29.7; the threshold doubles that margin
#: (``4 * EVIDENCE_SHORTFALL`` = 59.3, rounded up to 60), so that at or above it a reversal
#: would need the evidence to depart from AICc by twice the most it has been measured to.
RUNNER_UP_AICC_GAP = 60.0


@dataclass(frozen=True)
class ReportSettings:
    """What the report computes. ``ReportSettings.for_run(...)`` gives the three runs' settings.

    Attributes
    ----------
    models : tuple of str or None
        Models to fit (None: every registered model).
    blocks : tuple of str or None
        Keys of :data:`BLOCKS` (None: all).
    methods : tuple
        ``("lsq",)`` or ``("lsq", "posterior")``: least squares only, or also posteriors
        (drawn by ``sampler``).
    n_starts : int
        Least-squares starts (the library default; fewer starts miss optima).
    posterior_top, cv_top, cross_top : int or None
        Posteriors, cross-validation and cross-impedance for the best N least-squares models
        of a block (None: all models; 0: none).
    sampler : {"nested", "emcee"}
        How the posteriors are sampled: nested sampling (the posterior and the evidence,
        :func:`fitdf.inference.nested.fit_nested`; its rule:
        :func:`fitdf.inference.nested.is_converged`) or emcee
        (:func:`fitdf.inference.mcmc.fit_mcmc`).
    nested_live, nested_networks, nested_max_evaluations : int
        Nested sampling's live points, networks per bound, and the evaluations at which a run
        stops unconverged.
    posterior_blocks : tuple of str or None
        The blocks whose best ``posterior_top`` laws get posteriors (None: every block).
    posterior_runner_up_below : float or None
        Of those laws, the best is always sampled and each other one only where its AICc
        exceeds the best's by less than this (:data:`RUNNER_UP_AICC_GAP`: where least squares
        leave the order open); None: the best ``posterior_top`` laws, whatever their gaps
        (:func:`posterior_laws`).
    sensitivity_top : int
        For the best this many sampled laws of each block, the evidence again with the prior
        box halved (about the best fit) and doubled (about its centre): how much the Bayes
        factors depend on the prior (nested sampling only).
    n_steps, max_steps, n_walkers : int
        emcee's (``sampler="emcee"``) production steps at least, at most (the chain is extended until it is
        converged: :func:`fitdf.inference.mcmc.is_converged`) and walkers (None: twice the
        dimensions plus two, the fewest differential evolution allows).
    extend_steps : int or None
        A chain that reaches ``max_steps`` on course for
        :data:`~fitdf.inference.convergence.MIN_STEPS_OVER_TAU` autocorrelation times but is
        short of R-hat or ESS goes on up to this many steps, while that many autocorrelation
        times fit in them (``fit_mcmc(extend_steps=...)``); the chains too slow for ``max_steps``
        still stop at it, or before.
    closed_form_step_factor : int
        ``max_steps`` and ``extend_steps`` are this many times longer for the laws whose
        describing function is in closed form (``HysteresisModel.closed_form``): through the
        exact chain they cost 0.9-3.3 ms per parameter set against Preisach's 3.5-10 ms, so the
        same time buys them more steps. Of those laws only cubic_hc needs them: its kinked
        posterior (the joint ``h1`` between rows) mixes slowly (benchmarks/README.md measures
        the steps it takes); the others converge within the common limits.
    posterior_skip : tuple of str
        Laws left out of the report's posteriors (the best laws *without* them are sampled;
        default none).
    cv_starts : int or None
        Least-squares starts per cross-validation fold (None: polished from the block's
        optimum, :func:`fitdf.inference.ranking.cross_validate`).
    cross : tuple
        Cross-impedance directions (subset of :data:`CROSS_DIRECTIONS`).
    limit_cycles : bool
        Run the Tables 5.1/5.2 limit-cycle comparison when the module is available.
    plot_top : int
        Models drawn in the residual figure; the loci show the best two.
    workers : int
        Local worker processes (1: serial; results are identical).
    scheduler : str or None
        Address of a Dask distributed scheduler (``tcp://host:8786``) to run the jobs on
        instead of local processes (results are identical); None: local.
    chain : str
        The measurement chain of every fit (default: the exact ``voltage`` circuit).
    approximate_chain : str or None
        A second chain every model is also fitted through by least squares, to show how
        far an approximation (``winding``: sinusoidal current) moves the ranking, the
        predictions and the fitted constants; None (the default) skips it
        (``fitdf report --compare-chain winding``).
    approximate_screen : int
        Starts from the usual screen that refit adds to the exact chain's optimum (0: the
        nearest optimum of the approximation only; ``--quick``).
    dynamic_chain : str or None
        The chain with rate-dependent losses (``dynamic``: Bertotti's dynamic fields) the
        best ``dynamic_top`` laws of each block (``dynamic_skip`` aside)
        are refitted through by least squares, ranked beside the static fits by AICc and, with
        ``dynamic_cv``, cross-validation (:mod:`fitdf.report.physics`); None skips them.
    printed_top : int
        On every block whose rows the audit's reversed column changes (the default row
        policy reverses it), the best ``printed_top`` laws are also fitted to the rows as
        printed (policy ``as_printed``), to show both.
    """

    models: tuple | None = None
    blocks: tuple | None = None
    methods: tuple = ("lsq", "posterior")
    n_starts: int = 6
    posterior_top: int | None = 3
    sampler: str = "nested"
    nested_live: int = DEFAULT_LIVE
    nested_networks: int = DEFAULT_NETWORKS
    nested_max_evaluations: int = 100_000
    posterior_blocks: tuple | None = None
    posterior_runner_up_below: float | None = None
    sensitivity_top: int = 0
    n_steps: int = 300
    max_steps: int = 4000
    extend_steps: int | None = 6000
    closed_form_step_factor: int = 3
    n_walkers: int | None = None
    posterior_skip: tuple = ()
    cv_top: int | None = 2
    cv_starts: int | None = None
    cross_top: int | None = 2
    cross: tuple = CROSS_DIRECTIONS
    limit_cycles: bool = True
    plot_top: int = 3
    workers: int = 2
    scheduler: str | None = None
    chain: str = DEFAULT_CHAIN
    approximate_chain: str | None = None
    approximate_screen: int = 1
    dynamic_chain: str | None = "dynamic"
    dynamic_top: int | None = 2
    dynamic_skip: tuple = ()
    dynamic_cv: bool = True
    printed_top: int | None = 2

    @classmethod
    def for_run(
        cls,
        quick: bool = False,
        methods=("lsq", "posterior"),
        *,
        full: bool = False,
        scheduler: str | None = None,
        compare_chain: str | None = None,
    ) -> ReportSettings:
        """The settings of the three runs of ``fitdf report``.

        The default: every law on every block by least squares, cross-validation,
        cross-impedance, limit cycles, the rate-dependent refits, and the posterior and
        evidence of the best law of each core (:data:`CORE_BLOCKS`) by nested sampling, with
        the runner-up's where its AICc is within :data:`RUNNER_UP_AICC_GAP` of the best's
        (where a Bayes factor could plausibly reverse the order).
        ``full``: the posteriors of the best three laws of every block, and the evidence's
        sensitivity to the prior for the best two. ``quick``: least squares only (the same
        models, starts and seeds, so the same rankings), no cross-validation, one law per
        cross-impedance direction and per refit; every section is still produced.
        ``compare_chain``: also refit every law through this approximate chain (``winding``).
        ``scheduler``: run on that Dask cluster (see :class:`ReportSettings`).
        """
        methods = tuple(methods)
        bad = set(methods) - {"lsq", "posterior"}
        if bad or "lsq" not in methods:
            raise OptionError(f"methods must be ('lsq',) or ('lsq', 'posterior'), got {methods}")
        if quick and full:
            raise OptionError("--quick and --full exclude each other")
        common = {"scheduler": scheduler, "approximate_chain": compare_chain}
        if quick:
            return cls(
                methods=("lsq",),
                posterior_top=0,
                cv_top=0,
                cross_top=1,
                approximate_screen=0,
                dynamic_top=1,
                dynamic_cv=False,
                printed_top=1,
                **common,
            )
        sampled = "posterior" in methods
        if full:
            return cls(
                methods=methods, posterior_top=3 if sampled else 0, sensitivity_top=2, **common
            )
        return cls(
            methods=methods,
            posterior_top=2 if sampled else 0,
            posterior_blocks=CORE_BLOCKS,
            posterior_runner_up_below=RUNNER_UP_AICC_GAP,
            **common,
        )

    def step_limits(self, model: str) -> tuple:
        """``(max_steps, extend_steps)`` of ``model``'s chains (``closed_form_step_factor``)."""
        factor = self.closed_form_step_factor if get_model(model).closed_form else 1
        extend = None if self.extend_steps is None else factor * self.extend_steps
        return factor * self.max_steps, extend

    def model_list(self) -> list[str]:
        return list(self.models) if self.models else model_names()

    def block_list(self) -> list[Block]:
        keys = self.blocks or [b.key for b in BLOCKS]
        unknown = set(keys) - {b.key for b in BLOCKS}
        if unknown:
            raise OptionError(f"unknown report block(s) {', '.join(sorted(unknown))}")
        return [b for b in BLOCKS if b.key in keys]


def posterior_laws(settings: ReportSettings, key: str, aicc: dict) -> list[str]:
    """The laws of block ``key`` whose posteriors ``settings`` sample, best first.

    ``aicc``: each law's least-squares AICc on the block, in its ranking's order (best
    first). The best ``posterior_top`` laws (``posterior_skip`` aside) of a block of
    ``posterior_blocks``; with ``posterior_runner_up_below``, the best of them and those whose
    AICc exceeds its by less than that.

    Examples
    --------
    >>> s = ReportSettings.for_run()
    >>> posterior_laws(s, "B.4", {"preisach": 314.4, "jiles_atherton": 365.1, "cubic_hc": 467.1})
    ['preisach', 'jiles_atherton']
    >>> posterior_laws(s, "B.4", {"preisach": 314.4, "jiles_atherton": 374.4})
    ['preisach']
    >>> posterior_laws(s, "B.1", {"preisach": 60.2, "jiles_atherton": 99.7})
    []
    """
    if "posterior" not in settings.methods or not (
        settings.posterior_blocks is None or key in settings.posterior_blocks
    ):
        return []
    laws = [m for m in aicc if m not in settings.posterior_skip]
    top = laws if settings.posterior_top is None else laws[: max(int(settings.posterior_top), 0)]
    below = settings.posterior_runner_up_below
    if below is None or not top:
        return top
    return top[:1] + [m for m in top[1:] if aicc[m] - aicc[top[0]] < below]


#: The runs of ``fitdf report``, each with its command-line option.
RUNS = {"quick": "--quick", "default": "", "full": "--full"}


def run_record(settings: ReportSettings, seed: int) -> dict:
    """Which run of ``fitdf report`` made a report of ``settings`` and ``seed``, and the command
    that makes it again: ``{"run": "quick" | "default" | "full" | None, "command": str | None}``
    (None: settings no option of the command gives, such as a test's)."""
    made = settings_record(settings)
    for name, option in RUNS.items():
        run = ReportSettings.for_run(
            quick=name == "quick",
            full=name == "full",
            compare_chain=settings.approximate_chain,
        )
        if settings_record(run) == made:
            words = ["fitdf report", option]
            if settings.approximate_chain:
                words.append(f"--compare-chain {settings.approximate_chain}")
            if int(seed) != 0:
                words.append(f"--seed {int(seed)}")
            return {"run": name, "command": " ".join(w for w in words if w)}
    return {"run": None, "command": None}


def settings_record(settings: ReportSettings) -> dict:
    """``settings`` as ``results.json`` keeps them: every choice that can change a number (the
    workers and the cluster aside), the laws and blocks listed."""
    d = asdict(settings)
    d["models"] = settings.model_list()
    d["blocks"] = [b.key for b in settings.block_list()]
    d["cross"] = [list(c) for c in settings.cross]
    d["methods"] = list(settings.methods)
    d.pop("workers")  # where the jobs ran does not change any number
    d.pop("scheduler")
    return d


def _count(n) -> float:
    """How many of the best laws a ``*_top`` setting takes (None: all)."""
    return float("inf") if n is None else max(int(n), 0)


def _count_below(record) -> float:
    """A record's ``posterior_runner_up_below`` (None or absent: every gap, infinity)."""
    below = record.get("posterior_runner_up_below")
    return float("inf") if below is None else float(below)


def _some(values, value) -> set:
    """The set ``values`` stands for; None stands for every one (``value``: that set)."""
    return (
        set(value) if values is None else {tuple(v) if isinstance(v, list) else v for v in values}
    )


def lost_by(old: dict, new: dict) -> list[str]:
    """What a report of settings ``new`` lacks that one of settings ``old`` holds (both as
    ``results.json`` keeps them, :func:`settings_record`): the laws, blocks, posteriors,
    cross-validations, predictions, refits and comparisons ``old`` computed and ``new`` does
    not, in words; empty when ``new`` computes at least what ``old`` did.

    Examples
    --------
    >>> full, quick = (settings_record(ReportSettings.for_run(full=f, quick=q))
    ...                for f, q in ((True, False), (False, True)))
    >>> lost_by(full, quick)[:2]
    ['posteriors', 'cross-validations']
    >>> lost_by(quick, full)
    []
    """

    def get(record, name, default=None):
        return record.get(name, default)

    def top(record, name):
        return _count(get(record, name, 0))

    lost = []
    laws = set(get(old, "models") or []) - set(get(new, "models") or [])
    blocks = set(get(old, "blocks") or []) - set(get(new, "blocks") or [])
    lost += [f"laws {', '.join(sorted(laws))}"] if laws else []
    lost += [f"blocks {', '.join(sorted(blocks))}"] if blocks else []

    def sampled(record):
        return top(record, "posterior_top") if "posterior" in (get(record, "methods") or []) else 0

    if sampled(old):
        every = set(get(old, "blocks") or []) | set(get(new, "blocks") or [])
        fewer = (
            sampled(new) < sampled(old)
            or _count_below(new) < _count_below(old)
            or not (
                _some(get(old, "posterior_blocks"), every)
                <= _some(get(new, "posterior_blocks"), every)
            )
        )
        if fewer or get(new, "sampler") != get(old, "sampler"):
            lost.append("posteriors")
        elif top(new, "sensitivity_top") < top(old, "sensitivity_top"):
            lost.append("prior-sensitivity runs")
    every_cross = {tuple(c) for c in get(old, "cross") or []}
    fewer_cross = not every_cross <= {tuple(c) for c in get(new, "cross") or []}
    for name, what, fewer in (
        ("cv_top", "cross-validations", False),
        ("cross_top", "cross-impedance predictions", fewer_cross),
        ("printed_top", "fits to the rows as printed", False),
    ):
        if top(old, name) and (fewer or top(new, name) < top(old, name)):
            lost.append(what)
    if get(old, "limit_cycles") and not get(new, "limit_cycles"):
        lost.append("limit cycles")
    approx = get(old, "approximate_chain")
    if approx and get(new, "approximate_chain") != approx:
        lost.append(f"{approx} refits")
    dynamic = get(old, "dynamic_chain")
    if dynamic and top(old, "dynamic_top"):
        if get(new, "dynamic_chain") != dynamic or top(new, "dynamic_top") < top(
            old, "dynamic_top"
        ):
            lost.append("rate-dependent refits")
        elif get(old, "dynamic_cv") and not get(new, "dynamic_cv"):
            lost.append("rate-dependent refits' cross-validations")
    return lost
