"""One model + one measurement chain + one dataset: predictions, residuals, log-likelihood.

This is the single code path shared by least squares and MCMC. Everything works on
*internal* parameter vectors (``log10`` for log-scaled parameters, see
:class:`~fitdf.params.ParamSpec`) of shape ``(..., P)``, so a whole ensemble of walkers
evaluates in one call.

Residual definition
-------------------
For a row with measured ``D`` and predicted ``M`` the error has two parts, in the
quantities the analyser reads (Chapter V: a magnitude and a phase against input
amplitude): the magnitude error ``|M| - |D|`` and the phase error
``arg M - arg D`` (wrapped to (-pi, pi]) times ``|D|``, the arc it spans on the
measured circle. They are scaled by the magnitude noise and by ``|D|`` times the phase
noise (with a floor), so a degree of phase counts less where the DF itself is tiny,
where the analyser's phase reading means little. Where ``D = 0`` there is no phase, and
only the magnitude counts.

To first order this is the complex error ``M - D`` split along the measured phasor. The
phase error is measured on ``|D|``, not on the predicted ``|M|``: measured on ``|M|``, a law
predicting ``M ~ 0`` would fit every phase (``tests/test_noise_marginal.py``).
"""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np

from fitdf.chains import get_chain, series_resistance_prior
from fitdf.data.cores import CoreGeometry
from fitdf.data.fitdata import FitData, NoiseModel
from fitdf.errors import ModelError
from fitdf.inference.noise_models import get_noise_law
from fitdf.models import get_model
from fitdf.params import PER_TABLE, ParamSpec, parameter_base, table_parameter

__all__ = [
    "FitProblem",
    "error_components",
    "physical_spec",
    "UNDEFINED_PHASE_ERROR",
]

#: Phase error (rad) of a row whose predicted DF is exactly 0: the RMS error of a phase
#: drawn uniformly on the circle. (Counted as 0, a law whose loop never leaves its dead
#: band "fitted" every phase: constant_width on B.3, k = 0.35 H, b = 0.12 A.)
UNDEFINED_PHASE_ERROR = np.pi / np.sqrt(3.0)


def error_components(predicted, measured):
    """Magnitude error ``|M| - |D|`` and phase error times ``|D|`` of predictions ``M`` of
    measured ``D`` (module docstring), each of the shape of ``predicted``."""
    absD = np.abs(measured)
    phase = np.angle(predicted * np.conj(measured))  # x |D| below: nothing where D = 0
    # M = 0 (a loop that never leaves its dead band) has no phase: it misses the
    # measured one as a uniformly random phase would, by pi/sqrt(3) rms
    phase = np.where(predicted == 0, UNDEFINED_PHASE_ERROR, phase)
    return np.abs(predicted) - absD, absD * phase


def physical_spec(spec: ParamSpec, geometry: CoreGeometry) -> ParamSpec:
    """``spec`` with bounds and start from the material limits of its quantity (if it has any)."""
    box = geometry.winding_box(spec.quantity) if spec.quantity else None
    if box is None:
        return spec
    lo, typical, hi = box
    return replace(spec, bounds=(lo, hi), default=min(max(typical, lo), hi))


