"""The tolerance checks: position and dose limits, the verdicts, and what each one means.

Positions: 1 mm recommended / 2 mm required (AAPM MPPG 13.a, 2023; TG-56); doses: an action
level on the largest dose difference at the standard dose points (default 5 %); the simulation's
numerical error: a warning above 0.1 mm; for an RT Plan, its own dwells and times dosed by ringqa
against the TPS's doses at the plan's points: an action level of 5 % (an input check: a wrong
source strength, channel time or source model shows here first).

Two kinds of finding are kept apart in the wording: "centreline vs reference" is a finding about
the TPS's source-path model (planning on the channel centreline); "simulated vs reference" is a
check of the simulation. One conclusion line sums them up (:func:`conclusion`). Reference
positions outside the channel are left out of the checks; infeasible ones are named.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ringqa.pipeline.deviations import Deviations
from ringqa.pipeline.doses import StandardPlans
from ringqa.pipeline.numbers import DOSE_PCT, ERROR_MM, fmt, fmt_verdict_value
from ringqa.pipeline.result import Verdict

#: Action level of the RT Plan's own doses against the TPS's, %: the independent dose check of
#: an HDR plan (AAPM TG-56 asks for a secondary check; 5 % is the usual action level). ringqa and
#: the TPS use the same TG-43 formalism and consensus data, so they agree within about 1 % when
#: the plan was read right (the shipped example: 0.3-1.0 %).
TPS_CHECK_ACTION_PCT = 5.0

#: Verdict roles.
ROLE_TPS = "TPS model"
ROLE_SIMULATION = "simulation check"
ROLE_NUMERICS = "numerics"
ROLE_INPUT = "input check"

#: Check names (results.json ``check``).
CHECK_CENTRELINE = "position: centreline vs reference"
CHECK_SIMULATED = "position: simulated vs reference"
CHECK_SIM_VS_CENTRELINE = "position: simulated vs centreline"
CHECK_NUMERICS = "numerics: simulated positions"
CHECK_TPS = "dose: plan's own dwells vs TPS"


def _position_verdict(check: str, role: str, what_is: str, dist_mm: np.ndarray, rec: float,
                      req: float, extra: str) -> Verdict:  # fmt: skip
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
    text = f"{what_is}: max {fmt(worst)} mm over {dist_mm.size} positions, {what}.{extra}"
    return Verdict(check, worst, "mm", (rec, req), status, text, role)


def _dose_verdict(check: str, role: str, what_is: str, diff_pct: np.ndarray,
                  action: float) -> Verdict:  # fmt: skip
    worst = float(np.max(np.abs(diff_pct))) if diff_pct.size else 0.0
    status = "PASS" if worst <= action else "ACTION"
    word = "within" if status == "PASS" else "beyond"
    return Verdict(
        check, worst, "%", (action,), status,
        f"{what_is}: max |dose difference| {fmt(worst, DOSE_PCT)} %, {word} the {action:g} % "
        "action level.",
        role,
    )  # fmt: skip


def tps_verdict(doses: pd.DataFrame, action_pct: float = TPS_CHECK_ACTION_PCT) -> Verdict | None:
    """The RT Plan's own dwells and times, dosed by ringqa, against the TPS's doses at the plan's
    points (rows ``plan == "rtplan"`` with a TPS dose); None without such rows.

    Parameters
    ----------
    doses : pandas.DataFrame
        The dose table (``plan``, ``point``, ``diff_pct``, ``tps_dose_gy``).
    action_pct : float
        Action level on the largest |difference|, %.
    """
    own = doses[(doses["plan"] == "rtplan") & np.isfinite(doses["tps_dose_gy"].astype(float))]
    if own.empty:
        return None
    diff = own["diff_pct"].to_numpy(dtype=float)
    at = own["point"].iloc[int(np.argmax(np.abs(diff)))]
    return _dose_verdict(
        CHECK_TPS, ROLE_INPUT,
        f"The plan's own dwells and times, dosed by ringqa, vs the TPS's doses at the plan's "
        f"{len(own)} points (largest at {at})",
        diff, action_pct,
    )  # fmt: skip


def numerics_verdict(max_error_mm: float, warn_mm: float, cross_check=None) -> Verdict:
    """PASS when the simulation's numerical error (max over the dwells) is at most ``warn_mm``,
    else WARN; FAIL when the cross-check (``cross_check.fails``: the flexible-element engine
    disagrees with the reported dwells by more than the numerical errors allow)."""
    status = "PASS" if max_error_mm <= warn_mm else "WARN"
    word = "within" if status == "PASS" else "above"
    shown = fmt_verdict_value(max_error_mm, "mm", CHECK_NUMERICS)
    text = f"Numerical error of the simulated positions: max {shown}, {word} {warn_mm:g} mm."
    if cross_check is not None and getattr(cross_check, "fails", False):
        status = "FAIL"
        text += (
            f" The independent flexible-element engine disagrees by up to "
            f"{fmt(cross_check.max_mm, ERROR_MM)} mm (allowed {fmt(cross_check.limit_mm)} mm)."
        )
    return Verdict(
        CHECK_NUMERICS, max_error_mm, "mm", (warn_mm,), status, text, ROLE_NUMERICS,
    )  # fmt: skip


def _v(v: Verdict) -> str:
    """A verdict's value as every page prints it (:mod:`ringqa.pipeline.numbers`)."""
    return fmt_verdict_value(v.value, v.unit, v.check)


