"""Proposals of the MCMC production chains, and the mix of moves built from the pilot.

:func:`production_moves` returns the moves of the production chains of
:func:`fitdf.inference.mcmc.fit_mcmc`, adapted to the pilot's draws, in the shares
:data:`MOVE_SHARES`: the independence proposal :class:`KernelProposal` (Gaussian kernels on
the draws, with a defensive Student t), the symmetric :class:`ArchiveDifferentialProposal`
(differential evolution on a fixed archive of draws, DE-MCz) and a random walk at the
Gaussian-optimal scale ``2.38^2 / d`` of the last round's covariance; where the pilot
spreads a logit coordinate like its prior (:func:`free_columns`),
:class:`PriorCoordinateProposal` redraws one such coordinate from its prior, at
:data:`PRIOR_SHARE`. Every move acts on one walker alone and is fixed before production
starts, so each walker is an ordinary Metropolis-Hastings chain with the posterior as its
stationary law, and R-hat can compare them. The kernels cover what the pilot visited, side
lobes of skewed posteriors included; the defensive t keeps the importance ratio bounded
where it did not reach; steps between archived draws follow curved ridges and, at
``gamma = 1``, jump between lobes.

References
----------
Hesterberg, T., "Weighted average importance sampling and defensive mixture
distributions", Technometrics 37, 185 (1995).

ter Braak, C. J. F. and Vrugt, J. A., "Differential Evolution Markov Chain with snooker
updater and fewer chains", Statistics and Computing 18, 435 (2008).

Roberts, G. O., Gelman, A. and Gilks, W. R., "Weak convergence and optimal scaling of
random walk Metropolis algorithms", Annals of Applied Probability 7, 110 (1997).
"""

from __future__ import annotations

import emcee
import numpy as np
from scipy.special import gammaln, logsumexp

__all__ = [
    "StudentTProposal",
    "KernelProposal",
    "ArchiveDifferentialProposal",
    "PriorCoordinateProposal",
    "free_columns",
    "production_moves",
]


def _jitter(cov):
    """``1e-12`` of the mean variance of ``cov`` on a diagonal: added, it makes ``cov``
    positive definite where the draws are degenerate."""
    d = cov.shape[0]
    return 1e-12 * np.eye(d) * max(np.trace(cov) / d, 1e-300)


def _subsample(draws, n, rng):
    """At most ``n`` of the rows of ``draws``, chosen with ``rng``, in their order."""
    if len(draws) <= n:
        return draws
    return draws[np.sort(rng.choice(len(draws), n, replace=False))]


class StudentTProposal:
    """Independence proposal for :class:`emcee.moves.MHMove`: a multivariate Student t.

    ``q(x) ~ (1 + (x - mean)' S^-1 (x - mean) / nu)^(-(nu + d)/2)``, ``S = scale^2 cov``:
    heavier tails than the posterior it approximates (so the importance ratio stays
    bounded), the same for every walker. Returns ``(proposal, log q(x) - log q(x'))``,
    the Metropolis-Hastings correction of a move that does not depend on ``x``.
    """

    def __init__(self, mean, cov, nu: float = 5.0, scale: float = 1.2):
        self.mean = np.asarray(mean, float)
        d = self.mean.size
        cov = np.atleast_2d(np.asarray(cov, float))
        cov = cov + _jitter(cov)
        self.chol = np.linalg.cholesky(scale**2 * cov)
        self.inv_chol = np.linalg.inv(self.chol)
        self.nu = float(nu)
        #: log of the normalising constant (what a mixture with another density needs)
        self.log_norm = float(
            gammaln((nu + d) / 2)
            - gammaln(nu / 2)
            - 0.5 * d * np.log(nu * np.pi)
            - np.sum(np.log(np.diag(self.chol)))
        )

    def log_density(self, x):
        """``log q`` up to its constant (which cancels in the ratio)."""
        z = (np.asarray(x) - self.mean) @ self.inv_chol.T
        return -0.5 * (self.nu + self.mean.size) * np.log1p(np.sum(z * z, axis=-1) / self.nu)

    def sample(self, n, random):
        z = random.standard_normal((n, self.mean.size))
        g = random.chisquare(self.nu, n)
        return self.mean + (z * np.sqrt(self.nu / g)[:, None]) @ self.chol.T

    def __call__(self, coords, random):
        q = self.sample(coords.shape[0], random)
        return q, self.log_density(coords) - self.log_density(q)


