"""DICOM RT Plans for brachytherapy: channels, dwells, source, dose points, applicator library.

:func:`read_rtplan` reads a brachytherapy RT Plan with pydicom, by keyword:

- channels (``ApplicationSetupSequence[*].ChannelSequence``): number, length (``ChannelLength``),
  step (``SourceApplicatorStepSize``), total time (``ChannelTotalTime``), and its dwells from the
  ``BrachyControlPointSequence``: relative position (``ControlPointRelativePosition``), 3D position
  (``ControlPoint3DPosition``), orientation (``ControlPointOrientation`` (300A,0412), when every
  dwell has one; unit vector) and dwell time;
- the source (``SourceSequence``): isotope, S_K (``ReferenceAirKermaRate``, uGy m^2 h^-1 = U),
  reference date, manufacturer/model, and a guess of the TG-43 data set (``tg43_name``);
- dose reference points (``DoseReferenceSequence`` items with ``DoseReferencePointCoordinates``)
  with the TPS dose (``TargetPrescriptionDose``; else, in an HDR plan, the DICOM dose at the
  point: the sum over channels of the last control point's ``CumulativeDoseReferenceCoefficient``
  x ``BrachyApplicationSetupDose``, as Eclipse/BrachyVision write it; else
  ``DeliveryMaximumDose``, ``TargetMaximumDose``, ``OrganAtRiskMaximumDose``);
- Oncentra's embedded applicator library where present (:mod:`ringqa.io.oncentra`).

Dwell times
    Consecutive control points at the same position (same relative and 3D position) form one
    dwell. With cumulative weights (the DICOM meaning), a dwell's time is ``ChannelTotalTime x
    (increase of CumulativeTimeWeight over the dwell) / FinalCumulativeTimeWeight``, per channel.
    This never treats weights as seconds, so PDR plans (weights are not seconds; times are per
    pulse) come out right. A control point alone at its position (unpaired) whose weight does not
    increase is a zero-time position. Weights that increase while the source MOVES between
    positions are ambiguous and refused. Plans that store per-dwell weights in
    ``CumulativeTimeWeight`` (weights that decrease, or whose increments do not add up to
    ``FinalCumulativeTimeWeight`` while the per-position weights do) are detected and read as
    per-dwell weights, with a notice in ``RTPlan.warnings``; so are weights that do not restart
    at 0 in each channel (they continue from the previous channel up to a plan-wide
    ``FinalCumulativeTimeWeight``). Anything else is refused. Times are never negative.

Every problem raises :class:`RTPlanError` (a :class:`~ringqa.errors.InputFileError`) naming the
file, the element (keyword, channel, control point) and the fix; pydicom's own exceptions never
escape.
"""

from __future__ import annotations

import datetime as _dt
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ringqa.errors import InputFileError, named_warning
from ringqa.io import oncentra
from ringqa.io.oncentra import LibraryChannel
from ringqa.io.points import MAX_COORDINATE_MM

RT_PLAN_SOP_CLASS = "1.2.840.10008.5.1.4.1.1.481.5"
_SOP_NAMES = {
    "1.2.840.10008.5.1.4.1.1.481.1": "RT Image",
    "1.2.840.10008.5.1.4.1.1.481.2": "RT Dose",
    "1.2.840.10008.5.1.4.1.1.481.3": "RT Structure Set",
    "1.2.840.10008.5.1.4.1.1.481.4": "RT Beams Treatment Record",
    "1.2.840.10008.5.1.4.1.1.481.6": "RT Brachy Treatment Record",
    "1.2.840.10008.5.1.4.1.1.481.8": "RT Ion Plan",
    "1.2.840.10008.5.1.4.1.1.2": "CT Image",
    "1.2.840.10008.5.1.4.1.1.4": "MR Image",
}
#: Control points closer than this (mm) are at the same position.
SAME_POSITION_MM = 1.0e-3
#: plan dwells farther than this (mm) from the library's source path (its measured path, else
#: its centreline, on which Oncentra then puts the dwells): the library is not this plan's
#: (Oncentra puts its dwells on the path within 1e-6 mm: the example's 5e-7 mm; the check it
#: protects is the 1-2 mm position tolerance; ``plan.library_match``)
LIBRARY_PATH_TOL_MM = 0.1
#: the treatment types ringqa commissions (a stepping source on a cable)
AFTERLOADER_TYPES = ("HDR", "PDR")
#: ``DosePoint.dose_tag`` of a dose from the control points' coefficients (module docstring).
COEFFICIENT_DOSE_TAG = "CumulativeDoseReferenceCoefficient x BrachyApplicationSetupDose"
#: TPS dose tags, in order of preference (a coefficient dose comes after the first).
DOSE_TAGS = (
    "TargetPrescriptionDose",
    "DeliveryMaximumDose",
    "TargetMaximumDose",
    "OrganAtRiskMaximumDose",
)

__all__ = [
    "DosePoint",
    "LibraryChannel",
    "PlanChannel",
    "PlanSource",
    "RTPlan",
    "RTPlanError",
    "applicator_from_rtplan",
    "dwell_times",
    "guess_tg43_name",
    "read_rtplan",
]


class RTPlanError(InputFileError):
    """An RT Plan cannot be read correctly (names the file, the element and the fix)."""