def verdict_meanings(verdicts) -> list[str]:
    """What a physicist should conclude from the verdicts that are not PASS (report notes)."""
    out = []
    for v in verdicts:
        if v.status == "PASS":
            continue
        if v.check == CHECK_TPS:
            out.append(
                f"TPS check {v.status}: the plan's own dwells and times, dosed with ringqa's "
                f"TG-43 data, differ from the TPS's doses by up to {_v(v)}. Check the "
                "plan's source strength (S_K), channel times and source model before trusting any "
                "dose number in this report."
            )
        elif v.check == CHECK_CENTRELINE:
            out.append(
                f"Centreline vs reference {v.status} (a finding about the TPS model): planning on "
                f"the channel centreline would misplace dwells by up to {_v(v)} in this "
                "applicator; plan on the reference source path (or a validated source-path "
                "model) instead."
            )
        elif v.check == CHECK_SIMULATED:
            out.append(
                f"Simulated vs reference {v.status} (a check of the simulation): the simulation "
                f"does not reproduce the reference path within tolerance (max {_v(v)}); "
                "it cannot stand in for the reference path of this applicator."
            )
        elif v.check == CHECK_SIM_VS_CENTRELINE:
            out.append(
                f"Simulated vs centreline {v.status}: the simulated source deviates from the "
                f"centreline by up to {_v(v)}; measure the source path of this "
                "applicator before planning on its centreline."
            )
        elif v.check == CHECK_NUMERICS:
            out.append(
                f"Numerics {v.status}: the simulated positions carry an error of up to {_v(v)} "
                "(the numerical settings and the modelling cuts it includes, e.g. the simulated "
                "stem: see the numerical check); simulated-vs-reference differences of that size "
                "are within what the simulation can tell apart."
            )
        elif v.check.startswith("dose:"):
            out.append(
                f"{v.check} {v.status}: the dwell-position differences change the dose at the "
                f"dose points by up to {_v(v)} (lateral ring-surface points are the most "
                "sensitive; see the dose table)."
            )
    return out


def conclusion(verdicts) -> str:
    """One line: what the run says about the TPS model and about the simulation."""
    by = {v.check: v for v in verdicts}
    parts = []
    cl = by.get(CHECK_CENTRELINE)
    if cl is not None:
        parts.append(
            "planning on the centreline is within tolerance"
            if cl.status == "PASS"
            else f"planning on the centreline misplaces dwells by up to {_v(cl)} ({cl.status})"
        )
    sim = by.get(CHECK_SIMULATED) or by.get(CHECK_SIM_VS_CENTRELINE)
    if sim is not None:
        against = "reference path" if sim.check == CHECK_SIMULATED else "centreline"
        parts.append(
            f"the simulation reproduces the {against} within tolerance"
            if sim.status == "PASS"
            else f"the simulation departs from the {against} by up to {_v(sim)} ({sim.status})"
        )
    num = by.get(CHECK_NUMERICS)
    if num is not None and num.status != "PASS":
        parts.append(f"but its numerical error ({_v(num)}) is not negligible")
    tps = by.get(CHECK_TPS)
    if tps is not None and tps.status != "PASS":
        parts.insert(0, f"the plan's own doses differ from the TPS's by {_v(tps)} "
                        "(check S_K, times and source first)")  # fmt: skip
    doses = [v for v in verdicts if v.unit == "%" and v.status != "PASS" and v.check != CHECK_TPS]
    if doses:
        worst = max(doses, key=lambda v: v.value)
        parts.append(f"dose differences reach {_v(worst)} ({worst.check})")
    return "Conclusion: " + "; ".join(parts) + "." if parts else "Conclusion: nothing checked."


