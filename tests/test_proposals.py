"""The production moves of :mod:`fitdf.inference.proposals`, on targets known in closed form.

Differential evolution on an archive (DE-MCz) must leave the target invariant (its
increment is symmetric) and must carry a chain between separated lobes, which a random
walk at the lobes' own scale cannot do: both are checked on a two-lobe Gaussian mixture
whose weights, mean and variance are known exactly.
"""

import emcee
import numpy as np
import pytest

from fitdf.inference.proposals import (
    MOVE_SHARES,
    PRIOR_SHARE,
    ArchiveDifferentialProposal,
    KernelProposal,
    PriorCoordinateProposal,
    free_columns,
    production_moves,
)

CENTRES = np.array([[-4.0, 0.0], [4.0, 1.0]])
WEIGHTS = np.array([0.3, 0.7])
SD = np.array([0.3, 0.5])


def log_target(x):
    x = np.atleast_2d(x)
    comps = [
        np.log(w) - 0.5 * np.sum(((x - c) / SD) ** 2, axis=1) for w, c in zip(WEIGHTS, CENTRES)
    ]
    return np.logaddexp(*comps)


def exact_draws(n, seed):
    rng = np.random.default_rng(seed)
    lobe = rng.uniform(size=n) < WEIGHTS[1]
    return CENTRES[lobe.astype(int)] + SD * rng.standard_normal((n, 2))