@dataclass(frozen=True)
class PlanChannel:
    """One channel of a brachytherapy plan with its dwells.

    Attributes
    ----------
    number : int
        ``ChannelNumber``.
    name : str
        ``SourceApplicatorName``, else the library part label, else ``SourceApplicatorID`` when
        it is a word (Eclipse's ``'tandem'``; not Oncentra's number), else ``"channel <N>"``.
    length_mm : float or None
        ``ChannelLength`` (indexer length).
    step_mm : float or None
        ``SourceApplicatorStepSize``.
    relative_position_mm : numpy.ndarray
        (n,) ``ControlPointRelativePosition`` of each dwell (0 = most distal position).
    positions_mm : numpy.ndarray
        (n, 3) ``ControlPoint3DPosition`` (patient coordinates).
    times_s : numpy.ndarray
        (n,) dwell times (s), >= 0; per pulse for PDR plans.
    directions : numpy.ndarray or None
        (n, 3) unit ``ControlPointOrientation`` per dwell, when the plan has it for every dwell.
    total_time_s : float
        ``ChannelTotalTime``.
    applicator_id : str
        ``SourceApplicatorID``.
    applicator_length_mm : float or None
        ``SourceApplicatorLength``.
    source_number : int or None
        ``ReferencedSourceNumber``.
    number_of_pulses : int or None
        ``NumberOfPulses`` (PDR).
    pulse_interval_s : float or None
        ``PulseRepetitionInterval`` (PDR).
    joint_address : str or None
        Oncentra's part address (private (300B,1013)), links the channel to the library.
    """

    number: int
    name: str
    length_mm: float | None
    step_mm: float | None
    relative_position_mm: np.ndarray
    positions_mm: np.ndarray
    times_s: np.ndarray
    directions: np.ndarray | None
    total_time_s: float
    applicator_id: str = ""
    applicator_length_mm: float | None = None
    source_number: int | None = None
    number_of_pulses: int | None = None
    pulse_interval_s: float | None = None
    joint_address: str | None = None

    @property
    def n_dwells(self) -> int:
        """Number of dwell positions (including zero-time positions)."""
        return len(self.times_s)


@dataclass(frozen=True)
class PlanSource:
    """The plan's source (``SourceSequence`` item).

    Attributes
    ----------
    isotope : str
        ``SourceIsotopeName`` (e.g. ``"Ir-192"``).
    model : str
        Manufacturer, model id/description and treatment machine, joined (what the guess used).
    tg43_name : str or None
        Guessed TG-43 data set (``"mhdr-v2"``, ``"flexisource"``, ``"gammamed-plus"``,
        ``"vs2000"``, ``"m-19"``) or None when unsure.
    sk_U : float or None
        Air-kerma strength ``ReferenceAirKermaRate`` (uGy m^2 h^-1 = U) at the reference date.
    reference_date : datetime.date or None
        ``SourceStrengthReferenceDate``.
    half_life_days : float or None
        ``SourceIsotopeHalfLife``.
    number : int or None
        ``SourceNumber``.
    """

    isotope: str
    model: str
    tg43_name: str | None
    sk_U: float | None
    reference_date: _dt.date | None
    half_life_days: float | None = None
    number: int | None = None


@dataclass(frozen=True)
class DosePoint:
    """A dose reference point with the dose the TPS computed there.

    Attributes
    ----------
    name : str
        ``DoseReferenceDescription`` (else ``"point <number>"``).
    position_mm : numpy.ndarray
        (3,) ``DoseReferencePointCoordinates``.
    tps_dose_gy : float or None
        The TPS dose (first present of :data:`DOSE_TAGS`, the coefficient dose after the first:
        module docstring).
    dose_tag : str or None
        Which tag gave ``tps_dose_gy``.
    number : int or None
        ``DoseReferenceNumber``.
    """

    name: str
    position_mm: np.ndarray
    tps_dose_gy: float | None
    dose_tag: str | None = None
    number: int | None = None


@dataclass(frozen=True)
class RTPlan:
    """A brachytherapy RT Plan as read by :func:`read_rtplan`.

    Attributes
    ----------
    channels : tuple of PlanChannel
        In file order.
    source : PlanSource
        The source the channels use.
    points : tuple of DosePoint
        Dose reference points with coordinates.
    library : dict of int to LibraryChannel, or None
        Oncentra's applicator library per channel number; None when the plan has none.
    path : str
        The file read.
    treatment_type : str
        ``BrachyTreatmentType`` (``"HDR"``, ``"PDR"``, ...).
    plan_label : str
        ``RTPlanLabel``.
    prescription_gy : float or None
        ``BrachyApplicationSetupDose`` of the first fraction group's first setup.
    applicator_name : str or None
        Oncentra's applicator name (private (300B,1010)), when present.
    warnings : tuple of str
        Notices (no library, per-dwell weights read, partial orientations, ...).
    """

    channels: tuple[PlanChannel, ...]
    source: PlanSource
    points: tuple[DosePoint, ...]
    library: dict[int, LibraryChannel] | None
    path: str
    treatment_type: str = ""
    plan_label: str = ""
    prescription_gy: float | None = None
    applicator_name: str | None = None
    warnings: tuple[str, ...] = field(default_factory=tuple)

    def channel(self, number: int) -> PlanChannel:
        """The channel with ``ChannelNumber == number``."""
        for ch in self.channels:
            if ch.number == number:
                return ch
        have = ", ".join(str(c.number) for c in self.channels)
        raise RTPlanError(self.path, f"no channel {number}", f"channels are {have}")


# --------------------------------------------------------------------------------------------
# dwell times (pure function, tested on its own)


