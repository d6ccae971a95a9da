"""The reference path, checked against the channel and registered to it (page 1 of the report).

A reference path is what the user (or the vendor's library) says the source does; before anything
is compared with it, :func:`review_reference` asks what :mod:`ringqa.geometry.registration`
asks: can each position lie in the lumen (``infeasible`` otherwise), is it along the channel
(``outside_channel`` otherwise), was the path stored in 2D (planar, at a constant height above the
ring plane)? Then the path is registered to the CHANNEL as the user chose (``--register``: none,
plane-height, rigid), never to the simulation. Positions outside the channel are left out of the
plan and the verdicts; infeasible ones are kept and named in the verdicts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.errors import RingQAError
from ringqa.geometry.frame import frame_of
from ringqa.geometry.registration import (
    FLAG_INFEASIBLE,
    FLAG_OUTSIDE,
    MIN_POSITIONS,
    PLANAR_TOL_M,
    ReferencePathCheck,
    Registration,
    RegistrationError,
    check_reference_path,
    register_reference,
)
from ringqa.pipeline.dwells import PathDwells, ReferenceDwells
from ringqa.plan import path_directions
from ringqa.units import m_to_mm, mm_to_m


@dataclass(frozen=True, eq=False)
class ReferenceReview:
    """The reference path as supplied and as compared.

    Attributes
    ----------
    mode : str
        Registration mode (``"none"``, ``"plane-height"``, ``"rigid"``).
    source : str
        Where the path comes from (library name/version/date, the user's file), or the centreline.
    capsule_radius_mm : float
        Source capsule radius of the feasibility check, mm.
    raw : ReferencePathCheck or None
        The supplied path against the channel (None for a centreline reference).
    registration : Registration or None
        The transform and the registered path's check (None for a centreline reference).
    registered : ReferenceDwells
        The reference as compared (the registered positions; the supplied ones with ``none``).
    flags : (n,) ndarray of str
        Per dwell of the compared path: ``""``, ``"infeasible"`` or ``"outside_channel"``.
    raw_flags : (n,) ndarray of str
        The same for the supplied path.
    """

    mode: str
    source: str
    capsule_radius_mm: float
    raw: ReferencePathCheck | None
    registration: Registration | None
    registered: ReferenceDwells
    flags: np.ndarray
    raw_flags: np.ndarray

    @property
    def compared(self) -> np.ndarray:
        """(n,) bool: dwells compared (not outside the channel)."""
        return self.flags != FLAG_OUTSIDE

    def named(self, flag: str, raw: bool = False) -> str:
        """The relative positions (mm) carrying ``flag``, as text (``"10, 12.5 mm"``), or ``""``."""
        flags = self.raw_flags if raw else self.flags
        rel = self.registered.relative_position_mm[flags == flag]
        return f"{', '.join(f'{x:g}' for x in rel)} mm" if rel.size else ""

    def count(self, flag: str, raw: bool = False) -> int:
        """Number of dwells carrying ``flag`` (in the compared path, or the supplied one)."""
        return int(np.count_nonzero((self.raw_flags if raw else self.flags) == flag))

    def as_dict(self) -> dict:
        """The ``results.json`` ``reference_check`` section (mm, deg)."""
        out: dict = {"registration": self.mode, "source": self.source,
                     "capsule_radius_mm": self.capsule_radius_mm}  # fmt: skip
        if self.raw is None:
            return out
        raw, reg = self.raw, self.registration
        matrix = reg.matrix() if reg is not None else np.eye(4)
        matrix[:3, 3] = m_to_mm(matrix[:3, 3])  # the translation in mm
        out.update(
            planar=bool(raw.planar),
            constant_height=bool(raw.constant_height),
            height_mm=m_to_mm(raw.height_m),
            plane_rms_mm=m_to_mm(raw.plane_rms_m),
            plane_tilt_deg=raw.plane_tilt_deg,
            infeasible_raw=self.named(FLAG_INFEASIBLE, raw=True),
            infeasible=self.named(FLAG_INFEASIBLE),
            outside_channel=self.named(FLAG_OUTSIDE),
            transform_mm=matrix.tolist(),
            description=reg.description if reg is not None else "",
            rms_before_mm=m_to_mm(reg.rms_before_m) if reg is not None else None,
            max_before_mm=m_to_mm(reg.max_before_m) if reg is not None else None,
            rms_after_mm=m_to_mm(reg.rms_after_m) if reg is not None else None,
            max_after_mm=m_to_mm(reg.max_after_m) if reg is not None else None,
            findings=list(raw.summary),
        )
        return out

    def lines(self) -> tuple[str, ...]:
        """Page 1 of the report: where the path comes from, what the checks found, how it was
        registered (each a sentence)."""
        if self.raw is None:
            return (
                "Reference: the channel centreline (no reference source path was supplied): "
                "the comparison is simulated vs centreline, no measurement involved.",
            )
        out = [f"Reference path: {self.source or 'source not stated'}."]
        out += list(self.raw.summary)
        reg = self.registration
        if reg is not None:
            out.append(f"Registration ({self.mode}): {reg.description}")
            if self.mode != "none":
                out.append(
                    f"Distance of the reference positions from the centreline: RMS "
                    f"{m_to_mm(reg.rms_before_m):.2f} mm / max {m_to_mm(reg.max_before_m):.2f} "
                    f"mm as supplied, {m_to_mm(reg.rms_after_m):.2f} / "
                    f"{m_to_mm(reg.max_after_m):.2f} mm registered."
                )
        n_inf, n_out = self.count(FLAG_INFEASIBLE), self.count(FLAG_OUTSIDE)
        cap = f"{2 * self.capsule_radius_mm:.2f} mm capsule"
        if n_inf:
            out.append(
                f"{n_inf} reference position(s) of the compared path cannot lie in the lumen with "
                f"a {cap} (relative {self.named(FLAG_INFEASIBLE)}): kept, and named in the "
                "verdicts."
            )
        if n_out:
            out.append(
                f"{n_out} reference position(s) are not along the channel (relative "
                f"{self.named(FLAG_OUTSIDE)}): left out of the plan and the verdicts."
            )
        lifted = abs(self.raw.height_m) > PLANAR_TOL_M
        if self.raw.planar and self.raw.constant_height and lifted and self.mode == "none":
            out.append(
                "The path is planar at a constant height above the ring plane: it was stored in "
                "2D. --register plane-height moves it into the ring channel's plane (one "
                "translation, no fitting)."
            )
        return tuple(out)


def review_reference(
    app, channel, reference: ReferenceDwells, mode: str, capsule_radius_m: float
) -> ReferenceReview:
    """Check the reference path against ``channel`` and register it as ``mode`` says.

    Parameters
    ----------
    app : Applicator
        Gives the applicator frame (:func:`ringqa.geometry.frame.frame_of`: centre, normal).
    channel : Channel
        The channel the path belongs to.
    reference : ReferenceDwells
        The reference dwells (a centreline reference is passed through unchecked).
    mode : str
        Registration mode.
    capsule_radius_m : float
        Radius of the source capsule whose path it is (m).

    Returns
    -------
    ReferenceReview

    Raises
    ------
    RingQAError
        Fewer than 3 positions along the channel, or a registration that cannot be done (the
        message names the positions and the fix).
    """
    n = reference.relative_position_mm.size
    empty = np.full(n, "", dtype=object)
    if reference.kind != "measured":
        return ReferenceReview("none", "the channel centreline", m_to_mm(capsule_radius_m),
                               None, None, reference, empty, empty)  # fmt: skip
    points_m = mm_to_m(reference.dwells.positions_mm)
    rel_m = mm_to_m(reference.relative_position_mm)
    frame = (np.asarray(frame_of(app).centre_m, dtype=float),
             np.asarray(frame_of(app).normal, dtype=float))  # fmt: skip
    try:
        raw = check_reference_path(points_m, channel, capsule_radius_m, frame, relative_m=rel_m)
        on = int(np.count_nonzero(raw.on_channel))
        if on < MIN_POSITIONS:
            raise RingQAError(
                f"applicator {app.name}, channel {channel.name}: only {on} reference position(s) "
                f"lie along the channel (at least {MIN_POSITIONS} are needed); check that the "
                "path and the centreline are in the same frame and units (mm)"
            )
        reg = register_reference(points_m, channel, mode, capsule_radius_m, frame,
                                 relative_m=rel_m)  # fmt: skip
    except RegistrationError as exc:
        raise RingQAError(f"applicator {app.name}, channel {channel.name}: {exc}") from None
    pos_mm = m_to_mm(reg.points_m)
    registered = ReferenceDwells(
        reference.kind, reference.relative_position_mm,
        PathDwells(pos_mm, path_directions(pos_mm)), reference.step_mm, reference.source,
    )  # fmt: skip
    return ReferenceReview(
        mode=mode,
        source=reference.source,
        capsule_radius_mm=m_to_mm(capsule_radius_m),
        raw=raw,
        registration=reg,
        registered=registered,
        flags=np.array(reg.after.flags, dtype=object),
        raw_flags=np.array(raw.flags, dtype=object),
    )
