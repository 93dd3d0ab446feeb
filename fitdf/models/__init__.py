"""Registry of the candidate hysteresis laws (name -> model class); one law per module."""

from __future__ import annotations

import difflib

from fitdf.errors import ModelError
from fitdf.models.base import HysteresisModel
from fitdf.models.constant_width import ConstantWidth
from fitdf.models.cubic_hc import CubicHc
from fitdf.models.frequency_hc import FrequencyHc
from fitdf.models.jiles_atherton import JilesAtherton
from fitdf.models.preisach import Preisach
from fitdf.models.preisach_rayleigh import PreisachRayleigh
from fitdf.models.proportional_width import ProportionalWidth, ProportionalWidthFig42
from fitdf.models.rayleigh import Rayleigh

__all__ = [
    "HysteresisModel",
    "MODELS",
    "ADDITIONAL_MODELS",
    "get_model",
    "model_names",
    "law_name",
]

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

#: Laws available by name (``fitdf fit --models``, :func:`get_model`) but not in the default
#: set that reports, rankings and listings fit when no law is named.
ADDITIONAL_MODELS: dict[str, type[HysteresisModel]] = {cls.name: cls for cls in (PreisachRayleigh,)}


def model_names() -> list[str]:
    """The default laws (:data:`MODELS`), in order."""
    return list(MODELS)


def law_name(name: str) -> str:
    """The registered law ``name`` names, in any case (``"Preisach"`` -> ``"preisach"``); a
    :class:`ModelError` otherwise, suggesting the nearest name when one is close."""
    text = str(name)
    by_lower = {n.lower(): n for n in (*MODELS, *ADDITIONAL_MODELS)}
    if text.strip().lower() in by_lower:
        return by_lower[text.strip().lower()]
    close = difflib.get_close_matches(text.strip().lower(), list(by_lower), n=1, cutoff=0.6)
    hint = f" (did you mean {by_lower[close[0]]!r}?)" if close else ""
    shown = text if len(text) <= 40 else text[:37] + "..."
    raise ModelError(
        f"unknown law {shown!r}{hint}; known laws: {', '.join((*MODELS, *ADDITIONAL_MODELS))}"
    )


def get_model(name) -> type[HysteresisModel]:
    """Model class by name, in any case (:func:`law_name`; a class passes through)."""
    if isinstance(name, type) and issubclass(name, HysteresisModel):
        return name
    name = law_name(name)
    return MODELS[name] if name in MODELS else ADDITIONAL_MODELS[name]
