"""The clinic's measured source paths, prepared for a fit: read, registered, flagged.

A measured item (``ringqa calibrate --measured ...``) is one of

- ``FILE``: a measured source path (CSV/JSON, :mod:`ringqa.io.points`: any subset of relative
  positions, optionally ``sd_mm`` per point or one ``measured_sd_mm``, and a ``method``) of the
  ring channel of the command's INPUT;
- ``APPLICATOR=FILE``: the same for another applicator (a shipped name, folder, applicator
  file or RT Plan), e.g. a second ring of the same cable;
- ``FOLDER`` (or an applicator file or RT Plan): an applicator whose ring channel carries its own
  measured path (the folder's ``measured_path.csv``, the vendor's library path).

Each path is checked against its channel and registered to it as ``--register`` says
(:func:`ringqa.pipeline.reference.review_reference`, the commissioning's own check): a point that
cannot lie in the lumen after registration, or is not along the channel, is flagged and left out
of the fit (said in ``calibration.json`` and ``residuals.csv``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ringqa.errors import RingQAError
from ringqa.geometry.registration import FLAG_INFEASIBLE, FLAG_OUTSIDE
from ringqa.io.points import read_point_set
from ringqa.pipeline.dwells import PathDwells, ReferenceDwells
from ringqa.pipeline.inputs import channel_of, choose_source, load_input
from ringqa.pipeline.reference import review_reference
from ringqa.pipeline.simulate import choose_cable, instrument_radii_m
from ringqa.plan import path_directions
from ringqa.units import m_to_mm

__all__ = [
    "DEFAULT_SD_MM",
    "FALLBACK_SD_MM",
    "CalibrationError",
    "MeasuredApplicator",
    "measured_applicators",
]

#: Standard uncertainty (mm) of a point when the file gives none, by method (issue 26: film
#: about 0.5-1 mm, CT 0.3-0.5 mm; an imaging panel like CT; a vendor's library path is what the
#: vendor says, taken as 0.2 mm). Stated as ASSUMED wherever used.
DEFAULT_SD_MM = {"film": 0.75, "ct": 0.4, "panel": 0.4, "vendor": 0.2}
#: ... and when the method is not stated either.
FALLBACK_SD_MM = 0.5


class CalibrationError(RingQAError):
    """A calibration cannot be done (bad measurements, too few points, no convergence)."""


@dataclass(frozen=True, eq=False)
class MeasuredApplicator:
    """One applicator's measured source path, ready for the fit.

    Attributes
    ----------
    label : str
        Applicator name (unique among the fitted ones).
    input : str
        The applicator input (shipped name, folder, file, RT Plan).
    file : str
        The measured path's file (``""``: the applicator's own path).
    applicator : Applicator
    channel : Channel
        Its ring channel (as loaded: the simulation trims its stem itself).
    cable : str
        The cable preset its source uses (or ``--config``'s ``simulation.cable``).
    relative_position_mm : (m,) ndarray
        Relative positions of the measured points, mm (0 = most distal).
    measured_mm : (m, 3) ndarray
        The points as compared: registered to the channel as ``--register`` says, mm.
    sd_mm : (m,) ndarray
        Each point's standard uncertainty, mm.
    sd_assumed : bool
        The file gave no uncertainty: :data:`DEFAULT_SD_MM` of the method was used.
    method : str
        How the path was measured (film, ct, panel, vendor; ``""`` not stated).
    flags : (m,) ndarray of str
        ``""``, ``"infeasible"`` (cannot lie in the lumen) or ``"outside_channel"``.
    registration : str
        How the path was registered (for the report).
    notes : tuple of str
        The reader's notes (an outlier kept, an encoding).
    files : tuple of Path
        Input files (checksummed into the provenance).
    """

    label: str
    input: str
    file: str
    applicator: Any
    channel: Any
    cable: str
    relative_position_mm: np.ndarray
    measured_mm: np.ndarray
    sd_mm: np.ndarray
    sd_assumed: bool
    method: str
    flags: np.ndarray
    registration: str
    notes: tuple[str, ...]
    files: tuple[Path, ...]

    @property
    def used(self) -> np.ndarray:
        """(m,) bool: points in the fit (not flagged)."""
        return self.flags == ""


def _split_item(item: str, default_input) -> tuple[Any, str]:
    """``(applicator input, measured file or "")`` of one ``--measured`` item."""
    text = str(item)
    if "=" in text and not Path(text).exists():
        app, _, file = text.partition("=")
        if not app or not file:
            raise CalibrationError(
                f"--measured {text!r}: write APPLICATOR=FILE (e.g. ring30x60=film_ring30.csv)"
            )
        return app, file
    p = Path(text)
    if p.is_file() and p.suffix.lower() in (".csv", ".json") and not _is_applicator_json(p):
        if default_input is None:
            raise CalibrationError(
                f"--measured {text}: a measured path file needs an applicator (give INPUT, or "
                "write APPLICATOR=FILE)"
            )
        return default_input, text
    if not p.exists() and (
        (default_input is not None and text == str(default_input)) or not (p.suffix or "/" in text)
    ):
        return text, ""  # an applicator by name (a shipped one): load_input says if unknown
    if not p.exists():
        raise CalibrationError(
            f"--measured {text}: no such file or folder (give a measured path CSV/JSON, an "
            "applicator folder with its measured path, or APPLICATOR=FILE)"
        )
    return text, ""


def _is_applicator_json(p: Path) -> bool:
    """An applicator file (it has channels) rather than a points file."""
    if p.suffix.lower() != ".json":
        return False
    try:
        head = p.read_text(encoding="utf-8-sig", errors="replace")[:20000]
    except OSError:
        return False
    return '"channels"' in head


def measured_applicators(
    items,
    default_input=None,
    *,
    settings,
    sd_mm: float | None = None,
    method: str | None = None,
) -> tuple[MeasuredApplicator, ...]:
    """Read, check and register every ``--measured`` item.

    Parameters
    ----------
    items : sequence of str
        The ``--measured`` items (see the module docstring); empty: ``default_input``'s own
        measured path.
    default_input : str, Path or None
        The command's INPUT.
    settings : CommissionSettings
        Gives the channel, source, cable, registration mode.
    sd_mm : float, optional
        One uncertainty for every point of every path without its own (``--sd-mm``).
    method : str, optional
        The method of paths that do not state one (``--method``).

    Returns
    -------
    tuple of MeasuredApplicator

    Raises
    ------
    CalibrationError
        Nothing to fit, a path without relative positions, an applicator without a measured
        path, two paths of one applicator, cables that differ between applicators.
    """
    items = list(items) or ([str(default_input)] if default_input is not None else [])
    if not items:
        raise CalibrationError("give the measured paths (--measured FILE_OR_FOLDER ...)")
    out: list[MeasuredApplicator] = []
    for item in items:
        app_input, file = _split_item(item, default_input)
        out.append(_prepare(app_input, file, settings, sd_mm, method))
    labels = [m.label for m in out]
    dup = sorted({x for x in labels if labels.count(x) > 1})
    if dup:
        raise CalibrationError(
            f"applicator {dup[0]}: measured twice; give one measured path per applicator (join "
            "the positions into one file)"
        )
    cables = sorted({m.cable for m in out})
    if len(cables) > 1:
        raise CalibrationError(
            f"the measured applicators use different cables ({', '.join(cables)}): a calibration "
            "fits one cable; give the cable with --config ([simulation] cable = ...) or fit them "
            "apart"
        )
    return tuple(out)


def _prepare(app_input, file: str, settings, sd_mm, method) -> MeasuredApplicator:
    loaded = load_input(app_input)
    app = loaded.applicator
    ring = channel_of(app, settings.channel)
    files = tuple(loaded.files)
    notes: tuple[str, ...] = ()
    if file:
        ps = read_point_set(file, kind="path")
        if ps.relative_position_mm is None:
            raise CalibrationError(
                f"{file}: no relative_position_mm column: a measured subset must say where each "
                "point is along the path (relative position, mm, 0 = most distal)"
            )
        rel = np.asarray(ps.relative_position_mm, dtype=float)
        pts_mm = m_to_mm(np.asarray(ps.points_m, dtype=float))
        sd = ps.sd_mm
        meth = ps.method or (method or "")
        notes = tuple(ps.notes)
        files = (*files, Path(file))
        source = f"{Path(file).name}" + (f" ({meth})" if meth else "")
    else:
        path = getattr(ring, "measured_path_m", None)
        if path is None:
            raise CalibrationError(
                f"applicator {app.name}: its {settings.channel} channel has no measured source "
                "path to fit; give one (--measured FILE or APPLICATOR=FILE)"
            )
        rel_m = ring.measured_relative_positions_m
        if rel_m is None:
            raise CalibrationError(
                f"applicator {app.name}: its measured path has neither relative positions nor "
                "a step"
            )
        rel = m_to_mm(np.asarray(rel_m, dtype=float))
        pts_mm = m_to_mm(np.asarray(path, dtype=float))
        sd = None
        kind_vendor = loaded.kind == "rtplan"
        meth = method or ("vendor" if kind_vendor else "")
        source = getattr(ring, "measured_source", "") or "the applicator's measured path"
    assumed = sd is None
    if assumed:
        sd = np.full(rel.size, sd_mm if sd_mm is not None else
                     DEFAULT_SD_MM.get(meth, FALLBACK_SD_MM))  # fmt: skip
    src = choose_source(settings.source, settings.sk_U, loaded.rtplan)
    cable = choose_cable(settings.cable, src.source.name).preset
    capsule_r_m, _ = instrument_radii_m(None, ring, cable)
    reference = ReferenceDwells(
        "measured", rel, PathDwells(pts_mm, path_directions(pts_mm)), None, source
    )
    review = review_reference(app, ring, reference, settings.register, capsule_r_m)
    flags = np.array([str(f) for f in review.flags], dtype=object)
    flags = np.where(np.isin(flags, [FLAG_INFEASIBLE, FLAG_OUTSIDE]), flags, "")
    reg = review.registration
    registration = f"{review.mode}: {reg.description}" if reg is not None else review.mode
    return MeasuredApplicator(
        label=str(app.name),
        input=str(app_input),
        file=str(file),
        applicator=app,
        channel=ring,
        cable=cable,
        relative_position_mm=rel,
        measured_mm=np.asarray(review.registered.dwells.positions_mm, dtype=float),
        sd_mm=np.asarray(sd, dtype=float),
        sd_assumed=assumed,
        method=meth,
        flags=flags.astype(str),
        registration=registration,
        notes=notes,
        files=files,
    )