def dwell_times(
    weights: np.ndarray,
    groups: list[tuple[int, int]],
    total_time_s: float,
    final_weight: float | None,
) -> tuple[np.ndarray, str]:
    """Dwell times from control-point weights.

    Parameters
    ----------
    weights : numpy.ndarray
        (n_cp,) ``CumulativeTimeWeight`` of each control point (finite, >= 0).
    groups : list of (start, stop)
        Control points ``start:stop`` share one position (one dwell), in order.
    total_time_s : float
        ``ChannelTotalTime`` (s), >= 0.
    final_weight : float or None
        ``FinalCumulativeTimeWeight`` (None: the last weight).

    Returns
    -------
    times_s : numpy.ndarray
        (n_groups,) dwell times, >= 0.
    mode : str
        ``"cumulative"``, ``"continued"`` (non-decreasing weights covering only part of
        ``[0, FinalCumulativeTimeWeight]``: cumulative weights not reset per channel, the
        channel's own weight increase is shared out; the caller must check that the channels
        chain up), ``"per-dwell"`` or ``"empty"`` (all weights and the total zero).

    Raises
    ------
    ValueError
        With a message saying why the weights cannot be turned into times.
    """
    w = np.asarray(weights, dtype=float)
    n = len(groups)
    if n == 0:
        return np.zeros(0), "empty"
    W = float(w[-1]) if final_weight is None else float(final_weight)
    scale = max(abs(W), float(np.max(w)))
    tol = 1e-6 * scale  # weights are DS strings: relative rounding only
    if W <= tol:
        if np.all(w <= tol):
            if total_time_s > 0:
                raise ValueError(
                    f"FinalCumulativeTimeWeight is {W:g} but ChannelTotalTime is "
                    f"{total_time_s:g} s: the time cannot be shared out"
                )
            return np.zeros(n), "empty"
        raise ValueError(f"FinalCumulativeTimeWeight is {W:g} while control points have weights")
    monotone = bool(np.all(np.diff(w) >= -tol))
    span = float(w[-1] - w[0])
    if monotone and abs(span - W) <= tol:
        if w[0] > tol:
            raise ValueError(f"the first CumulativeTimeWeight is {w[0]:g}, not 0")
        return total_time_s * _increments(w, groups, tol) / W, "cumulative"
    per = np.array([np.max(w[a:b]) for a, b in groups])
    if abs(per.sum() - W) <= 1e-5 * scale * n:  # n rounded per-dwell values
        return total_time_s * per / W, "per-dwell"
    if monotone and span > tol and w[-1] <= W + tol:
        # weights not reset per channel: this channel holds the sub-range [w[0], w[-1]] of a
        # plan-wide cumulative weight ending at W (read_rtplan checks that channels chain up)
        return total_time_s * _increments(w, groups, tol) / span, "continued"
    raise ValueError(
        "CumulativeTimeWeight is neither cumulative (non-decreasing with increments adding up to "
        f"FinalCumulativeTimeWeight {W:g}; they add up to {w[-1] - w[0]:g}) nor per-dwell "
        f"(per-position weights add up to {per.sum():g})"
    )


def _increments(w: np.ndarray, groups: list[tuple[int, int]], tol: float) -> np.ndarray:
    """Weight increase over each group; refuse increases while the source moves."""
    for g in range(1, len(groups)):
        a, _ = groups[g]
        jump = w[a] - w[groups[g - 1][1] - 1]
        if jump > tol:
            raise ValueError(
                f"CumulativeTimeWeight increases by {jump:g} while the source moves from "
                f"control point {groups[g - 1][1] - 1} to {a} (different positions): it is "
                "ambiguous which position the time belongs to (export the plan with paired "
                "control points, two per dwell position)"
            )
    return np.clip(np.array([w[b - 1] - w[a] for a, b in groups]), 0.0, None)


# --------------------------------------------------------------------------------------------
# source model guess

_TG43_PATTERNS = (
    ("flexisource", ("flexisource", "flexitron", "isodose control")),
    ("mhdr-v2", ("mhdr-v2", "mhdr v2", "mhdr", "microselectron", "micro selectron")),
    ("gammamed-plus", ("gammamed",)),
    ("vs2000", ("vs2000", "varisource", "vs 2000")),
    ("m-19", ("m-19", "m19", "spec")),
)


def guess_tg43_name(text: str, isotope: str) -> str | None:
    """Guess the TG-43 data set from manufacturer/model/machine text (None when unsure).

    Only Ir-192 sources are guessed. ``"microSelectron"`` maps to ``"mhdr-v2"`` (the v2 and v2r
    sources share the consensus data); ``"Flexitron"`` / ``"Flexisource"`` to ``"flexisource"``.
    """
    iso = isotope.lower().replace(" ", "")
    if "192" not in iso:
        return None
    t = text.lower()
    for name, keys in _TG43_PATTERNS:
        if any(k in t for k in keys):
            return name
    return None


# --------------------------------------------------------------------------------------------
# reading


def read_rtplan(path: str | Path) -> RTPlan:
    """Read a brachytherapy DICOM RT Plan.

    Parameters
    ----------
    path : str or Path
        The RT Plan file.

    Returns
    -------
    RTPlan

    Raises
    ------
    RTPlanError
        Not DICOM, truncated or corrupt, not an RT Plan, not a brachytherapy plan, no channels,
        NaN or missing positions, weights that cannot be turned into times, ...
    """
    p = Path(path)
    if p.is_dir():
        raise RTPlanError(p, "is a folder, not an RT Plan file", "give the RP*.dcm file itself")
    if not p.is_file():
        raise RTPlanError(p, "file not found", "check the path")
    import pydicom
    from pydicom.errors import InvalidDicomError

    try:
        ds = pydicom.dcmread(p)
    except InvalidDicomError:
        raise RTPlanError(
            p, "not a DICOM file (no DICM preamble)", "export the plan from the TPS as DICOM"
        ) from None
    except Exception as exc:  # pydicom raises many kinds on damaged files
        raise RTPlanError(
            p,
            f"cannot be parsed as DICOM ({type(exc).__name__}: {exc}); the file is truncated or "
            "corrupt",
            "export the plan again",
        ) from None
    try:
        return _parse(p, ds)
    except RTPlanError:
        raise
    except Exception as exc:  # element access on a damaged file
        raise RTPlanError(
            p,
            f"damaged or inconsistent DICOM data ({type(exc).__name__}: {exc}); the file may be "
            "truncated or corrupt",
            "export the plan again",
        ) from None