class KernelProposal:
    """Independence proposal: Gaussian kernels on the pilot's draws, with a defensive t.

    ``q = (1 - defensive) (1/K) sum_k N(x; c_k, h^2 C) + defensive t(x)``: ``K`` centres
    (at most ``max_centres`` of the draws, chosen with ``rng``), ``C`` the draws'
    covariance, ``h`` Scott's factor ``K^(-1/(d + 4))``; the t has the draws' mean and 1.5
    times their spread. Returns ``(proposal, log q(x) - log q(x'))`` like
    :class:`StudentTProposal`.
    """

    def __init__(self, draws, rng, max_centres: int = 2000, defensive: float = 0.1):
        draws = _subsample(np.asarray(draws, float), max_centres, rng)
        k, d = draws.shape
        cov = np.atleast_2d(np.cov(draws, rowvar=False))  # (1, 1) for one parameter
        cov = cov + _jitter(cov)
        h = k ** (-1.0 / (d + 4))
        self.centres = draws
        self.chol = np.linalg.cholesky(h**2 * cov)
        inv = np.linalg.inv(self.chol)
        self._inv_t = inv.T
        self._white = draws @ inv.T
        self._white_sq = np.sum(self._white**2, axis=1)
        self._log_norm = (
            -np.log(k) - 0.5 * d * np.log(2 * np.pi) - np.sum(np.log(np.diag(self.chol)))
        )
        self.defensive = float(defensive)
        self.tail = StudentTProposal(np.mean(draws, axis=0), cov, scale=1.5)

    def log_density(self, x):
        """``log q`` (normalised: the kernels and the t are mixed by their densities)."""
        w = np.atleast_2d(np.asarray(x, float)) @ self._inv_t
        d2 = np.sum(w * w, axis=1)[:, None] - 2.0 * w @ self._white.T + self._white_sq[None, :]
        kernels = logsumexp(-0.5 * np.maximum(d2, 0.0), axis=1) + self._log_norm
        tail = self.tail.log_density(x) + self.tail.log_norm
        return np.logaddexp(np.log1p(-self.defensive) + kernels, np.log(self.defensive) + tail)

    def __call__(self, coords, random):
        n, d = coords.shape
        centre = self.centres[random.randint(len(self.centres), size=n)]
        q = centre + random.standard_normal((n, d)) @ self.chol.T
        from_tail = random.uniform(size=n) < self.defensive
        q = np.where(from_tail[:, None], self.tail.sample(n, random), q)
        return q, self.log_density(coords) - self.log_density(q)


class ArchiveDifferentialProposal:
    """Symmetric proposal for :class:`emcee.moves.MHMove`: differential evolution on a fixed
    archive (DE-MCz, ter Braak & Vrugt 2008).

    ``x' = x + g (z1 - z2) + e``: ``z1 != z2`` drawn uniformly from ``archive`` (at most
    ``max_archive`` of its rows, chosen with ``rng``), ``g = 1`` with probability ``jump``
    (a lobe-to-lobe step) and otherwise ``2.38 / sqrt(2 d)`` (the DE-MC scale) times a
    uniform factor in ``[0.5, 1.5]``, ``e`` Gaussian at ``1e-4`` of the archive's spread
    (so that the proposals are not confined to a lattice of differences). The increment
    does not depend on ``x`` and is symmetric about 0, so the Metropolis-Hastings
    correction is 0.
    """

    def __init__(self, archive, rng, max_archive: int = 4000, jump: float = 0.1):
        archive = _subsample(np.atleast_2d(np.asarray(archive, float)), max_archive, rng)
        if len(archive) < 2:
            raise ValueError("the archive needs at least two draws")
        self.archive = archive
        d = archive.shape[1]
        self.gamma = 2.38 / np.sqrt(2.0 * d)
        self.jump = float(jump)
        self.jitter = 1e-4 * np.std(archive, axis=0)

    def __call__(self, coords, random):
        n, d = coords.shape
        k = len(self.archive)
        i = random.randint(k, size=n)
        j = (i + 1 + random.randint(k - 1, size=n)) % k  # any row but i, uniformly
        g = np.where(
            random.uniform(size=n) < self.jump, 1.0, self.gamma * random.uniform(0.5, 1.5, size=n)
        )
        step = g[:, None] * (self.archive[i] - self.archive[j])
        q = coords + step + self.jitter * random.standard_normal((n, d))
        return q, np.zeros(n)


