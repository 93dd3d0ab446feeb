"""The small-signal study in the report (:mod:`fitdf.report.small_signal_study`), as document
blocks (:mod:`fitdf.report.document`): what it asks, a table per part, and the claims of
:mod:`fitdf.report.small_signal_claims` under each."""

from __future__ import annotations

from fitdf.inference.ranking import log_bayes_factor
from fitdf.report.claims import text
from fitdf.report.document import TABLE, H, P, fmt

__all__ = ["study_blocks", "STUDY"]

STUDY = "The noise of the readings and the low-field law, by the evidence"

_ASK = (
    "The rows the laws miss most are small-signal rows. Two questions, each answered by nested "
    "sampling with the report's sampler settings and seed: were they read with an error that "
    "grows as the input falls (the DF is an output reading divided by the input), and does a "
    "law with the low-field behaviour soft magnetic materials have (Rayleigh's law: a Preisach "
    "density finite at the origin) describe them? The noise laws (docs: the measurement noise "
    "of the printed tables): `constant`, two fitted scales; `reading`, a floor and a reading "
    "resolution in volts of output, so that the DF's error grows as the input falls and the "
    "phase's as the output falls; `student`, constant scales with Student-t tails. Each "
    "noise law's parameters are sampled with the law's, log-uniform on their boxes."
)


def _lnz(run: dict) -> str:
    return f"{run['log_evidence']:.2f} ± {run['log_evidence_error']:.2f}"


def _noise_table(records: list) -> list:
    rows = []
    for rec in records:
        runs = rec["runs"]
        const = runs.get("constant")
        for name, run in runs.items():
            lnb = (
                f"{log_bayes_factor(run, const)[0]:.1f}"
                if const is not None and name != "constant"
                else ""
            )
            noise = ", ".join(f"{k} {fmt(v[1], 3)}" for k, v in run["noise"].items())
            rows.append(
                [
                    rec["block"],
                    rec["law"],
                    name,
                    _lnz(run),
                    lnb,
                    "yes" if run["converged"] else "no",
                    f"{run['n_effective']:.0f}",
                    run["n_likelihood_evaluations"],
                    f"{run['rms_complex']:.4f}",
                    noise,
                ]
            )
    return [
        TABLE(
            [
                "table",
                "law",
                "noise law",
                "ln Z",
                "ln B over constant",
                "converged",
                "effective draws",
                "evaluations",
                "RMS at the point estimate",
                "noise parameters (medians; s_p in deg, r in V)",
            ],
            rows,
        )
    ]


def _low_field_table(records: list) -> list:
    rows = []
    for rec in records:
        post, base = rec["posterior"], rec["base_posterior"]
        rows.append(
            [
                rec["block"],
                f"{rec['lsq']['aicc']:.1f} / {rec['base_lsq']['aicc']:.1f}",
                f"{rec['lsq']['rms_complex']:.4f} / {rec['base_lsq']['rms_complex']:.4f}",
                f"{rec['lsq']['cv_rms_complex']:.4f} / {rec['base_lsq']['cv_rms_complex']:.4f}",
                f"{_lnz(post)} / {_lnz(base)}",
                f"{log_bayes_factor(post, base)[0]:.1f}",
                f"{post['rms_complex']:.4f} / {base['rms_complex']:.4f}",
            ]
        )
    law, base = records[0]["law"], records[0]["base"]
    return [
        P(
            f"`{law}` against `{base}` (each cell: `{law}` / `{base}`; `{base}`'s fits and "
            "posterior are the report's own, `printed` noise):"
        ),
        TABLE(
            [
                "table",
                "AICc",
                "RMS (least squares)",
                "held-out RMS",
                "ln Z",
                "ln B",
                "RMS at the posterior's point estimate",
            ],
            rows,
        ),
    ]


def study_blocks(res: dict, words: dict) -> list:
    """The study's heading, question, tables and claims; a line saying how to add it when the
    report holds none."""
    rec = res.get("small_signal_evidence")
    out = [H(3, STUDY), P(_ASK)]
    if not rec:
        return out + [
            P(
                "Not computed for this report: `python -m fitdf.report.small_signal_study "
                "REPORT` adds it."
            )
        ]
    claims = words["claims"].get("small_signal") or {}
    if rec["noise"]:
        out += _noise_table(rec["noise"])
        out.append(P(text(claims.get("noise") or [])))
        if claims.get("resolutions"):
            out.append(P(text(claims["resolutions"])))
    if rec["low_field"]:
        out += _low_field_table(rec["low_field"])
        out.append(P(text(claims.get("low_field") or [])))
        if claims.get("worst_rows"):
            out.append(P(text(claims["worst_rows"])))
    return out