def _flag_text(rel_mm: np.ndarray, flags: np.ndarray, compared: np.ndarray) -> str:
    out = ""
    n_out = int(np.count_nonzero(~compared))
    if n_out:
        listed = ", ".join(f"{x:g}" for x in rel_mm[~compared])
        out += f" Left out: {n_out} reference position(s) outside the channel ({listed} mm)."
    bad = flags == "infeasible"
    if bad.any():
        listed = ", ".join(f"{x:g}" for x in rel_mm[bad])
        out += f" Reference positions that cannot lie in the lumen: {listed} mm."
    return out


def check_tolerances(
    ref_kind: str,
    dev: Deviations,
    doses: pd.DataFrame,
    plans: StandardPlans,
    position_limits_mm: tuple[float, float],
    dose_action_pct: float,
    *,
    relative_position_mm: np.ndarray,
    flags: np.ndarray,
    numerical_error_mm: float,
    numerical_warn_mm: float,
    tps_action_pct: float = TPS_CHECK_ACTION_PCT,
    cross_check=None,
) -> tuple[Verdict, ...]:
    """The position verdicts, one dose verdict per compared plan, the RT Plan's own doses vs the
    TPS (when there are any) and the numerics verdict (last).

    Parameters
    ----------
    ref_kind : str
        ``"measured"`` or ``"centreline"``: the reference path and plan.
    dev : Deviations
        The simulated and centreline dwells' deviations from the (registered) reference.
    doses : pandas.DataFrame
        The dose table (TPS points are left out of the dose verdicts; ``diff_registered_pct``
        is judged).
    plans : StandardPlans
        The simulated and centreline plans get a dose verdict, in table order.
    position_limits_mm : (float, float)
        Recommended and required position tolerance, mm.
    dose_action_pct : float
        Dose-difference action level, %.
    relative_position_mm : (n,) ndarray
        The dwells' relative positions (named in the texts).
    flags : (n,) ndarray of str
        ``reference_flag`` per dwell: ``"outside_channel"`` dwells are left out, ``"infeasible"``
        ones named.
    numerical_error_mm : float
        The simulation's numerical error, max over the dwells, mm.
    numerical_warn_mm : float
        Its warning level, mm.
    tps_action_pct : float
        Action level of the RT Plan's own doses against the TPS's, %.
    cross_check : ringqa.pipeline.simulate.CrossCheck or None
        The flexible-element engine's comparison (its ``fails`` makes the numerics FAIL).

    Returns
    -------
    tuple of Verdict
    """
    rec, req = position_limits_mm
    flags = np.asarray(flags, dtype=object)
    compared = flags != "outside_channel"
    extra = _flag_text(np.asarray(relative_position_mm), flags, compared)
    verdicts = []
    if ref_kind == "measured":
        verdicts.append(_position_verdict(
            CHECK_CENTRELINE, ROLE_TPS, "Centreline (the TPS model) vs reference path",
            dev.centreline.dist_mm[compared], rec, req, extra))  # fmt: skip
        verdicts.append(_position_verdict(
            CHECK_SIMULATED, ROLE_SIMULATION, "Simulated vs reference path (simulation check)",
            dev.simulated.dist_mm[compared], rec, req, extra))  # fmt: skip
    else:
        verdicts.append(_position_verdict(
            CHECK_SIM_VS_CENTRELINE, ROLE_SIMULATION, "Simulated vs centreline",
            dev.simulated.dist_mm, rec, req, ""))  # fmt: skip
    std = doses[doses["kind"] != "tps"]
    reference_plan = (
        "the standard plan on the reference path" if ref_kind == "measured"
        else "the standard plan on the centreline"
    )  # fmt: skip
    for plan in (plans.simulated, plans.centreline):
        if plan is None:
            continue
        sub = std[std["plan"] == plan.name]
        role = ROLE_SIMULATION if plan is plans.simulated else ROLE_TPS
        verdicts.append(_dose_verdict(
            f"dose: {plan.name} plan vs reference plan", role,
            f"Same dwell times on the {plan.name} positions vs {reference_plan}",
            sub["diff_registered_pct"].to_numpy(), float(dose_action_pct)))  # fmt: skip
    tps = tps_verdict(doses, tps_action_pct)
    if tps is not None:
        verdicts.append(tps)
    verdicts.append(numerics_verdict(numerical_error_mm, numerical_warn_mm, cross_check))
    return tuple(verdicts)