def _get(item, keyword: str):
    """Value of a keyword, or None when absent or empty."""
    el = item.get(keyword) if hasattr(item, "get") else None
    if el is None:
        return None
    value = getattr(el, "value", el)
    if value is None or value == "":
        return None
    return value


def _float(p: Path, item, keyword: str, where: str, required: bool = False) -> float | None:
    v = _get(item, keyword)
    if v is None:
        if required:
            raise RTPlanError(p, f"{where}: {keyword} is missing", "export a complete plan")
        return None
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise RTPlanError(p, f"{where}: {keyword} is {v!r}, not a number", "") from None
    if not math.isfinite(f):
        raise RTPlanError(p, f"{where}: {keyword} is {f}", "the plan holds no valid value there")
    return f


def _vector(p: Path, item, keyword: str, where: str) -> np.ndarray | None:
    v = _get(item, keyword)
    if v is None:
        return None
    try:
        arr = np.array([float(x) for x in v], dtype=float)
    except (TypeError, ValueError):
        raise RTPlanError(p, f"{where}: {keyword} is {v!r}, not numbers", "") from None
    if arr.shape != (3,):
        raise RTPlanError(p, f"{where}: {keyword} has {arr.size} values, not 3", "")
    if not np.all(np.isfinite(arr)):
        raise RTPlanError(
            p,
            f"{where}: {keyword} is {arr.tolist()} (not finite)",
            "the plan has no valid coordinates there; re-export it from the TPS",
        )
    return arr


def _parse(p: Path, ds) -> RTPlan:
    sop = str(_get(ds, "SOPClassUID") or "")
    modality = str(_get(ds, "Modality") or "")
    if modality != "RTPLAN" or (sop and sop != RT_PLAN_SOP_CLASS):
        what = _SOP_NAMES.get(sop, f"SOP class {sop or 'unknown'}")
        raise RTPlanError(
            p,
            f"not an RT Plan (Modality {modality or 'missing'}, {what})",
            "give the RT Plan file (Modality RTPLAN, usually named RP*.dcm)",
        )
    setups = _get(ds, "ApplicationSetupSequence")
    if not _get(ds, "BrachyTreatmentType") and not setups:
        beams = " (it has a BeamSequence: external beam)" if _get(ds, "BeamSequence") else ""
        raise RTPlanError(
            p,
            f"not a brachytherapy plan: no BrachyTreatmentType or ApplicationSetupSequence{beams}",
            "give a brachytherapy RT Plan",
        )
    warnings: list[str] = []
    treatment_type = str(_get(ds, "BrachyTreatmentType") or "")
    raw_channels = [(s, c) for s in (setups or []) for c in (_get(s, "ChannelSequence") or [])]
    if not raw_channels:
        raise RTPlanError(
            p,
            "no channels (ApplicationSetupSequence[*].ChannelSequence is missing or empty)",
            "export the plan after the channels were reconstructed and dwells activated",
        )
    sources = _read_sources(p, ds, warnings)
    channels = []
    used_sources = set()
    ranges: dict[int, tuple] = {}
    for k, (_setup, item) in enumerate(raw_channels):
        ch = _read_channel(p, item, k, warnings, treatment_type, ranges)
        channels.append(ch)
        used_sources.add(ch.source_number)
    numbers = [c.number for c in channels]
    if len(set(numbers)) != len(numbers):
        raise RTPlanError(p, f"ChannelNumber repeats ({numbers})", "export a consistent plan")
    _check_continued(p, ranges, warnings)
    _check_treatment_type(treatment_type, warnings)
    _check_source_references(channels, sources, warnings)
    source = _pick_source(p, sources, used_sources, warnings)
    points = _read_points(
        p, ds, warnings, _coefficient_doses(p, ds) if treatment_type.upper() == "HDR" else {}
    )
    library, app_name = _read_library(p, setups, channels, warnings)
    if library:
        channels = [
            _with_name(c, library[c.number].name) if c.number in library and not c.name else c
            for c in channels
        ]
        _check_library(channels, library, warnings)
    channels = [c if c.name else _with_name(c, _fallback_name(c)) for c in channels]
    if treatment_type == "PDR":
        warnings.append("PDR plan: dwell times are per pulse (ChannelTotalTime covers one pulse)")
    prescription = None
    fgs = _get(ds, "FractionGroupSequence")
    if fgs:
        refs = _get(fgs[0], "ReferencedBrachyApplicationSetupSequence")
        if refs:
            prescription = _float(p, refs[0], "BrachyApplicationSetupDose", "fraction group 1")
    return RTPlan(
        channels=tuple(channels),
        source=source,
        points=tuple(points),
        library=library,
        path=str(p),
        treatment_type=treatment_type,
        plan_label=str(_get(ds, "RTPlanLabel") or ""),
        prescription_gy=prescription,
        applicator_name=app_name,
        warnings=tuple(warnings),
    )


def _fallback_name(ch: PlanChannel) -> str:
    """A channel's name when the plan has no ``SourceApplicatorName`` and no library label.

    ``SourceApplicatorID`` when it is a word (Eclipse writes ``'tandem'``, ``'left ovoid'``);
    Oncentra writes a number there (``'1'``, ``'3'``), which names nothing, so then
    ``"channel <N>"``.
    """
    aid = ch.applicator_id.strip()
    return aid if any(c.isalpha() for c in aid) else f"channel {ch.number}"


