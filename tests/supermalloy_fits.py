"""Helper, not a test: Table B.4's best law near its least-squares optimum, cheaply.

The values are those of the report's Preisach fit of Table B.4 through the ``voltage`` chain
and of its refit through the ``dynamic`` chain (rounded); every parameter but the
calibration gain is held there and the gain polished, so a test gets a real ``FitResult``
in about a second instead of a full fit's minute.
"""

from __future__ import annotations

from fitdf.data.cores import core_geometry
from fitdf.data.resolve import resolve_data
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.problem import FitProblem

STATIC = dict(
    lambda_s=0.047113,
    i_c=1.6372e-4,
    sigma_c=0.37099,
    i_i=1.9435e-4,
    l_rev=6.1051,
    f_rev=0.20646,
    r_series=79.667,
    gain=1.018,
)
DYNAMIC = dict(
    lambda_s=0.045832,
    i_c=1.4906e-4,
    sigma_c=0.29953,
    i_i=1.8804e-4,
    l_rev=9.6356,
    f_rev=0.23747,
    r_series=78.166,
    gain=1.038,
    c_cl=1.1229e-9,
    c_ex=4.4036e-5,
)


def near_optimum(chain: str, values: dict, data="B.4", core="supermalloy"):
    """A least-squares fit of ``data`` with every parameter but the gain held at ``values``."""
    rows = resolve_data(data, "default")
    fixed = {k: v for k, v in values.items() if k != "gain"}
    problem = FitProblem(rows, "preisach", chain, fixed=fixed, geometry=core_geometry(core))
    return fit_lsq(problem, starts=problem.to_internal(values), uncertainties=False)
