"""The fitted noise scales integrated out of the likelihood (collapsed sampling).

Provides :class:`NoiseMarginal`: for a residual vector, the likelihood with the two noise
scales integrated out, and draws of the scales from their law given it; the scales' log10
bounds :data:`NOISE_BOUNDS` (the support of their log-uniform priors) and names
:data:`NOISE_NAMES`.

Notes
-----
MCMC fits two noise scales besides the model's parameters: ``sigma_m`` of the magnitude
residuals ``r_i`` and ``sigma_p`` of the phase, whose arc residuals ``t_i`` (phase error
times ``|D_i|``) have the scale ``s_t,i = hypot(|D_i| sigma_p, floor)`` with the floor of
:class:`fitdf.data.fitdata.NoiseModel`. Given the parameters the scales enter only through
the residuals, so the sampler works on the marginal likelihood::

    L(theta) = Int Int prod_i N(r_i; 0, sigma_m) N(t_i; 0, s_t,i)
                       p(sigma_m) p(sigma_p) dsigma_m dsigma_p

and the scales are drawn afterwards from their law given each parameter draw: the joint
posterior is the same, the walkers move in two dimensions fewer, and there is no funnel
between a noise scale and the parameters it loosens. The two integrals separate; each is
taken in ``u = log10 sigma`` by a composite 10-node Gauss-Legendre rule on panels of 0.05,
or of five conditional widths ``1 / (ln 10 sqrt(2 n))`` for ``n`` rows where that is
smaller (about 1000 nodes per residual vector). The rule resolves a smooth bump inside the
box, the plateau of the phase scale below ``floor / |D|`` and a steep exponential against a
bound alike: against the magnitude factor in closed form (an incomplete gamma function) and
the phase factor by adaptive quadrature, the error in ``log L`` is below 1e-8
(``tests/test_noise_marginal.py``).
"""

from __future__ import annotations

import numpy as np
from scipy.special import logsumexp

__all__ = ["NOISE_RANGES", "NOISE_BOUNDS", "NOISE_NAMES", "NoiseMarginal"]

#: Bounds of the fitted noise scales (magnitude, phase in degrees): the prior of a
#: measurement noise. The magnitude's upper bound is 0.3: 30 times the tables' printed
#: precision and twice the largest magnitude RMS of any law's least-squares fit (0.15); a
#: wider box admits a posterior mode in which a law predicting DF ~ 0 trades every
#: magnitude for its phases (``tests/test_noise_marginal.py``).
NOISE_RANGES = ((0.001, 0.3), (0.1, 50.0))
#: :data:`NOISE_RANGES` in log10, the coordinates the samplers move in.
NOISE_BOUNDS = np.log10(np.array(NOISE_RANGES))
NOISE_NAMES = ("sigma_magnitude", "sigma_phase_deg")


_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(10)


def _rule(lo, hi, panel):
    """Composite Gauss-Legendre nodes on ``[lo, hi]`` (panels no wider than ``panel``) and
    ``log`` of their weights times the log-uniform prior's density ``1 / (hi - lo)``."""
    edges = np.linspace(lo, hi, int(np.ceil((hi - lo) / panel)) + 1)
    half = 0.5 * np.diff(edges)[:, None]
    nodes = (0.5 * (edges[:-1] + edges[1:]))[:, None] + half * _GL_NODES
    weights = half * _GL_WEIGHTS
    return nodes.ravel(), np.log(weights.ravel() / (hi - lo))


def _uniform(lo, hi, step):
    """Nodes in ``[lo, hi]`` no farther apart than ``step`` (for drawing by cells)."""
    nodes = np.linspace(lo, hi, int(np.ceil((hi - lo) / step)) + 1)
    return nodes, np.zeros(nodes.size)


class NoiseMarginal:
    """The noise scales of ``problem`` on quadrature grids: marginal likelihood and draws.

    Parameters
    ----------
    problem : FitProblem
        Its ``scales`` give the per-row tangential scales for each ``sigma_p``.
    panel : float, optional
        Width of the quadrature panels in ``log10 sigma``; default 0.05, or five
        conditional widths where that is smaller (over 900 rows).
    """

    def __init__(self, problem, panel: float | None = None):
        self.problem = problem
        n = problem.data.n
        self.panel = panel or min(0.05, 5.0 / (np.log(10.0) * np.sqrt(2.0 * n)))
        self._tables = self._tabulate(_rule, self.panel)

    def _tabulate(self, grid, size):
        (m_lo, m_hi), (p_lo, p_hi) = NOISE_BOUNDS
        um, wm = grid(m_lo, m_hi, size)
        up, wp = grid(p_lo, p_hi, size)
        _, st = self.problem.scales(np.ones(up.size), 10.0**up)  # (nodes, rows)
        return {
            "magnitude": (um, wm, 10.0 ** (-2.0 * um), um * np.log(10.0)),
            "phase": (up, wp, 1.0 / st**2, np.sum(np.log(st), axis=-1)),
        }

    @staticmethod
    def _log_terms(radial, tang, tables):
        """Log-likelihood on each grid, with the quadrature weights: ``(..., nodes)`` twice."""
        um, wm, inv_m2, log_m = tables["magnitude"]
        _, wp, inv_t2, sum_log_t = tables["phase"]
        n = radial.shape[-1]
        ss = np.sum(radial**2, axis=-1)[..., None]
        lm = -0.5 * ss * inv_m2 - n * log_m + wm
        lp = -0.5 * (tang**2) @ inv_t2.T - sum_log_t + wp
        return lm, lp

    def log_likelihood(self, radial, tang):
        """``log L(theta)`` of the module docstring for residuals ``(..., n)``: shape ``(...)``."""
        lm, lp = self._log_terms(radial, tang, self._tables)
        n = radial.shape[-1]
        return logsumexp(lm, axis=-1) + logsumexp(lp, axis=-1) - n * np.log(2.0 * np.pi)

    def draw(self, radial, tang, rng, step: float = 0.002):
        """``log10`` of ``(sigma_m, sigma_p)`` drawn from their law given each residual
        vector ``(..., n)``: shape ``(..., 2)``.

        On a uniform grid of spacing ``step``, a node by its posterior density, then
        uniform within its cell (in place of drawing from the continuous law: the cell is
        a fourteenth of the conditional law's width or less up to 120 rows, which adds
        4e-4 of its variance).
        """
        tables = self._tabulate(_uniform, step)
        out = []
        for logw, (nodes, *_) in zip(
            self._log_terms(radial, tang, tables), (tables["magnitude"], tables["phase"])
        ):
            p = np.exp(logw - logw.max(axis=-1, keepdims=True))
            cdf = np.cumsum(p, axis=-1)
            u = rng.random(cdf.shape[:-1] + (1,)) * cdf[..., -1:]
            idx = np.minimum(np.sum(cdf < u, axis=-1), nodes.size - 1)
            jitter = (rng.random(idx.shape) - 0.5) * step
            out.append(np.clip(nodes[idx] + jitter, nodes[0], nodes[-1]))
        return np.stack(out, axis=-1)
