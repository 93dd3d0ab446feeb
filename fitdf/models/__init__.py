"""Registry of the candidate hysteresis laws (name -> model class); one law per module."""

from __future__ import annotations

from fitdf.errors import ModelError
from fitdf.models.base import HysteresisModel
from fitdf.models.constant_width import ConstantWidth
from fitdf.models.cubic_hc import CubicHc
from fitdf.models.frequency_hc import FrequencyHc
from fitdf.models.jiles_atherton import JilesAtherton
from fitdf.models.preisach import Preisach
from fitdf.models.proportional_width import ProportionalWidth, ProportionalWidthFig42
from fitdf.models.rayleigh import Rayleigh

__all__ = ["HysteresisModel", "MODELS", "get_model", "model_names"]

#: Registered laws by name, in the order listings and reports show them.
MODELS: dict[str, type[HysteresisModel]] = {
    cls.name: cls
    for cls in (
        ConstantWidth,
        ProportionalWidth,
        ProportionalWidthFig42,
        CubicHc,
        Rayleigh,
        FrequencyHc,
        Preisach,
        JilesAtherton,
    )
}


def model_names() -> list[str]:
    return list(MODELS)


def get_model(name) -> type[HysteresisModel]:
    """Model class by name (a class passes through)."""
    if isinstance(name, type) and issubclass(name, HysteresisModel):
        return name
    if name not in MODELS:
        raise ModelError(f"unknown model {name!r}; known models: {', '.join(MODELS)}")
    return MODELS[name]
