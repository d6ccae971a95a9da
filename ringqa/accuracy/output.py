"""What a study writes: ``accuracy.csv``, ``reference.csv``, ``recommended.toml``, ``study.json``.

The files are written atomically into the study's folder (with the figure of
:mod:`ringqa.accuracy.figure`). The run cache ``runs.jsonl`` is appended to in the folder itself
while the study runs (so an interrupted study resumes) and carried into the new folder when the
folder is replaced (:func:`ringqa.outdir.staged_output`'s ``ours``).
"""

from __future__ import annotations

import math
from pathlib import Path

from ringqa.accuracy.cache import CACHE_NAME, engine_fingerprint
from ringqa.accuracy.figure import plot_study
from ringqa.accuracy.result import AccuracyStudy, recommendation_summary
from ringqa.jsonio import to_jsonable, write_json
from ringqa.outdir import atomic_write_text, staged_output
from ringqa.provenance import Provenance
from ringqa.simulation.scenefile import scene_to_dict, scene_with_overrides

CSV_NAME = "accuracy.csv"
PNG_NAME = "accuracy.png"
TOML_NAME = "recommended.toml"
REFERENCE_CSV = "reference.csv"


def write_study(study: AccuracyStudy, scene, out_dir: str | Path) -> None:
    """Write ``accuracy.csv``, ``reference.csv``, ``accuracy.png``, ``recommended.toml`` and
    ``study.json`` into ``out_dir`` (atomically; the run cache is carried over beside them)."""
    with staged_output(out_dir, ours=(CACHE_NAME,)) as stage:
        study.table.to_csv(stage / CSV_NAME, index=False, float_format="%.6g")
        import pandas as pd

        pd.DataFrame([lv.csv_row() for lv in study.reference.levels]).to_csv(
            stage / REFERENCE_CSV, index=False, float_format="%.6g"
        )
        plot_study(study, stage / PNG_NAME)
        if study.recommended_overrides is not None:
            write_recommended(study, scene, stage / TOML_NAME)
        info = {
            "scene": study.scene_name,
            "target_mm": study.target_mm,
            "recommended": study.recommended,
            "recommended_overrides": study.recommended_overrides,
            "reference": {
                "converged": study.reference.converged,
                "agreement_mm": study.reference.agreement_mm,
                "smallest_error_mm": study.reference.smallest_error_mm,
                "criterion": study.reference.criterion,
                "tail_estimate_mm": study.reference.tail_estimate_mm,
                "ratio": study.reference.ratio,
                "levels": list(study.reference.levels),
            },
            "recommendations": recommendation_summary(study),
            "dose_points": study.dose_points,
            "engine_fingerprint": engine_fingerprint(),
            "warnings": list(study.warnings),
            "provenance": Provenance.now(settings={"scene": study.scene_name}).as_dict(),
        }
        write_json(stage / "study.json", info, indent=2)


def write_recommended(study: AccuracyStudy, scene, path: Path) -> None:
    """``recommended.toml``: the scene with the recommended settings, commented header."""
    import tomli_w

    rec_scene = scene_with_overrides(scene, study.recommended_overrides or {})
    row = study.recommended or {}
    header = [
        f"# ringqa accuracy: cheapest settings meeting {study.target_mm:g} mm for {scene.name}",
        f"# claimed: max dwell error {row.get('max_err_mm', math.nan):.4g} mm, "
        f"{row.get('max_err_deg', math.nan):.3g} deg; "
        f"solve time {row.get('time_s', math.nan):.4g} s",
        f"# settings: {row.get('label', '')}",
        f"# reference converged: {study.reference.converged} "
        f"(two finest levels agree to {study.reference.agreement_mm:.3g} mm)",
    ]
    data = scene_to_dict(rec_scene)
    data["description"] = (
        f"recommended by ringqa accuracy for {study.target_mm:g} mm: {row.get('label', '')}"
    )
    atomic_write_text(path, "\n".join(header) + "\n" + tomli_w.dumps(to_jsonable(data)))