def _with_name(ch: PlanChannel, name: str) -> PlanChannel:
    from dataclasses import replace

    return replace(ch, name=name)


def _check_continued(p: Path, ranges: dict, warnings: list) -> None:
    """Weights that continue across channels must chain up from 0 to the plan-wide final."""
    if not any(r[3] == "continued" for r in ranges.values()):
        return
    used = sorted((r for r in ranges.items() if r[1][3] != "empty"), key=lambda r: r[1][0])
    finals = {round(r[1][2], 6) for r in used}
    expect = 0.0
    for number, (w0, w1, W, _mode) in used:
        tol = 1e-6 * max(abs(W), 1e-300)
        if abs(w0 - expect) > tol or len(finals) != 1:
            raise RTPlanError(
                p,
                f"channel {number}: CumulativeTimeWeight runs {w0:g}..{w1:g} of "
                f"FinalCumulativeTimeWeight {W:g}, but does not continue where the previous "
                f"channel ended ({expect:g}); the weights cannot be turned into times",
                "export the plan with weights restarting at 0 in each channel",
            )
        expect = w1
    W = used[-1][1][2]
    if abs(expect - W) > 1e-6 * abs(W):
        raise RTPlanError(
            p,
            f"the channels' CumulativeTimeWeight ends at {expect:g}, not at "
            f"FinalCumulativeTimeWeight {W:g}; the weights cannot be turned into times",
            "export a consistent plan",
        )
    warnings.append(
        "CumulativeTimeWeight does not restart at 0 in each channel (it continues across "
        "channels up to the plan-wide FinalCumulativeTimeWeight); each channel's own weight "
        "increase was shared out over its ChannelTotalTime"
    )


def _read_channel(
    p: Path, item, k: int, warnings: list, treatment_type: str, ranges: dict
) -> PlanChannel:
    number_v = _get(item, "ChannelNumber")
    try:
        number = int(number_v) if number_v is not None else k + 1
    except (TypeError, ValueError):
        raise RTPlanError(p, f"channel item {k}: ChannelNumber is {number_v!r}", "") from None
    where = f"channel {number}"
    total = _float(p, item, "ChannelTotalTime", where)
    cps = _get(item, "BrachyControlPointSequence") or []
    declared = _get(item, "NumberOfControlPoints")
    if declared is not None and int(declared) != len(cps):
        raise RTPlanError(
            p,
            f"{where}: NumberOfControlPoints is {int(declared)} but {len(cps)} control points "
            "are present; the file is truncated or corrupt",
            "export the plan again",
        )
    if total is None:
        if cps:
            raise RTPlanError(
                p, f"{where}: ChannelTotalTime is missing", "export the plan with dwell times"
            )
        total = 0.0
    if total < 0:
        raise RTPlanError(p, f"{where}: ChannelTotalTime is {total:g} s (negative)", "")
    rel, pos, w, orient = [], [], [], []
    for j, cp in enumerate(cps):
        cw = f"{where}, control point {j}"
        r = _float(p, cp, "ControlPointRelativePosition", cw)
        x = _vector(p, cp, "ControlPoint3DPosition", cw)
        if x is None:
            raise RTPlanError(
                p,
                f"{cw}: ControlPoint3DPosition is missing",
                "ringqa needs the 3D dwell positions; export them from the TPS",
            )
        if r is None:
            raise RTPlanError(
                p,
                f"{cw}: ControlPointRelativePosition is missing",
                "ringqa needs relative positions to match dwells to the channel",
            )
        wt = _float(p, cp, "CumulativeTimeWeight", cw)
        if wt is None:
            if j == 0:
                wt = 0.0
            else:
                raise RTPlanError(p, f"{cw}: CumulativeTimeWeight is missing", "")
        if wt < 0:
            raise RTPlanError(p, f"{cw}: CumulativeTimeWeight is {wt:g} (negative)", "")
        if not np.all(np.abs(x) <= MAX_COORDINATE_MM):
            raise RTPlanError(
                p,
                f"{cw}: ControlPoint3DPosition {_fmt_xyz(x)} mm lies more than "
                f"{MAX_COORDINATE_MM / 1000:g} m from the origin: no dwell position does",
                "export the plan again with positions in millimetres",
            )
        rel.append(r)
        pos.append(x)
        w.append(wt)
        orient.append(_vector(p, cp, "ControlPointOrientation", cw))
    groups: list[tuple[int, int]] = []
    for j in range(len(cps)):
        if (
            groups
            and abs(rel[j] - rel[groups[-1][0]]) < SAME_POSITION_MM
            and np.linalg.norm(pos[j] - pos[groups[-1][0]]) < SAME_POSITION_MM
        ):
            groups[-1] = (groups[-1][0], j + 1)
        else:
            groups.append((j, j + 1))
    final = _float(p, item, "FinalCumulativeTimeWeight", where)
    try:
        times, mode = dwell_times(np.array(w), groups, total, final)
    except ValueError as exc:
        raise RTPlanError(p, f"{where}: {exc}", "") from None
    if w:
        ranges[number] = (w[0], w[-1], final if final is not None else w[-1], mode)
    if total == 0.0 and len(groups) and max(w, default=0.0) > 0:
        warnings.append(named_warning(
            "plan.channel_time",
            f"{where}: ChannelTotalTime is 0 s but the channel has {len(groups)} dwell(s) with "
            "time weights: it gives no dose (check the exported plan; a channel the TPS does "
            "not use has no dwells)",
        ))  # fmt: skip
    if mode == "per-dwell":
        warnings.append(
            f"{where}: CumulativeTimeWeight holds per-dwell weights (not cumulative); read as "
            "per-dwell weights x ChannelTotalTime / FinalCumulativeTimeWeight"
        )
    have = [orient[a] is not None for a, _ in groups]
    directions = None
    if groups and all(have):
        d = np.array([orient[a] for a, _ in groups])
        norms = np.linalg.norm(d, axis=1)
        if np.any(norms < 1e-9):
            bad = int(np.flatnonzero(norms < 1e-9)[0])
            raise RTPlanError(
                p, f"{where}, dwell {bad}: ControlPointOrientation is a zero vector", ""
            )
        directions = d / norms[:, None]
    elif any(have):
        warnings.append(
            f"{where}: ControlPointOrientation present for only some dwells; orientations ignored"
        )
    pulses = _get(item, "NumberOfPulses")
    src = _get(item, "ReferencedSourceNumber")
    return PlanChannel(
        number=number,
        name=str(_get(item, "SourceApplicatorName") or "").strip(),
        length_mm=_float(p, item, "ChannelLength", where),
        step_mm=_float(p, item, "SourceApplicatorStepSize", where),
        relative_position_mm=np.array([rel[a] for a, _ in groups], dtype=float),
        positions_mm=np.array([pos[a] for a, _ in groups], dtype=float).reshape(-1, 3),
        times_s=np.asarray(times, dtype=float),
        directions=directions,
        total_time_s=float(total),
        applicator_id=str(_get(item, "SourceApplicatorID") or ""),
        applicator_length_mm=_float(p, item, "SourceApplicatorLength", where),
        source_number=None if src is None else int(src),
        number_of_pulses=None if pulses is None else int(pulses),
        pulse_interval_s=_float(p, item, "PulseRepetitionInterval", where),
        joint_address=_private_str(item, oncentra.JOINT_ADDRESS_OFFSET),
    )


