"""The circuit's series resistance ``r_series``: its declaration and its prior.

Every chain with a circuit (``winding``, ``voltage``, ``dynamic``) drives the winding
through ``R = R_source + r_series`` (Fig 5.10, section V.5): the nominal source impedance
of the table and a resistance besides it, the winding's own, the source's output impedance
and the leads. Data at one source impedance leave a current scale that only ``r_series``
fixes (:mod:`fitdf.data.cores`), so a fit with a core geometry puts a log-normal prior on
it about the winding's Appendix A estimate
(:attr:`fitdf.data.cores.CoreGeometry.r_winding_estimate`): the fits
(:class:`fitdf.inference.problem.FitProblem`), the material check
(:mod:`fitdf.inference.material`) and the cross-impedance prediction
(:mod:`fitdf.inference.cross_impedance`) all read it from :func:`series_resistance_prior`.
"""

from __future__ import annotations

from fitdf.params import ParamSpec

__all__ = ["R_SERIES", "series_resistance_prior", "SOURCE_AND_LEADS_OHM", "R_SERIES_PRIOR_SIGMA"]

#: The parameter, as every chain with a circuit declares it.
R_SERIES = ParamSpec(
    "r_series",
    70.0,
    (1.0, 5000.0),
    unit="ohm",
    description=(
        "series resistance besides the source impedance: winding, source output and leads"
    ),
    equation="sec V.5, Fig 5.10",
    log=True,
)

#: The prior's median is the winding's estimate plus this typical source and leads (ohm; a
#: low-impedance generator adds some tens of ohms, not hundreds: the thesis's 600 ohm is the
#: resistor of section V.5, counted as the source impedance) ...
SOURCE_AND_LEADS_OHM = 25.0
#: ... and this its width (natural log): the winding estimate is good to about 30 % and the
#: source is unknown, so the 95 % interval, median x/÷ 2.46, runs from the winding alone at
#: 70 % of its estimate to some 150 ohm of source and leads.
R_SERIES_PRIOR_SIGMA = 0.45


def series_resistance_prior(r_winding_estimate: float) -> tuple[float, float]:
    """``(median, sigma)`` of the log-normal prior of ``r_series`` (ohm; sigma of its natural
    log) for a winding of estimated resistance ``r_winding_estimate`` (ohm)."""
    return float(r_winding_estimate) + SOURCE_AND_LEADS_OHM, R_SERIES_PRIOR_SIGMA
