"""Registry of the candidate hysteresis laws (name -> model class)."""
from __future__ import annotations

from ..errors import ModelError
from .base import HysteresisModel

__all__ = ["HysteresisModel", "MODELS", "get_model", "model_names"]

MODELS: dict[str, type[HysteresisModel]] = {}


def _register(*classes):
    for cls in classes:
        MODELS[cls.name] = cls


def _load():
    # Imported lazily in one place so adding a law is one line here.
    from .constant_width import ConstantWidth
    from .proportional_width import ProportionalWidth, ProportionalWidthFig42
    from .cubic_hc import CubicHc
    from .rayleigh import Rayleigh
    from .frequency_hc import FrequencyHc

    _register(ConstantWidth, ProportionalWidth, ProportionalWidthFig42, CubicHc, Rayleigh, FrequencyHc)


def model_names() -> list[str]:
    if not MODELS:
        _load()
    return list(MODELS)


def get_model(name) -> type[HysteresisModel]:
    """Model class by name (a class passes through)."""
    if isinstance(name, type) and issubclass(name, HysteresisModel):
        return name
    names = model_names()
    if name not in MODELS:
        raise ModelError(f"unknown model {name!r}; known models: {', '.join(names)}")
    return MODELS[name]
