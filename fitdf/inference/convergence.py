"""When a posterior counts as converged: the thresholds of both samplers, and the rule in words.

:func:`fitdf.inference.mcmc.is_converged` and :func:`fitdf.inference.nested.is_converged`
apply them; every text that states a rule (:data:`CONVERGED`: ``fitdf fit``'s checks, the
report) renders it from them.
"""

from __future__ import annotations

__all__ = [
    "RHAT_MAX",
    "MIN_STEPS_OVER_TAU",
    "MIN_ESS",
    "MIN_EFFECTIVE",
    "MAX_LOG_EVIDENCE_ERROR",
    "CONVERGED",
]

#: MCMC: R-hat at or above this is reported as not converged (rank-normalised split R-hat,
#: walkers as chains; Vehtari et al. 2021 recommend 1.01).
RHAT_MAX = 1.01
#: MCMC: the chain must be at least this many integrated autocorrelation times long.
MIN_STEPS_OVER_TAU = 50
#: MCMC: ... and every parameter's bulk effective sample size at least this.
MIN_ESS = 400

#: Nested sampling: at least this many effective draws (Kish) ...
MIN_EFFECTIVE = 400
#: ... and an error of the log-evidence of at most this.
MAX_LOG_EVIDENCE_ERROR = 0.3

#: The rule by method (``diagnostics["converged"]``), in words.
CONVERGED = {
    "nested": f">= {MIN_EFFECTIVE} effective draws, evidence error <= {MAX_LOG_EVIDENCE_ERROR:g}",
    "mcmc": (
        f"{MIN_STEPS_OVER_TAU} autocorrelation times, R-hat < {RHAT_MAX:g}, bulk ESS >= {MIN_ESS}"
    ),
}