def _private_str(item, offset: int) -> str | None:
    """Oncentra's private text element at ``offset`` (creator "NUCLETRON" checked)."""
    try:
        el = oncentra.private_element(item, offset)
    except Exception:
        return None
    if el is None or el.value is None:
        return None
    v = el.value
    if isinstance(v, bytes):
        v = v.decode("latin-1", errors="replace")
    v = str(v).strip().strip("\x00").strip()
    return v or None


#: isotopes of the TG-43 data ringqa ships (data/sources), normalised ("ir192")
TG43_ISOTOPES = ("ir192",)
#: Half-lives (days) of those isotopes, to read a SourceIsotopeName that names the source model
#: instead (Eclipse/BrachyVision: "GammaMed Plus HDR source 0.9 mm"): Ir-192 73.829 d (NNDC).
TG43_HALF_LIVES_DAYS = {"Ir-192": 73.829}
#: A half-life within this many days of one in :data:`TG43_HALF_LIVES_DAYS` identifies it.
HALF_LIFE_TOLERANCE_DAYS = 0.1
_ISOTOPE_NAME = re.compile(
    r"^\s*([A-Za-z]{1,2}\s*-?\s*\d{1,3}m?|\d{1,3}m?\s*-?\s*[A-Za-z]{1,2})\s*$"
)


def _isotope_of(name: str, half_life_days, where: str, warnings: list) -> str:
    """The isotope of a source: its SourceIsotopeName when that names an isotope ("Ir-192",
    "192Ir", "Co-60"); when it names something else (a source model, as Eclipse writes it) and
    the plan's half-life is one of :data:`TG43_HALF_LIVES_DAYS`, that isotope, with a named
    warning (``plan.isotope_name``); otherwise the name as it is."""
    if not name or _ISOTOPE_NAME.match(name) or half_life_days is None:
        return name
    for isotope, days in TG43_HALF_LIVES_DAYS.items():
        if abs(float(half_life_days) - days) <= HALF_LIFE_TOLERANCE_DAYS:
            warnings.append(named_warning(
                "plan.isotope_name",
                f"{where}: SourceIsotopeName is {name!r} (a source, not an isotope); its "
                f"SourceIsotopeHalfLife {float(half_life_days):g} d is {isotope}'s "
                f"({days:g} d): read as {isotope}",
            ))  # fmt: skip
            return isotope
    return name


def _fmt_xyz(x) -> str:
    return "(" + ", ".join(f"{float(v):.6g}" for v in x) + ")"


