"""Physical plausibility of a simulation (issue 25): a wall that cannot hold the cable, a cable
outside its lumen, a work balance that does not close.

Three checks, each stated with its threshold:

``check_wall_stiffness`` (before the run, refusal)
    The wall must hold the cable's bending force: a cable of bending stiffness ``EI`` forced
    round a bend of curvature ``kappa`` presses on the wall with about ``F = EI kappa^2 / 2``
    (the push force round a frictionless arc, docs/validation.md, mechanics.md 1), which a wall
    of stiffness ``k`` per contact point takes up by a sink ``F / k``. A sink estimated above
    :data:`SINK_REFUSE_RADII` lumen radii cannot give a position in the lumen: the scene is
    refused, naming the wall stiffness that holds the cable and the paper's values. Sinks
    between 10 % of the clearance and that are left to the run's own penetration warning and
    failure (:mod:`ringqa.simulation.solvers.driver`), which measure instead of estimate.
``outside_lumen`` (after the run, failed status)
    Every recorded source centre and cable tip is compared with the lumen: a point farther
    from the centreline than the lumen radius ``r_b`` there plus :data:`OUTSIDE_MARGIN_M` is
    outside the channel, whatever the solver's status (issue 25: a 1e-3 N/m wall gave source
    positions 50 mm outside a 1.5 mm lumen with status "jammed" and no warning). The run's
    status becomes failed (-1).
``work_balance_warning`` (after the run, warning)
    The input work (push force x advance) must equal the change of stored energy plus the work
    dissipated (friction, damping, stabilisation) and the kinetic energy. A relative error above
    :data:`WORK_BALANCE_WARN` means the load steps do not follow the equilibrium path: with a
    stiff wall the contact force changes over a sink of ``F / k`` (nanometres at 1e7 N/m), so an
    increment of a millimetre steps over the path's snap-throughs and the forces at the
    recorded advances are those of a state off the path (ring26-flexitron, frictionless, 1 mm
    increments: 43 % at 1e6 N/m per contact point, 71 % at 1e7 with push forces up to 4x those
    of the paper's wall; it closes to 0.09 % at 0.1 mm (1e6) and to 0.0 % at 0.03 mm (1e7):
    docs/engine.md). The shipped scenes close to <= 1.3 % (the dynamic one; the quasi-static
    ones <= 0.3 %).

The paper's wall stiffness (Straathof et al., Med Phys 2024, Table 1) is named in every
message: 1e5 N/m per contact point for the Flexitron cable, 1e6 N/m for the catheter.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ringqa.errors import SceneError

#: A point (source centre, cable tip) farther than this beyond the lumen wall r_b is outside
#: the channel (m): the engine's accuracy goal, 0.05 mm (docs/simulate.md, the benchmark).
OUTSIDE_MARGIN_M = 0.05e-3
#: A work balance error (relative) above this is reported as a warning.
WORK_BALANCE_WARN = 0.05
#: A wall whose estimated sink under the cable's bending force exceeds this many lumen radii is
#: refused before the run (it cannot hold the cable in the lumen).
SINK_REFUSE_RADII = 10.0
#: Above this wall stiffness (N/m per contact point; the paper's Flexitron value) the work balance
#: warning names the stiff wall as the likely cause.
STIFF_WALL_N_M = 1.0e5
#: How the work balance warning starts (the commissioning run names it ``simulation.work_balance``).
WORK_BALANCE_TEXT = "the work balance does not close"
#: The paper's wall stiffness, for the messages.
PAPER_STIFFNESS = (
    "the paper's value is 1e5 N/m per contact point for the Flexitron cable, 1e6 N/m for the "
    "catheter (Straathof et al. 2024, Table 1; the presets' defaults)"
)


def flexible_ei_nm2(ei) -> float:
    """The largest finite positive bending stiffness in ``ei`` (N m^2; 0 if none): rigid links
    (``inf``) and sections marked rigid are left out by the callers."""
    ei = np.asarray(ei, dtype=float).reshape(-1)
    ei = ei[np.isfinite(ei) & (ei > 0)]
    return float(ei.max()) if ei.size else 0.0


def bending_force(ei_nm2: float, table) -> tuple[float, float]:
    """``(F, kappa)``: the force (N) with which a cable of bending stiffness ``ei_nm2`` (N m^2)
    presses on the wall of the channel's tightest bend (curvature kappa, 1/m, from the run's
    :class:`~ringqa.simulation.channel.ChannelTable`), ``F = EI kappa^2 / 2``; 0 on a straight
    channel."""
    kappa = np.asarray(table.kappa, dtype=float)
    kappa = kappa[np.isfinite(kappa)]
    if kappa.size == 0 or not ei_nm2 > 0:
        return 0.0, 0.0
    c = float(kappa.max())
    return 0.5 * float(ei_nm2) * c**2, c


def check_wall_stiffness(scene, table, clearance_m: float, ei_nm2: float) -> None:
    """Refuse a wall too soft to hold the cable in the lumen (module docstring).

    Parameters
    ----------
    scene : Scene
        The scene (``contact.stiffness_n_m``, ``effects.contact``).
    table : ringqa.simulation.channel.ChannelTable
        The run's channel table (curvature, lumen segments).
    clearance_m : float
        The smallest clearance r_b - r_o (m).
    ei_nm2 : float
        The largest bending stiffness of the modelled flexible cable (N m^2;
        :func:`flexible_ei_nm2`).

    Raises
    ------
    SceneError
        Naming ``contact.stiffness_n_m``, the estimated sink, the stiffness that holds the cable
        to a tenth of the clearance and the paper's values.
    """
    if not scene.effects.contact:
        return
    k = float(scene.contact.stiffness_n_m)
    force, kappa = bending_force(ei_nm2, table)
    ei = float(ei_nm2)
    r_b = float(np.min(table.seg_rb))
    if force <= 0.0 or force / k <= SINK_REFUSE_RADII * r_b:
        return
    k_fit = force / (0.1 * clearance_m)
    raise SceneError(
        f"contact.stiffness_n_m = {k:g} N/m is too soft for this cable: bent round the "
        f"channel's tightest bend (radius {1e3 / kappa:.3g} mm) the cable (EI {ei:.3g} N m^2) "
        f"presses on the wall with about EI/(2 R^2) = {force:.3g} N and would sink "
        f"{force / k * 1e3:.3g} mm into it, more than {SINK_REFUSE_RADII:g} lumen radii "
        f"({SINK_REFUSE_RADII * r_b * 1e3:.3g} mm): no position would lie in the lumen; use "
        f">= {k_fit:.2g} N/m (a sink of a tenth of the clearance); {PAPER_STIFFNESS}"
    )


@dataclass(frozen=True)
class OutsideLumen:
    """The point of a result farthest outside its lumen.

    Attributes
    ----------
    beyond_m : float
        How far beyond the lumen wall ``r_b`` (m).
    offset_m : float
        Its distance from the centreline (m).
    r_b_m : float
        The lumen radius there (m).
    advance_mm : float
        The requested advance where it was recorded (mm).
    what : str
        "source centre" or "cable tip".
    """

    beyond_m: float
    offset_m: float
    r_b_m: float
    advance_mm: float
    what: str


def outside_lumen(table, s_m, offset_m, tip_pos_m, advances_mm) -> OutsideLumen | None:
    """The recorded point farthest beyond the lumen wall plus :data:`OUTSIDE_MARGIN_M`, or None.

    Parameters
    ----------
    table : ringqa.simulation.channel.ChannelTable
        The run's channel table (centreline samples and lumen segments).
    s_m, offset_m : (n,) ndarray
        Arc length of the centreline point closest to each recorded source centre and its
        distance from it (m; the recorder's ``s_m``, ``offset_m``; NaN: not reached, skipped).
    tip_pos_m : (n, 3) ndarray or None
        The cable's tip at the recorded advances (m).
    advances_mm : (n,) ndarray
        The recorded advances (mm).

    Notes
    -----
    The distance is to the closest centreline point (its straight extensions beyond the ends
    included, where the engine's lumen continues) and the wall is the lumen's circle ``r_b``
    there; a U-shaped lumen's flat side only narrows it, so this never calls a point inside the
    lumen outside. The source centre and the tip are checked (the chain's nodes in between are
    covered by the run's penetration check).
    """
    s = np.asarray(s_m, dtype=float).reshape(-1)
    d = np.asarray(offset_m, dtype=float).reshape(-1)
    n = s.size
    what = ["source centre"] * n
    rows = list(range(n))
    if tip_pos_m is not None:
        from ringqa.simulation._kernels import closest_rows  # numba: only where tips are checked

        tips = np.asarray(tip_pos_m, dtype=float).reshape(-1, 3)
        keep = np.flatnonzero(np.isfinite(tips).all(axis=1))
        # ChannelTable.closest of every finite tip, in one compiled call
        ts = np.empty(keep.size)
        td = np.empty(keep.size)
        closest_rows(table.h, table.pos, table.tan, np.ascontiguousarray(tips[keep]), ts, td)
        what += ["cable tip"] * keep.size
        rows += [int(k) for k in keep]
        s = np.r_[s, ts]
        d = np.r_[d, td]
    ok = np.isfinite(s) & np.isfinite(d)
    if not ok.any():
        return None
    seg = np.clip(np.searchsorted(table.seg_s, s[ok], side="right") - 1, 0, table.seg_rb.size - 1)
    r_b = np.asarray(table.seg_rb, dtype=float)[seg]
    beyond = d[ok] - r_b
    i = int(np.argmax(beyond))
    if not beyond[i] > OUTSIDE_MARGIN_M:
        return None
    j = int(np.flatnonzero(ok)[i])
    adv = np.asarray(advances_mm, dtype=float).reshape(-1)
    return OutsideLumen(
        beyond_m=float(beyond[i]),
        offset_m=float(d[j]),
        r_b_m=float(r_b[i]),
        advance_mm=float(adv[rows[j]]) if rows[j] < adv.size else float("nan"),
        what=what[j],
    )


def outside_message(out: OutsideLumen, stiffness_n_m: float, paper: bool = True) -> str:
    """The failed run's message for a point outside the lumen (``paper``: name the paper's
    wall stiffness)."""
    ref = f"; {PAPER_STIFFNESS}" if paper else ""
    return (
        f"the {out.what} lies {out.offset_m * 1e3:.2f} mm from the centreline at advance "
        f"{out.advance_mm:.2f} mm, {out.beyond_m * 1e3:.2f} mm outside the lumen "
        f"(r_b {out.r_b_m * 1e3:.2f} mm, {OUTSIDE_MARGIN_M * 1e3:g} mm allowed): the cable left "
        f"the channel, so its positions mean nothing (contact.stiffness_n_m = "
        f"{stiffness_n_m:g} N/m does not hold it{ref})"
    )


def work_balance_warning(work: dict, scene, n_stabilised: int) -> str:
    """The warning for a work balance error above :data:`WORK_BALANCE_WARN` ("" below it).

    Parameters
    ----------
    work : dict
        The run's work balance (``input``, ``elastic``, ..., ``balance_error``; J).
    scene : Scene
        The scene (solver and contact settings, for the message).
    n_stabilised : int
        Load steps that needed the fallback stabilisation.
    """
    err = float(work.get("balance_error", 0.0))
    if not err > WORK_BALANCE_WARN:
        return ""
    k = float(scene.contact.stiffness_n_m)
    if scene.solver.kind == "dynamic":
        step = f"solver.time_step_s = {scene.solver.time_step_s:g} s"
    else:
        step = f"solver.increment_mm = {scene.solver.increment_m * 1e3:g} mm"
    keys = ("elastic", "friction", "damping", "stabilisation", "kinetic")
    spent = sum(float(work.get(key, 0.0)) for key in keys)
    snaps = f", {n_stabilised} of them stabilised" if n_stabilised else ""
    if k > STIFF_WALL_N_M:
        why = (
            f"With a stiff wall (contact.stiffness_n_m = {k:g} N/m) the contact force changes "
            "within a sink of force / stiffness, far less than one step, and a step jumps over "
            "the path's snap-throughs: halve the step until the balance error stays below "
            f"{100 * WORK_BALANCE_WARN:g} %, or use a softer wall ({PAPER_STIFFNESS})"
        )
    else:
        why = (
            "The step is too coarse for the path's snap-throughs (or reversals of friction): "
            f"halve it until the balance error stays below {100 * WORK_BALANCE_WARN:g} %"
        )
    return (
        f"{WORK_BALANCE_TEXT}: the input work {work.get('input', 0.0):.3g} J "
        f"differs from the stored, dissipated and kinetic energy by {100 * err:.0f} % "
        f"(more than {100 * WORK_BALANCE_WARN:g} %; about {spent:.3g} J accounted): the load "
        f"steps ({step}{snaps}) do not follow the equilibrium path, so the push and contact "
        f"forces and the positions at the recorded advances may be far off. {why}"
    )


def checked_result(result, scene, table):
    """``result`` after the monitor's checks (for an engine that does not run them itself: the
    flexible one; the rigid driver runs the same checks while composing its message).

    Parameters
    ----------
    result : SimResult
        A finished run.
    scene : Scene
        Its scene.
    table : ringqa.simulation.channel.ChannelTable
        Its channel table.

    Returns
    -------
    SimResult
        Failed (status -1, the message saying where the cable left the lumen, the original
        message kept) when a recorded source centre or tip lies outside the lumen; the work
        balance warning added when the balance does not close.
    """
    status, message = int(result.status), str(result.message)
    out = outside_lumen(table, result.s_m, result.offset_m, result.tip_pos_m, result.advances_mm)
    if out is not None:
        why = outside_message(out, float(scene.contact.stiffness_n_m))
        message = f"{why}; {message}"
        status = -1
    warnings = tuple(result.warnings)
    n_stab = int(getattr(result.stats, "n_stabilised_steps", 0))
    unbalanced = work_balance_warning(dict(result.work), scene, n_stab)
    if unbalanced:
        warnings = (*warnings, unbalanced)
    if status == result.status and warnings == tuple(result.warnings):
        return result
    return replace(result, status=status, message=message, warnings=warnings)
