"""A ``results.json`` of an earlier schema read as the current one: :func:`upgrade`.

``results.json`` carries its ``schema_version`` (:data:`SCHEMA_VERSION`; a record without one
is version 1). Version 2 names the posteriors for what they are, whichever sampler drew them
(each fit keeps its ``method``: ``nested`` or ``mcmc``, and ``settings.sampler`` names the
report's):

==================================  ==============================
version 1                           version 2
==================================  ==============================
``settings.methods`` ``lsq, mcmc``  ``lsq, posterior``
``settings.mcmc_top``               ``settings.posterior_top``
``settings.mcmc_skip``              ``settings.posterior_skip``
``blocks.*.fits_mcmc``              ``blocks.*.fits_posterior``
``blocks.*.ranking_mcmc``           ``blocks.*.ranking_posterior``
``blocks.*.order_mcmc``             ``blocks.*.order_posterior``
``timing.mcmc_cv_cross_limit_s``    ``timing.second_phase_s``
==================================  ==============================

and the paths of the fields each stored claim reads (``claims``, :mod:`fitdf.report.claims`)
move with their keys. Every reader of a ``results.json`` reads it through :func:`upgrade`
(the renderers, the claims, the cost table, the tests of the committed report), so a report
written before the renames still renders and its sentences are still made again from their
fields. Version 1 is read for one release.
"""

from __future__ import annotations

import json
from pathlib import Path

__all__ = ["SCHEMA_VERSION", "RENAMED", "upgrade", "upgrade_path", "read_results"]

#: The schema version this code writes.
SCHEMA_VERSION = 2

#: The keys version 2 renamed, by the record they sit in: ``settings``, each block of
#: ``blocks``, ``timing``.
RENAMED = {
    "settings": {"mcmc_top": "posterior_top", "mcmc_skip": "posterior_skip"},
    "blocks/*": {
        "fits_mcmc": "fits_posterior",
        "ranking_mcmc": "ranking_posterior",
        "order_mcmc": "order_posterior",
    },
    "timing": {"mcmc_cv_cross_limit_s": "second_phase_s"},
}
#: ``settings.methods``: version 1 named the posteriors by one sampler.
_METHODS = {"mcmc": "posterior"}


def _renamed(record: dict, names: dict) -> dict:
    """``record`` with its keys renamed by ``names`` (the order kept)."""
    return {names.get(k, k): v for k, v in record.items()}


def upgrade_path(path: str) -> str:
    """A claim's field path (``blocks/B.1/ranking_mcmc/*/looic``) in the current schema."""
    parts = path.split("/")
    if len(parts) > 1 and parts[0] in ("settings", "timing"):
        parts[1] = RENAMED[parts[0]].get(parts[1], parts[1])
    elif len(parts) > 2 and parts[0] == "blocks":
        parts[2] = RENAMED["blocks/*"].get(parts[2], parts[2])
    return "/".join(parts)


def _claims(node):
    """``node`` (the ``claims`` tree) with every claim's field paths upgraded."""
    if isinstance(node, list):
        return [_claims(c) for c in node]
    if not isinstance(node, dict):
        return node
    if "kind" in node and isinstance(node.get("fields"), dict):
        return {**node, "fields": {k: upgrade_path(p) for k, p in node["fields"].items()}}
    return {k: _claims(v) for k, v in node.items()}


def upgrade(results: dict) -> dict:
    """``results`` (a ``results.json`` record) in the current schema.

    A current record is returned as it is (the same object); an older one as a new record
    with its keys renamed (:data:`RENAMED`) and ``schema_version`` set; the input is not
    changed. A record of a later schema than this code's is refused.

    Raises
    ------
    ValueError
        ``results`` was written by a later fitdf (a schema version above :data:`SCHEMA_VERSION`).

    Examples
    --------
    >>> old = {"settings": {"methods": ["lsq", "mcmc"], "mcmc_top": 2},
    ...        "blocks": {"B.1": {"fits_mcmc": {}, "order_mcmc": []}}}
    >>> new = upgrade(old)
    >>> new["schema_version"], new["settings"], sorted(new["blocks"]["B.1"])
    (2, {'methods': ['lsq', 'posterior'], 'posterior_top': 2}, ['fits_posterior', 'order_posterior'])
    """
    version = results.get("schema_version", 1)
    if version == SCHEMA_VERSION:
        return results
    if not isinstance(version, int) or version > SCHEMA_VERSION:
        raise ValueError(
            f"results.json of schema version {version!r}: this fitdf reads versions 1 to "
            f"{SCHEMA_VERSION} (upgrade fitdf)"
        )
    out = {"schema_version": SCHEMA_VERSION, **results}
    out["schema_version"] = SCHEMA_VERSION
    if isinstance(results.get("settings"), dict):
        settings = _renamed(results["settings"], RENAMED["settings"])
        if isinstance(settings.get("methods"), list):
            settings["methods"] = [_METHODS.get(m, m) for m in settings["methods"]]
        out["settings"] = settings
    if isinstance(results.get("blocks"), dict):
        out["blocks"] = {
            key: _renamed(block, RENAMED["blocks/*"]) if isinstance(block, dict) else block
            for key, block in results["blocks"].items()
        }
    if isinstance(results.get("timing"), dict):
        out["timing"] = _renamed(results["timing"], RENAMED["timing"])
    if "claims" in results:
        out["claims"] = _claims(results["claims"])
    return out


def read_results(path) -> dict:
    """The ``results.json`` at ``path`` (a file, or the report folder holding it) in the
    current schema (:func:`upgrade`)."""
    path = Path(path)
    if path.is_dir():
        path = path / "results.json"
    return upgrade(json.loads(path.read_text(encoding="utf-8")))