class FitProblem:
    """Predictions and residuals of ``model`` seen through ``chain`` on ``data``.

    Parameters
    ----------
    data : FitData
    model : str or HysteresisModel subclass
    chain : str or chain class
    noise : NoiseModel
        Fixed noise scales used by the least-squares residuals and as the centre of
        the MCMC noise priors.
    fixed : dict, optional
        Parameter values held fixed (not fitted).
    geometry : CoreGeometry, optional
        The core's turns and dimensions. With it (and a chain in winding units) every
        parameter that has a physical quantity is bounded by material limits
        (:data:`fitdf.data.cores.MATERIAL_LIMITS`) instead of its declared box, and
        ``r_series`` gets its log-normal prior
        (:func:`fitdf.chains.series_resistance.series_resistance_prior`): data at
        one source impedance leave a current scale that only the series resistance fixes
        (:mod:`fitdf.data.cores`).
    noise_law : str or NoiseLaw, optional
        A fitted measurement-noise law (:mod:`fitdf.inference.noise_models`) instead of the
        fixed scales of ``noise``; ``"printed"`` is the same as None.
    """

    def __init__(
        self,
        data: FitData,
        model,
        chain="winding",
        noise: NoiseModel | None = None,
        fixed: dict | None = None,
        geometry: CoreGeometry | None = None,
        noise_law=None,
    ):
        self.data = data
        #: The measurement-noise law fitted beside the parameters
        #: (:mod:`fitdf.inference.noise_models`; None: the fixed scales of ``noise``) ...
        self.noise_law = None if noise_law is None else get_noise_law(noise_law)
        if self.noise_law is not None and not self.noise_law.fitted:
            self.noise_law = None
        #: ... and, while it is fitted, the per-row scales of the weighted residuals.
        self.row_scales = None
        self.geometry = geometry
        self.model = get_model(model)
        self.chain = get_chain(chain)
        self.noise = noise or NoiseModel()
        self.fixed = dict(fixed or {})
        groups = data.groups
        chain_specs = []
        self._gain_specs = []
        for spec in self.chain.params:
            if spec.name in PER_TABLE and len(groups) > 1:
                for g in groups:  # one calibration gain per table in a joint fit
                    s = replace(
                        spec,
                        name=table_parameter(spec.name, g),
                        description=f"{spec.description} (table {g})",
                    )
                    chain_specs.append(s)
                    self._gain_specs.append((s.name, g))
            else:
                chain_specs.append(spec)
        model_specs = list(self.model.params)
        if geometry is not None and self.chain.winding_units:
            # (chain parameters with a physical quantity too: the dynamic chain's loss terms)
            model_specs = [physical_spec(s, geometry) for s in model_specs]
            chain_specs = [physical_spec(s, geometry) for s in chain_specs]
        self.all_specs: list[ParamSpec] = model_specs + chain_specs
        unknown = set(self.fixed) - {s.name for s in self.all_specs}
        if unknown:
            raise ModelError(
                f"cannot fix unknown parameter(s) {', '.join(sorted(unknown))}; "
                f"parameters are {', '.join(s.name for s in self.all_specs)}"
            )
        self.specs: list[ParamSpec] = [s for s in self.all_specs if s.name not in self.fixed]
        self.names = [s.name for s in self.specs]
        self._group_index = {g: data.group == g for g in groups}
        self.warm_current = None
        #: name -> (centre, sigma) of Gaussian priors in internal (log10) coordinates
        self.priors: dict[str, tuple[float, float]] = {}
        r0 = None if geometry is None else geometry.r_winding_estimate
        if r0 and "r_series" in self.names:
            median, sigma = series_resistance_prior(r0)
            self.priors["r_series"] = (float(np.log10(median)), sigma / np.log(10.0))

    # ---------------------------------------------------------------- coordinates
    @property
    def ndim(self) -> int:
        return len(self.specs)

    def internal_bounds(self) -> np.ndarray:
        return np.array([s.internal_bounds for s in self.specs])

    def to_internal(self, values: dict) -> np.ndarray:
        return np.array([float(s.to_internal(values[s.name])) for s in self.specs])

    def to_natural(self, internal) -> np.ndarray:
        internal = np.asarray(internal, float)
        out = np.empty_like(internal)
        for i, s in enumerate(self.specs):
            out[..., i] = s.from_internal(internal[..., i])
        return out

    def start_internal(self) -> np.ndarray:
        return self.to_internal({s.name: s.default for s in self.specs})

    def full_natural(self, internal) -> dict[str, np.ndarray]:
        """Name -> natural value (fixed ones included) for a batch of internal vectors."""
        nat = self.to_natural(internal)
        out = {s.name: nat[..., i] for i, s in enumerate(self.specs)}
        shape = nat.shape[:-1]
        for name, value in self.fixed.items():
            out[name] = np.full(shape, float(value))
        return out

    # ---------------------------------------------------------------- predictions
    def predict_natural(
        self, values: dict, amplitude, frequency, source_impedance, group=None, warm=None
    ):
        """Measured-DF prediction for natural parameter values (arrays of a common batch shape)."""
        m_theta = np.stack([np.asarray(values[s.name], float) for s in self.model.params], axis=-1)
        c_specs = self.chain.params
        c_values = []
        for s in c_specs:
            if s.name in PER_TABLE:
                c_values.append(np.ones_like(np.asarray(values[self.model.params[0].name], float)))
            else:
                c_values.append(np.asarray(values[s.name], float))
        c_theta = np.stack(c_values, axis=-1) if c_values else np.zeros(m_theta.shape[:-1] + (0,))
        pred = self.chain.predict(
            self.model,
            np.asarray(amplitude, float),
            np.asarray(frequency, float),
            np.asarray(source_impedance, float),
            m_theta,
            c_theta,
            initial_current=warm,
        )
        return pred * self._gain_per_row(values, np.asarray(amplitude).size, group)

    def _gain_per_row(self, values, n, group):
        if not any(s.name in PER_TABLE for s in self.chain.params):
            return 1.0
        if not self._gain_specs:
            g = np.asarray(values["gain"], float)
            return g[..., None]
        group = self.data.group if group is None else np.asarray(group)
        first = np.asarray(values[self._gain_specs[0][0]], float)
        gains = np.ones(first.shape + (n,))
        for name, g in self._gain_specs:
            gains[..., group == g] = np.asarray(values[name], float)[..., None]
        return gains

    def predict(self, internal):
        """Prediction at the data rows for internal vectors of shape ``(..., P)``."""
        d = self.data
        return self.predict_natural(
            self.full_natural(internal),
            d.amplitude,
            d.frequency,
            d.source_impedance,
            warm=self.warm_current,
        )

    def with_box_scaled(self, factor: float, about=None) -> FitProblem:
        """A copy whose free parameters' boxes are ``factor`` times as wide in internal
        coordinates (``log10`` for log-scaled parameters: a box of decades), centred on the
        box's centre, or on ``about`` (an internal vector) kept inside the old box: how a
        prior's width moves the evidence. A widened box stops at its parameter's physical
        :attr:`~fitdf.params.ParamSpec.limits` (a fraction stays below 1, a width above 0),
        so it is less than ``factor`` times as wide there. The Gaussian priors stay as they
        are."""
        lo, hi = self.internal_bounds().T
        width = (hi - lo) * float(factor)
        centre = 0.5 * (lo + hi)
        if about is not None:
            half = np.minimum(0.5 * width, 0.5 * (hi - lo))
            centre = np.clip(np.asarray(about, float), lo + half, hi - half)
        limit_lo, limit_hi = np.array([s.internal_limits() for s in self.specs]).T
        new_lo = np.maximum(centre - 0.5 * width, limit_lo)
        new_hi = np.minimum(centre + 0.5 * width, limit_hi)
        specs = []
        for s, a, b in zip(self.specs, new_lo, new_hi):
            bounds = (float(10.0**a), float(10.0**b)) if s.log else (float(a), float(b))
            default = min(max(s.default, bounds[0]), bounds[1])
            specs.append(replace(s, bounds=bounds, default=default))
        out = copy.copy(self)
        scaled = {s.name: s for s in specs}
        out.specs = specs
        out.all_specs = [scaled.get(s.name, s) for s in self.all_specs]
        return out

    def warm_started(self, internal) -> FitProblem:
        """A copy of this problem whose chain solver starts at the currents of ``internal``.

        The copy's start is fixed once, so its evaluations do not depend on their history;
        only convergence speed changes, but a root found from another start differs within
        the solver's tolerance, so this problem itself is left cold (its predictions, and
        every number reported from them, must not depend on what ran before).
        """
        warm = copy.copy(self)
        warm.warm_current = self.core_currents(internal)
        return warm

    def core_currents(self, internal):
        """Peak winding current at each data row for one internal vector (the chain's operating point)."""
        values = self.full_natural(np.asarray(internal, float))
        m_theta = np.array([float(values[s.name]) for s in self.model.params])
        c_theta = np.array(
            [1.0 if s.name in PER_TABLE else float(values[s.name]) for s in self.chain.params]
        )
        d = self.data
        return np.asarray(
            self.chain.core_current(
                self.model, d.amplitude, d.frequency, d.source_impedance, m_theta, c_theta
            )
        )

    def limit_warnings(self, internal) -> list[str]:
        """The model's :meth:`~fitdf.models.base.HysteresisModel.limit_warnings` at one internal
        vector, at the peak core currents of the data rows (the chain's operating point)."""
        values = self.full_natural(np.asarray(internal, float))
        theta = {s.name: float(values[s.name]) for s in self.model.params}
        return self.model.limit_warnings(self.core_currents(internal), **theta)

    # ---------------------------------------------------------------- residuals
    def error_components(self, predicted):
        """Magnitude error ``|M| - |D|`` and phase error times ``|D|`` (the arc on the
        measured circle; module docstring), each of the shape of ``predicted``."""
        return error_components(predicted, self.data.measured)

    def with_row_scales(self, magnitude, arc) -> FitProblem:
        """A copy whose weighted residuals use these per-row scales (DF units): a weighted
        least-squares step of a fitted noise law."""
        out = copy.copy(self)
        out.row_scales = (np.asarray(magnitude, float), np.asarray(arc, float))
        return out

    def scales(self, sigma_magnitude=None, sigma_phase_deg=None):
        """Magnitude and arc (``|D|`` x phase) noise scales per row (broadcast against batches);
        without arguments, the row scales of :meth:`with_row_scales` where they are set."""
        if sigma_magnitude is None and sigma_phase_deg is None and self.row_scales is not None:
            return self.row_scales
        sm = (
            self.noise.sigma_magnitude
            if sigma_magnitude is None
            else np.asarray(sigma_magnitude)[..., None]
        )
        sp = (
            self.noise.sigma_phase_deg
            if sigma_phase_deg is None
            else np.asarray(sigma_phase_deg)[..., None]
        )
        tang = np.hypot(
            np.abs(self.data.measured) * np.deg2rad(sp), self.noise.floor * np.ones_like(sm)
        )
        return sm, tang

    def prior_residuals(self, internal):
        """``(x - centre) / sigma`` of each prior, shape ``(..., n_priors)`` (may be empty)."""
        internal = np.asarray(internal, float)
        cols = [
            (internal[..., self.names.index(name)] - centre) / sigma
            for name, (centre, sigma) in self.priors.items()
        ]
        return np.stack(cols, axis=-1) if cols else np.zeros(internal.shape[:-1] + (0,))

    def objective_residuals(self, internal):
        """Data residuals and prior residuals: what least squares minimises (a penalised chi-square)."""
        return self.objective_residuals_from(internal, self.predict(internal))

    def objective_residuals_from(self, internal, predicted):
        """:meth:`objective_residuals` at ``internal`` from its prediction ``predicted``."""
        return np.concatenate([self._weighted(predicted), self.prior_residuals(internal)], axis=-1)

    @property
    def output_scale_indices(self) -> list[int]:
        """Positions in the internal vector of the parameters that only scale the prediction
        (the per-table calibration gains, applied after the chain): a change of them is a
        rescaling of rows, which needs no new solve of the chain (:meth:`rescaled`)."""
        return [i for i, s in enumerate(self.specs) if parameter_base(s.name) in PER_TABLE]

    def rescaled(self, predicted, internal_from, internal_to):
        """The prediction at ``internal_to`` from the prediction ``predicted`` at
        ``internal_from``, where the two differ only in :attr:`output_scale_indices`
        (batch-aware: the vectors broadcast against each other)."""
        n = self.data.n
        before = self._gain_per_row(self.full_natural(internal_from), n, None)
        after = self._gain_per_row(self.full_natural(internal_to), n, None)
        return predicted * (after / before)

    def log_prior(self, internal):
        """Log of the Gaussian priors (up to a constant), for MCMC."""
        return -0.5 * np.sum(self.prior_residuals(internal) ** 2, axis=-1)

    def weighted_residuals(self, internal):
        """Residual vector ``[magnitude/sigma_m, arc/sigma_t]`` of length ``2n``."""
        return self._weighted(self.predict(internal))

    def _weighted(self, predicted):
        magnitude, arc = self.error_components(predicted)
        sm, st = self.scales()
        return np.concatenate([magnitude / sm, arc / st], axis=-1)

    def pointwise_loglike(self, internal, sigma_magnitude=None, sigma_phase_deg=None):
        """Gaussian log-likelihood per row (batch-aware), for MCMC and PSIS-LOO/WAIC."""
        radial, tang = self.error_components(self.predict(internal))
        sr, st = self.scales(sigma_magnitude, sigma_phase_deg)
        return (
            -0.5 * ((radial / sr) ** 2 + (tang / st) ** 2)
            - np.log(sr)
            - np.log(st)
            - np.log(2.0 * np.pi)
        )
