"""Could a cheap surrogate of the likelihood stand in for the exact chain inside MCMC?

Run from the repository root::

    python benchmarks/surrogate_check.py B.1:preisach [B.3:cubic_hc ...] [--max-steps 1000]

A surrogate-accelerated sampler (delayed acceptance, or a surrogate transition: run the
proposals on the surrogate, correct with one exact evaluation) keeps the posterior exact
and pays off only if the surrogate's log-posterior is within about one unit of the exact
one across the posterior: the correction accepts ``exp(e(x') - e(x))`` of ``e`` the
surrogate's error, and a spread of 2 units already leaves 16 % of normal errors' steps.

For each ``block:law`` this runs the report's least squares and MCMC job (the report's
settings, ``--max-steps`` for production) and records every parameter set the sampler
evaluated with its prediction. The first half of the evaluations (in order: the pilot's
rounds first) trains two surrogates of the error components per row (magnitude and arc,
what the likelihood reads): a polynomial of degree 1-3 in the whitened logit
coordinates, and a local-linear fit on the ``k`` nearest training sets. Each is scored on
the later evaluations within 15 log units of the best: the mean and standard deviation of
``log p(exact) - log p(surrogate)`` and its 95th percentile about the mean, and the median
distance from a scored set to its nearest training set in posterior standard deviations.
No thresholds: numbers only.
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from _report_fit import report_lsq

from fitdf.inference import problem as problem_module
from fitdf.inference.mcmc import LogPosterior
from fitdf.report.jobs import job_mcmc
from fitdf.report.settings import ReportSettings


def record_chain(block_key: str, law: str, seed: int, max_steps: int):
    """The least-squares result and every ``(internal, prediction)`` the MCMC job evaluated."""
    settings = ReportSettings.for_run()
    lsq = report_lsq(block_key, law, seed, settings)
    seen_x, seen_m = [], []
    predict = problem_module.FitProblem.predict

    def recording(self, internal):
        out = predict(self, internal)
        seen_x.append(np.array(internal, float).reshape(-1, np.shape(internal)[-1]))
        seen_m.append(np.array(out).reshape(-1, out.shape[-1]))
        return out

    problem_module.FitProblem.predict = recording
    try:
        job_mcmc(lsq, seed, settings.n_steps, settings.n_walkers, max_steps, max_steps)
    finally:
        problem_module.FitProblem.predict = predict
    return lsq, np.concatenate(seen_x), np.concatenate(seen_m)


def monomials(u, degree):
    cols = [np.ones(len(u))]
    for k in range(1, degree + 1):
        for c in itertools.combinations_with_replacement(range(u.shape[1]), k):
            cols.append(np.prod(u[:, c], axis=1))
    return np.stack(cols, axis=1)


def local_linear(train_u, train_y, query_u, k):
    tree = cKDTree(train_u)
    dist, idx = tree.query(query_u, k)
    out = np.empty((len(query_u), train_y.shape[1]))
    for i in range(len(query_u)):
        a = np.hstack([np.ones((k, 1)), train_u[idx[i]] - query_u[i]])
        w = np.exp(-0.5 * (dist[i] / dist[i].max()) ** 2)[:, None]
        coef, *_ = np.linalg.lstsq(a * w, train_y[idx[i]] * w, rcond=None)
        out[i] = coef[0]
    return out, float(np.median(dist[:, 0]))


def score(block_key, law, seed, max_steps):
    lsq, X, M = record_chain(block_key, law, seed, max_steps)
    problem = lsq.problem
    logpost = LogPosterior(problem, logit=True, marginal_noise=True)
    Z = logpost.to_sampler(X)
    radial, arc = problem.error_components(M)
    Y = np.concatenate([radial, arc], axis=1)
    n_rows = radial.shape[1]
    fixed = problem.log_prior(X) + logpost.box.log_jacobian(Z)
    exact = logpost.noise.log_likelihood(radial, arc) + fixed
    top = exact.max()
    half = len(X) // 2
    train = np.flatnonzero(exact[:half] > top - 40)
    test = half + np.flatnonzero(exact[half:] > top - 15)
    test = test[:: max(1, len(test) // 1500)]
    mean = Z[train].mean(axis=0)
    chol = np.linalg.cholesky(np.cov(Z[train], rowvar=False))

    def white(a):
        return np.linalg.solve(chol, (a - mean).T).T

    print(
        f"{block_key} {law}: {len(X)} evaluations, {Z.shape[1]} dimensions, {n_rows} rows; "
        f"trained on {len(train)}, scored on {len(test)}"
    )

    def report(name, y_hat):
        surrogate = logpost.noise.log_likelihood(y_hat[:, :n_rows], y_hat[:, n_rows:])
        e = exact[test] - (surrogate + fixed[test])
        p95 = np.percentile(np.abs(e - e.mean()), 95)
        print(
            f"  {name:<24s} error mean {e.mean():7.2f}  sd {e.std():6.2f}  95 % within {p95:6.2f}"
        )

    for degree in (1, 2, 3):
        features = monomials(white(Z[train]), degree)
        if features.shape[1] > len(train) / 3:
            continue
        coef, *_ = np.linalg.lstsq(features, Y[train], rcond=None)
        report(f"polynomial, degree {degree}", monomials(white(Z[test]), degree) @ coef)
    for k in (20, 80):
        y_hat, nearest = local_linear(white(Z[train]), Y[train], white(Z[test]), k)
        report(f"local linear, k = {k}", y_hat)
    print(f"  (median distance to the nearest training set: {nearest:.2f} posterior sd)")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("chains", nargs="+", metavar="BLOCK:LAW")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-steps", type=int, default=1000)
    args = parser.parse_args(argv)
    for spec in args.chains:
        block_key, _, law = spec.partition(":")
        score(block_key, law, args.seed, args.max_steps)


if __name__ == "__main__":
    main()