def _read_sources(p: Path, ds, warnings: list) -> list[PlanSource]:
    items = _get(ds, "SourceSequence") or []
    if not items:
        raise RTPlanError(p, "no SourceSequence", "export the plan with its source")
    machine = ""
    tms = _get(ds, "TreatmentMachineSequence")
    if tms:
        machine = " ".join(
            str(_get(tms[0], k) or "")
            for k in ("Manufacturer", "ManufacturerModelName", "TreatmentMachineName")
        )
    out = []
    for k, s in enumerate(items):
        where = f"source {k}"
        isotope_name = str(_get(s, "SourceIsotopeName") or "").strip()
        half_life = _float(p, s, "SourceIsotopeHalfLife", where)
        isotope = _isotope_of(isotope_name, half_life, where, warnings)
        units = str(_get(s, "SourceStrengthUnits") or "AIR_KERMA_RATE")
        if units != "AIR_KERMA_RATE":
            raise RTPlanError(
                p,
                f"{where}: SourceStrengthUnits is {units}",
                "ringqa needs the air-kerma strength (AIR_KERMA_RATE)",
            )
        sk = _float(p, s, "ReferenceAirKermaRate", where)
        if sk is None:
            warnings.append(named_warning(
                "plan.no_sk",
                f"{where}: no ReferenceAirKermaRate (S_K): the plan's own dwells cannot be dosed "
                "against the TPS (give the strength with --sk-u)",
            ))  # fmt: skip
        elif sk <= 0:
            raise RTPlanError(p, f"{where}: ReferenceAirKermaRate is {sk:g}", "")
        date = None
        dv = _get(s, "SourceStrengthReferenceDate")
        if dv is not None:
            try:
                date = _dt.datetime.strptime(str(dv)[:8], "%Y%m%d").date()
            except ValueError:
                warnings.append(f"{where}: SourceStrengthReferenceDate {dv!r} is not a date")
        model = " ".join(
            x
            for x in (
                str(_get(s, "SourceManufacturer") or ""),
                str(_get(s, "SourceModelID") or ""),
                str(_get(s, "SourceDescription") or ""),
                machine,
                isotope_name if isotope_name != isotope else "",
            )
            if x.strip()
        ).strip()
        if isotope and isotope.replace("-", "").replace(" ", "").lower() not in TG43_ISOTOPES:
            warnings.append(named_warning(
                "plan.isotope",
                f"{where}: the plan's source is {isotope} ({model or 'no model given'}), but "
                "ringqa's TG-43 source data are all Ir-192: doses computed with them are wrong "
                f"for {isotope} (use the position results only, or a TPS for {isotope} doses)",
            ))  # fmt: skip
        num = _get(s, "SourceNumber")
        out.append(
            PlanSource(
                isotope=isotope,
                model=model,
                tg43_name=guess_tg43_name(model, isotope),
                sk_U=sk,
                reference_date=date,
                half_life_days=half_life,
                number=None if num is None else int(num),
            )
        )
    return out


def _pick_source(p: Path, sources: list, used: set, warnings: list) -> PlanSource:
    used = {u for u in used if u is not None}
    chosen = [s for s in sources if s.number in used] or sources[:1]
    if len(chosen) > 1:
        warnings.append(
            f"channels use {len(chosen)} sources; source {chosen[0].number} is reported"
        )
    return chosen[0]


def _check_treatment_type(treatment_type: str, warnings: list) -> None:
    """Warn (``plan.treatment_type``) for a plan that is not an afterloader's (LDR, MDR,
    MANUAL): ringqa's cable, step and dwell-time model do not describe it."""
    kind = treatment_type.strip().upper()
    if kind and kind not in AFTERLOADER_TYPES:
        warnings.append(named_warning(
            "plan.treatment_type",
            f"BrachyTreatmentType is {kind}: ringqa commissions HDR/PDR afterloader applicators "
            "(a stepping source on a cable); the cable simulation, the dwell times and the "
            f"Ir-192 dose data do not describe an {kind} plan, so its results do not apply "
            "(give the applicator's HDR plan)",
        ))  # fmt: skip


def _check_source_references(channels: list, sources: list, warnings: list) -> None:
    """Warn (``plan.source_reference``) for a channel whose ``ReferencedSourceNumber`` names a
    source the plan's ``SourceSequence`` does not have."""
    numbers = {s.number for s in sources if s.number is not None}
    for ch in channels:
        if ch.source_number is not None and numbers and ch.source_number not in numbers:
            have = ", ".join(str(n) for n in sorted(numbers))
            warnings.append(named_warning(
                "plan.source_reference",
                f"channel {ch.number}: ReferencedSourceNumber {ch.source_number} names a source "
                f"the plan does not have (SourceSequence: {have}); the plan's source "
                f"{sorted(numbers)[0]} is used for its doses (export the plan again, or check "
                "which source the afterloader uses)",
            ))  # fmt: skip


#: dose references that are not points (no coordinates expected)
_NOT_POINTS = ("VOLUME", "SITE")


def _coefficient_doses(p: Path, ds) -> dict[int, float]:
    """Dose (Gy) at each dose reference number from the control points (DICOM PS3.3 C.8.8.15):
    per application setup, ``BrachyApplicationSetupDose`` x the sum over its channels of the
    ``CumulativeDoseReferenceCoefficient`` at the channel's last control point; summed over the
    setups of the first fraction group. Empty when the plan has no coefficients or setup doses."""
    fgs = _get(ds, "FractionGroupSequence")
    setup_dose = {}
    for ref in (_get(fgs[0], "ReferencedBrachyApplicationSetupSequence") or []) if fgs else []:
        number = _get(ref, "ReferencedBrachyApplicationSetupNumber")
        dose = _float(p, ref, "BrachyApplicationSetupDose", "fraction group 1")
        if number is not None and dose is not None:
            setup_dose[int(number)] = dose
    out: dict[int, float] = {}
    for setup in _get(ds, "ApplicationSetupSequence") or []:
        number = _get(setup, "ApplicationSetupNumber")
        dose = setup_dose.get(int(number)) if number is not None else None
        if dose is None:
            continue
        for ch in _get(setup, "ChannelSequence") or []:
            cps = _get(ch, "BrachyControlPointSequence") or []
            for r in (_get(cps[-1], "BrachyReferencedDoseReferenceSequence") or []) if cps else []:
                ref = _get(r, "ReferencedDoseReferenceNumber")
                c = _float(p, r, "CumulativeDoseReferenceCoefficient", "control point")
                if ref is not None and c is not None:
                    out[int(ref)] = out.get(int(ref), 0.0) + c * dose
    return out


