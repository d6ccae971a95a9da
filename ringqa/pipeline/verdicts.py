"""The tolerance checks: position and dose limits, the verdicts, and what each one means.

Positions: 1 mm recommended / 2 mm required (AAPM MPPG 13.a, 2023; TG-56); doses: an action
level on the largest dose difference at the standard dose points (default 5 %).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ringqa.pipeline.deviations import Deviations
from ringqa.pipeline.doses import StandardPlans
from ringqa.pipeline.result import Verdict

#: Position tolerances, mm: recommended and required (AAPM MPPG 13.a, 2023; TG-56).
POSITION_RECOMMENDED_MM = 1.0
POSITION_REQUIRED_MM = 2.0
#: Default dose-difference action level, %.
DOSE_ACTION_PCT = 5.0


def _position_verdict(check: str, dist_mm: np.ndarray, rec: float, req: float) -> Verdict:
    worst = float(np.max(dist_mm)) if dist_mm.size else 0.0
    if worst <= rec:
        status, what = "PASS", f"within the recommended {rec:g} mm"
    elif worst <= req:
        status, what = (
            "WARN",
            f"within the required {req:g} mm but above the recommended {rec:g} mm",
        )
    else:
        status, what = "FAIL", f"beyond the required {req:g} mm"
    return Verdict(check, worst, "mm", (rec, req), status, f"{check}: max {worst:.2f} mm, {what}")


def _dose_verdict(check: str, diff_pct: np.ndarray, action: float) -> Verdict:
    worst = float(np.max(np.abs(diff_pct))) if diff_pct.size else 0.0
    status = "PASS" if worst <= action else "ACTION"
    word = "within" if status == "PASS" else "beyond"
    return Verdict(
        check, worst, "%", (action,), status,
        f"{check}: max |difference| {worst:.2f} %, {word} the {action:g} % action level",
    )  # fmt: skip


def verdict_meanings(verdicts) -> list[str]:
    """What a physicist should conclude from the verdicts that are not PASS (report notes)."""
    out = []
    for v in verdicts:
        if v.status == "PASS":
            continue
        if v.check == "position: centreline vs measured":
            out.append(
                f"Centreline vs measured {v.status}: planning on the channel centreline would "
                f"misplace dwells by up to {v.value:.1f} mm in this applicator; plan on the "
                "measured source path (or a validated source-path model) instead."
            )
        elif v.check == "position: simulated vs measured":
            out.append(
                f"Simulated vs measured {v.status}: the simulation does not reproduce the "
                f"measured path within tolerance (max {v.value:.1f} mm); it cannot replace the "
                "measurement for this applicator."
            )
        elif v.check.startswith("position: simulated vs centreline"):
            out.append(
                f"Simulated vs centreline {v.status}: the simulated source deviates from the "
                f"centreline by up to {v.value:.1f} mm; measure the source path of this "
                "applicator before planning on its centreline."
            )
        elif v.check.startswith("dose:"):
            out.append(
                f"{v.check} {v.status}: the dwell-position differences change the dose at the "
                f"dose points by up to {v.value:.1f} % (lateral ring-surface points are the most "
                "sensitive; see the dose table)."
            )
    return out


def check_tolerances(
    ref_kind: str,
    dev: Deviations,
    doses: pd.DataFrame,
    plans: StandardPlans,
    position_limits_mm: tuple[float, float],
    dose_action_pct: float,
) -> tuple[Verdict, ...]:
    """The position verdicts of the compared paths, then one dose verdict per compared plan.

    Parameters
    ----------
    ref_kind : str
        ``"measured"`` or ``"centreline"``: the reference path and plan.
    dev : Deviations
        The simulated and centreline dwells' deviations from the reference.
    doses : pandas.DataFrame
        The dose table (TPS points are left out of the dose verdicts).
    plans : StandardPlans
        Each plan but the reference gets a dose verdict, in table order.
    position_limits_mm : (float, float)
        Recommended and required position tolerance, mm.
    dose_action_pct : float
        Dose-difference action level, %.

    Returns
    -------
    tuple of Verdict
    """
    rec, req = position_limits_mm
    verdicts = []
    if ref_kind == "measured":
        verdicts.append(_position_verdict("position: centreline vs measured",
                                          dev.centreline.dist_mm, rec, req))  # fmt: skip
        verdicts.append(_position_verdict("position: simulated vs measured",
                                          dev.simulated.dist_mm, rec, req))  # fmt: skip
    else:
        verdicts.append(_position_verdict("position: simulated vs centreline",
                                          dev.simulated.dist_mm, rec, req))  # fmt: skip
    std = doses[doses["kind"] != "tps"]
    for plan in plans.in_order[1:]:
        pname = plan.name
        sub = std[std["plan"] == pname]
        verdicts.append(
            _dose_verdict(f"dose: {pname} vs {ref_kind} plan", sub["diff_pct"].to_numpy(),
                          float(dose_action_pct))
        )  # fmt: skip
    return tuple(verdicts)