class PriorCoordinateProposal:
    """Independence proposal for one coordinate at a time, from its prior, for
    :class:`emcee.moves.MHMove`: for parameters the data leave free.

    In the logit coordinates of the prior box (:class:`fitdf.inference.mcmc.BoxCoordinates`)
    a parameter with a uniform prior has the standard logistic density as its prior, so
    drawing ``z_j`` from it (``j`` uniformly among ``columns``, the rest kept) makes the
    Metropolis-Hastings ratio the likelihood ratio alone. Where the posterior of ``z_j``
    is its prior (cubic_hc's ``h0_ratio`` and ``bend`` on B.3: their draws fill the box),
    the move draws it anew in one step whatever its current value, which neither the
    kernel nor a random walk scaled to the other parameters does. Returns
    ``(proposal, log q(x) - log q(x'))``.
    """

    def __init__(self, columns):
        self.columns = np.asarray(columns, int)
        if not self.columns.size:
            raise ValueError("no columns to draw from their prior")

    @staticmethod
    def log_density(z):
        """The standard logistic density's log (``log s(z) + log s(-z)``)."""
        return -np.logaddexp(0.0, -z) - np.logaddexp(0.0, z)

    def __call__(self, coords, random):
        n = coords.shape[0]
        j = self.columns[random.randint(self.columns.size, size=n)]
        rows = np.arange(n)
        old = coords[rows, j]
        new = random.logistic(size=n)
        q = coords.copy()
        q[rows, j] = new
        return q, self.log_density(old) - self.log_density(new)


#: Logit coordinates whose pilot draws spread at least this share of the standard logistic
#: density's own spread (``pi / sqrt(3)``) are left free by the data: the prior-coordinate
#: move draws them (:class:`PriorCoordinateProposal`).
FREE_SPREAD = 0.5


def free_columns(draws, spread: float = FREE_SPREAD):
    """Columns of ``draws`` (logit coordinates) spread like their logistic prior."""
    sd = np.std(np.atleast_2d(draws), axis=0)
    return np.flatnonzero(sd >= spread * np.pi / np.sqrt(3.0))


#: Shares of the production moves: kernel independence, archive DE, random walk.
MOVE_SHARES = (0.4, 0.4, 0.2)
#: Share of the prior-coordinate move where the pilot's draws leave coordinates free
#: (:func:`free_columns`); the others' shares shrink in proportion.
PRIOR_SHARE = 0.2


def production_moves(last, pool=None, rng=None, logit: bool = False):
    """Moves adapted to the pilot, in :data:`MOVE_SHARES`: the kernel independence move and
    differential evolution, both on ``pool`` (default ``last``), and the random walk with
    the covariance of ``last``; and, for draws in the logit coordinates of the prior box
    (``logit``) with coordinates spread like their prior (:func:`free_columns`), the
    prior-coordinate move at :data:`PRIOR_SHARE`, the others' shares shrunk in proportion.

    ``last`` are the draws ``(n, d)`` of the last pilot round, ``pool`` those of every
    adapted round (a lobe the walkers visited once stays covered); ``rng`` chooses the
    kernel centres and the archive.
    """
    rng = np.random.default_rng(0) if rng is None else rng
    pool = last if pool is None else pool
    cov = np.atleast_2d(np.cov(last, rowvar=False))  # (1, 1) for one parameter
    d = cov.shape[0]
    kernel, differential, walk = MOVE_SHARES
    free = free_columns(pool) if logit else np.zeros(0, int)
    rest = 1.0 - PRIOR_SHARE if free.size else 1.0
    moves = [
        (emcee.moves.MHMove(KernelProposal(pool, rng)), rest * kernel),
        (emcee.moves.MHMove(ArchiveDifferentialProposal(pool, rng)), rest * differential),
        # random-walk Metropolis at the optimal scale for a Gaussian target (2.38^2 / d)
        (
            emcee.moves.GaussianMove((2.38**2 / d) * cov + _jitter(cov), mode="vector"),
            rest * walk,
        ),
    ]
    if free.size:
        moves.append((emcee.moves.MHMove(PriorCoordinateProposal(free)), PRIOR_SHARE))
    return moves
