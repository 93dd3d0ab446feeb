"""The inference layer: one likelihood (``problem``); least squares (``lsq``); posteriors by
two samplers, emcee's MCMC (``mcmc``, with its production proposals in ``proposals``) and
nautilus's nested sampling (``nested``, with the evidence's sensitivity to the prior in
``evidence``), the noise scales integrated out of both (``noise``), one result for both
(``posterior``; their priors stated in ``priors``, and the result in ArviZ's format in
``posterior_data``); the results and metrics; the ``fit`` entry point (``api``); the ranking
of fitted laws (``ranking``, ``selection``) and the prediction across source impedance
(``cross_impedance``). Fitters know nothing of a particular law: they see a
:class:`~fitdf.inference.problem.FitProblem`.
"""
