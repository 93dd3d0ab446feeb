"""The public fitting entry point: data + model + chain + method -> result."""

from __future__ import annotations

from fitdf.data.cores import CoreGeometry, core_geometry
from fitdf.data.fitdata import FitData, NoiseModel
from fitdf.data.resolve import resolve_data
from fitdf.errors import OptionError
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.material import with_material
from fitdf.inference.mcmc import fit_mcmc
from fitdf.inference.nested import fit_nested
from fitdf.inference.noise_models import get_noise_law
from fitdf.inference.problem import FitProblem

__all__ = ["fit", "resolve_data", "resolve_geometry", "METHODS", "DEFAULT_CHAIN"]

#: The chain of every fit unless another is asked for: the exact voltage-driven circuit.
DEFAULT_CHAIN = "voltage"

METHODS = ("lsq", "mcmc", "nested")

#: Noise laws (:mod:`fitdf.inference.noise_models`) MCMC takes: its likelihood has the two
#: scales of :mod:`fitdf.inference.noise` (integrated out), least squares before it the
#: printed or the fitted constant ones. Least squares and nested sampling take every law
#: (nested sampling samples a fitted law's parameters with the law's).
MCMC_NOISE = ("printed", "constant")


def fit(
    data,
    model,
    chain: str = DEFAULT_CHAIN,
    method: str = "lsq",
    seed: int = 0,
    policy: str = "default",
    source_impedance=None,
    noise: NoiseModel | str | None = None,
    fixed: dict | None = None,
    n_starts: int = 6,
    n_steps: int = 300,
    max_steps: int | None = 5000,
    n_walkers: int | None = None,
    progress: bool = False,
    geometry="auto",
    nested: dict | None = None,
):
    """Fit one model seen through one measurement chain.

    Parameters
    ----------
    data : str, path, DataFrame or FitData
        A bundled dataset ("B.3"), a core ("permalloy"), a CSV in the Appendix B schema.
    model : str
        A name from :func:`fitdf.models.model_names`.
    chain : {"voltage", "winding", "direct"}
        ``voltage`` (default) is the exact circuit; ``winding`` its sinusoidal-current
        approximation; ``direct`` reads the law's DF without a circuit.
    method : {"lsq", "mcmc", "nested"}
        "mcmc" runs least squares first and starts the walkers there; "nested" runs least
        squares first (its currents start the chain's solver), then nested sampling
        (:func:`fitdf.inference.nested.fit_nested`): the posterior and the evidence.
    seed : int
        Makes the multi-start and the chain reproducible.
    n_steps, max_steps : int
        MCMC runs a pilot, then at least ``n_steps`` and up to ``max_steps`` until the
        chain has converged (:func:`fitdf.inference.mcmc.is_converged`).
    noise : NoiseModel or str, optional
        The measurement noise: fixed scales (a :class:`~fitdf.data.fitdata.NoiseModel`;
        None: the printed precision), or the name of a noise law of
        :mod:`fitdf.inference.noise_models` whose parameters are fitted with the law's
        ("printed" is the default's name; "constant", "reading", "student",
        "reading-student"). MCMC takes "printed" and "constant" only
        (:data:`MCMC_NOISE`); nested sampling samples a fitted law's parameters.
    nested : dict, optional
        Options of :func:`~fitdf.inference.nested.fit_nested` (``n_live``,
        ``max_evaluations``, ...) for ``method="nested"``.
    geometry : "auto", CoreGeometry or None
        The core's turns and dimensions: material bounds, the ``r_series`` prior and the
        material constants of the result (:class:`~fitdf.inference.problem.FitProblem`).
        "auto" takes the Appendix A geometry when the rows name a thesis core; None fits
        in winding units with the laws' declared bounds.

    Returns
    -------
    FitResult or PosteriorResult

    Examples
    --------
    >>> import fitdf
    >>> r = fitdf.fit("B.3", "proportional_width", seed=1)   # doctest: +SKIP
    >>> r.metrics["rms_complex"]                              # doctest: +SKIP
    """
    if method not in METHODS:
        raise OptionError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    law = None
    if isinstance(noise, str):
        law, noise = get_noise_law(noise), None
        if law.name not in MCMC_NOISE and method == "mcmc":
            raise OptionError(
                f"noise law {law.name!r} needs method 'lsq' or 'nested'; method 'mcmc' "
                f"samples the {' or '.join(map(repr, MCMC_NOISE))} noise"
            )
    rows = resolve_data(data, policy, source_impedance)
    problem = FitProblem(
        rows, model, chain, noise, fixed, resolve_geometry(geometry, rows), noise_law=law
    )
    result = fit_lsq(problem, seed=seed, n_starts=n_starts)
    if method == "lsq":
        return with_material(result)
    if method == "nested":
        return with_material(fit_nested(problem, result, seed=seed, **(nested or {})))
    return with_material(
        fit_mcmc(
            problem,
            result,
            seed=seed,
            n_steps=n_steps,
            max_steps=max_steps,
            n_walkers=n_walkers,
            progress=progress,
        )
    )


def resolve_geometry(geometry, rows: FitData):
    """The core geometry a fit uses: ``"auto"`` -> Appendix A's for a thesis core, else as given."""
    if isinstance(geometry, str):
        if geometry != "auto":
            raise OptionError(f"geometry must be 'auto', None or a CoreGeometry, got {geometry!r}")
        if rows.core is None:
            return None
        try:
            return core_geometry(rows.core)
        except (
            OptionError
        ):  # a core Appendix A does not list: no geometry unless the user gives one
            return None
    if geometry is None or isinstance(geometry, CoreGeometry):
        return geometry
    raise OptionError(
        f"geometry must be 'auto', None or a CoreGeometry, got {type(geometry).__name__}"
    )