def _read_points(
    p: Path, ds, warnings: list | None = None, coefficient_doses: dict | None = None
) -> list[DosePoint]:
    out = []
    for k, item in enumerate(_get(ds, "DoseReferenceSequence") or []):
        num = _get(item, "DoseReferenceNumber")
        name = str(_get(item, "DoseReferenceDescription") or "").strip()
        where = f"dose reference {name or k}"
        xyz = _vector(p, item, "DoseReferencePointCoordinates", where)
        if xyz is None:
            kind = str(_get(item, "DoseReferenceStructureType") or "").strip().upper()
            if kind not in _NOT_POINTS and warnings is not None:
                label = name or f"number {num if num is not None else k + 1}"
                warnings.append(named_warning(
                    "plan.dose_point",
                    f"dose reference {label!r} ({kind or 'no DoseReferenceStructureType'}) has "
                    "no DoseReferencePointCoordinates: it is left out of the plan-vs-TPS dose "
                    "check (export the plan with the point's coordinates)",
                ))  # fmt: skip
            continue  # a volume or site reference, not a point
        dose = tag = None
        coefficient = (coefficient_doses or {}).get(int(num)) if num is not None else None
        for t in DOSE_TAGS:
            dose = _float(p, item, t, where)
            if dose is not None:
                tag = t
                break
            if t == DOSE_TAGS[0] and coefficient is not None:
                dose, tag = coefficient, COEFFICIENT_DOSE_TAG
                break
        out.append(
            DosePoint(
                name=name or f"point {num if num is not None else k + 1}",
                position_mm=xyz,
                tps_dose_gy=dose,
                dose_tag=tag,
                number=None if num is None else int(num),
            )
        )
    return out


def _read_library(p: Path, setups, channels: list, warnings: list):
    found = False
    app_name = None
    library: dict[int, LibraryChannel] = {}
    by_setup = {}
    for s in setups or []:
        app_name = app_name or _private_str(s, oncentra.APPLICATOR_NAME_OFFSET)
        el = oncentra.private_element(s, oncentra.LIBRARY_OFFSET)
        if el is None or not el.value:
            continue
        found = True
        details = _private_str(s, oncentra.APPLICATOR_DETAILS_OFFSET) or ""
        preferred = None
        if "Measured source path:" in details:
            preferred = details.split("Measured source path:", 1)[1].strip().splitlines()[0]
        try:
            lib = oncentra.parse_library(oncentra.decode_library(el.value))
        except oncentra.LibraryFormatError as exc:
            warnings.append(named_warning(
                "plan.library",
                f"Oncentra applicator library (300B,100D) not readable ({exc}); using the "
                "standard tags only",
            ))  # fmt: skip
            continue
        for ch_item in _get(s, "ChannelSequence") or []:
            by_setup[int(_get(ch_item, "ChannelNumber") or 0)] = (lib, preferred)
    if not found:
        warnings.append(
            "no Oncentra applicator library (private tag (300B,100D)) in the plan: no centrelines "
            "or measured source paths; using the standard tags only"
        )
        return None, app_name
    for ch in channels:
        if ch.number not in by_setup:
            continue
        lib, preferred = by_setup[ch.number]
        if not ch.joint_address:
            warnings.append(f"channel {ch.number}: no joint address (300B,1013); no library data")
            continue
        try:
            library[ch.number] = oncentra.library_channel(lib, ch.joint_address, preferred)
        except oncentra.LibraryFormatError as exc:
            warnings.append(named_warning(
                "plan.library",
                f"channel {ch.number}: library not usable ({exc}); no centreline or measured "
                "path for it (export the plan again from Oncentra, or give the applicator)",
            ))  # fmt: skip
    return (library or None), app_name


def _check_library(channels: list, library: dict, warnings: list) -> None:
    """Warn (``plan.library_match``) when the plan's dwells do not lie on the library's source
    path (its measured path, else its centreline): farther than :data:`LIBRARY_PATH_TOL_MM`
    from its polyline."""
    for ch in channels:
        lc = library.get(ch.number)
        if lc is None or ch.n_dwells == 0:
            continue
        on_path = lc.measured_path_mm is not None
        ref = lc.measured_path_mm if on_path else lc.centreline_mm
        tol = LIBRARY_PATH_TOL_MM
        d = polyline_distance_mm(np.asarray(ch.positions_mm, float), np.asarray(ref, float))
        if d.max() > tol:
            warnings.append(named_warning(
                "plan.library_match",
                f"channel {ch.number}: dwells lie up to {d.max():.2f} mm from the library's "
                f"{'source path' if on_path else 'centreline'} (more than {tol:g} mm; Oncentra "
                "puts its dwells on the path within 1e-6 mm): the library may not belong to "
                "this plan (export the plan and its applicator together again)",
            ))  # fmt: skip


def polyline_distance_mm(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Distance of each point to a polyline (its segments, not only its vertices).

    Parameters
    ----------
    points : (n, 3) ndarray
        Points, mm.
    line : (m, 3) ndarray
        Polyline vertices, mm (m >= 1).

    Returns
    -------
    (n,) ndarray
        Distances, mm. Memory O(m) per point (one point at a time).
    """
    if len(line) == 1:
        return np.linalg.norm(points - line[0], axis=1)
    a, b = line[:-1], line[1:]
    ab = b - a
    den = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    out = np.empty(len(points))
    for i, q in enumerate(points):
        t = np.clip(np.einsum("ij,ij->i", q - a, ab) / den, 0.0, 1.0)
        out[i] = np.sqrt(np.min(np.sum((a + t[:, None] * ab - q) ** 2, axis=1)))
    return out


def applicator_from_rtplan(plan: RTPlan):
    """Build an :class:`~ringqa.geometry.Applicator` from the plan's applicator library.

    See :func:`ringqa.io.plan_applicator.applicator_from_rtplan` (conventions there).
    """
    from ringqa.io.plan_applicator import applicator_from_rtplan as build

    return build(plan)
