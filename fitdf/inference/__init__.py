"""The inference layer: one likelihood (``problem``), least squares (``lsq``), MCMC (``mcmc``,
with its production proposals in ``proposals`` and the noise scales integrated out in ``noise``),
their results and metrics, the ``fit`` entry point (``api``) and ranking of fitted models
(``ranking``). Fitters know nothing of a particular law: they see a :class:`FitProblem`.
"""