def run_chains(moves, n_steps, seed, start):
    """Four independent chains (every move acts on each walker alone), all started in ``start``."""
    sampler = emcee.EnsembleSampler(4, 2, log_target, vectorize=True, moves=moves)
    sampler.random_state = np.random.RandomState(seed).get_state()
    p0 = start + 0.1 * np.random.default_rng(seed).standard_normal((4, 2))
    sampler.run_mcmc(p0, n_steps, skip_initial_state_check=True)
    return sampler.get_chain(discard=n_steps // 10, flat=True)


def test_increment_is_symmetric_and_correction_zero():
    prop = ArchiveDifferentialProposal(exact_draws(500, 0), np.random.default_rng(1))
    x = np.zeros((20000, 2))
    q, corr = prop(x, np.random.RandomState(2))
    assert np.all(corr == 0.0)
    step = q - x
    assert np.all(np.any(step != 0.0, axis=1))  # z1 != z2: never a null move
    # odd moments of a symmetric law vanish (to sampling error: sd of the mean ~ 4.4 / 141)
    assert np.all(np.abs(step.mean(axis=0)) < 0.1)
    assert np.all(np.abs(np.mean(step**3, axis=0)) < 0.1 * np.mean(np.abs(step) ** 3, axis=0))
    # g = 1 (every step with jump=1): the step is a whole archive difference, +-(a0 - a1)
    two = np.array([[-4.0, 0.0], [4.0, 1.0]])
    whole = ArchiveDifferentialProposal(two, np.random.default_rng(1), jump=1.0)
    step, _ = whole(np.zeros((1000, 2)), np.random.RandomState(3))
    np.testing.assert_allclose(np.abs(step), np.broadcast_to([8.0, 1.0], step.shape), atol=1e-2)
    assert 0.4 < np.mean(step[:, 0] > 0) < 0.6


def test_archive_is_subsampled_and_needs_two_rows():
    prop = ArchiveDifferentialProposal(
        exact_draws(5000, 0), np.random.default_rng(1), max_archive=300
    )
    assert prop.archive.shape == (300, 2)
    assert prop.gamma == pytest.approx(2.38 / 2.0)
    with pytest.raises(ValueError, match="two draws"):
        ArchiveDifferentialProposal(np.zeros((1, 2)), np.random.default_rng(0))


def test_differential_move_jumps_lobes_and_keeps_the_target():
    """Chains started in the light lobe reach the 0.7 weight of the other and the exact
    moments; the same chains by a random walk at the lobes' scale never leave their lobe."""
    archive = exact_draws(2000, 3)
    de = emcee.moves.MHMove(ArchiveDifferentialProposal(archive, np.random.default_rng(4)))
    flat = run_chains([de], 6000, seed=5, start=CENTRES[0])
    right = np.mean(flat[:, 0] > 0)
    assert right == pytest.approx(WEIGHTS[1], abs=0.06)
    mean = WEIGHTS @ CENTRES
    var0 = WEIGHTS @ (SD[0] ** 2 + CENTRES[:, 0] ** 2) - mean[0] ** 2
    assert flat.mean(axis=0) == pytest.approx(mean, abs=0.6)
    assert flat[:, 0].var() == pytest.approx(var0, rel=0.15)

    walk = emcee.moves.GaussianMove(np.diag(SD**2) * 2.38**2 / 2, mode="vector")
    stuck = run_chains([walk], 6000, seed=5, start=CENTRES[0])
    assert np.mean(stuck[:, 0] > 0) == 0.0


def test_production_moves_mix_and_sample_the_target():
    """The report's mix (kernel, archive DE, random walk) from a pilot that saw both lobes,
    chains started in the light lobe: the exact lobe weight and per-lobe spread."""
    pool = exact_draws(3000, 6)
    moves = production_moves(pool[-1000:], pool, np.random.default_rng(7))
    assert [w for _, w in moves] == list(MOVE_SHARES)
    assert isinstance(moves[0][0].get_proposal, KernelProposal)
    assert isinstance(moves[1][0].get_proposal, ArchiveDifferentialProposal)
    flat = run_chains(moves, 4000, seed=8, start=CENTRES[0])
    right = flat[:, 0] > 0
    assert np.mean(right) == pytest.approx(WEIGHTS[1], abs=0.05)
    np.testing.assert_allclose(flat[right].std(axis=0), SD, rtol=0.15)
    np.testing.assert_allclose(flat[~right].std(axis=0), SD, rtol=0.15)


def logistic_target(z):
    """A standard normal in ``z0`` times, in ``z1``, the logistic prior of a logit
    coordinate and a likelihood that tilts it (``exp(-(z1 - 1)^2 / 18)``)."""
    z = np.atleast_2d(z)
    return (
        -0.5 * z[:, 0] ** 2
        + PriorCoordinateProposal.log_density(z[:, 1])
        - (z[:, 1] - 1.0) ** 2 / 18.0
    )


def test_prior_coordinate_move_draws_a_flat_coordinate_and_keeps_the_target():
    """Where the likelihood is flat in a coordinate the move accepts every draw from the
    prior; with a likelihood that tilts it, the chain has the target's exact moments
    (numerical quadrature), and the other coordinate is left alone."""
    move = PriorCoordinateProposal([1])
    z = np.zeros((4000, 2))
    q, factor = move(z, np.random.RandomState(0))
    np.testing.assert_array_equal(q[:, 0], 0.0)
    # the Metropolis-Hastings ratio on the prior alone: exactly 1
    prior_only = PriorCoordinateProposal.log_density(q[:, 1]) - PriorCoordinateProposal.log_density(
        z[:, 1]
    )
    np.testing.assert_allclose(prior_only + factor, 0.0, atol=1e-12)
    assert q[:, 1].std() == pytest.approx(np.pi / np.sqrt(3.0), rel=0.05)

    sampler = emcee.EnsembleSampler(
        4,
        2,
        logistic_target,
        vectorize=True,
        moves=[(emcee.moves.MHMove(move), 0.5), (emcee.moves.GaussianMove(1.0), 0.5)],
    )
    sampler.random_state = np.random.RandomState(1).get_state()
    sampler.run_mcmc(np.zeros((4, 2)), 20000, skip_initial_state_check=True)
    flat = sampler.get_chain(discard=500, flat=True)
    grid = np.linspace(-40, 40, 200001)
    w = np.exp(PriorCoordinateProposal.log_density(grid) - (grid - 1.0) ** 2 / 18.0)
    w /= w.sum()
    mean, sd = grid @ w, np.sqrt(((grid - grid @ w) ** 2) @ w)
    # (80000 draws, autocorrelation of a few steps: the mean to ~0.03)
    assert flat[:, 1].mean() == pytest.approx(mean, abs=0.06)
    assert flat[:, 1].std() == pytest.approx(sd, rel=0.05)
    assert flat[:, 0].std() == pytest.approx(1.0, rel=0.05)


def test_free_columns_are_those_spread_like_their_prior():
    rng = np.random.default_rng(0)
    draws = np.column_stack(
        [0.1 * rng.standard_normal(5000), rng.logistic(size=5000), 0.8 * rng.standard_normal(5000)]
    )
    np.testing.assert_array_equal(free_columns(draws), [1])
    # in logit coordinates the production moves draw that column from its prior, at
    # PRIOR_SHARE, the others' shares shrunk in proportion; in other coordinates they do not
    moves = production_moves(draws, logit=True)
    assert isinstance(moves[-1][0].get_proposal, PriorCoordinateProposal)
    np.testing.assert_array_equal(moves[-1][0].get_proposal.columns, [1])
    assert [w for _, w in moves] == pytest.approx(
        [(1 - PRIOR_SHARE) * w for w in MOVE_SHARES] + [PRIOR_SHARE]
    )
    assert [w for _, w in production_moves(draws)] == list(MOVE_SHARES)
    with pytest.raises(ValueError, match="no columns"):
        PriorCoordinateProposal([])
