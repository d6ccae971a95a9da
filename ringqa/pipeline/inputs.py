"""What the user gave: the applicator, RT Plan, channel and source, checked.

An input is a shipped applicator name, a folder, an applicator JSON file, an RT Plan (``.dcm``,
with Oncentra's applicator library) or an Applicator object; bad inputs are refused here with a
message that says what to change (bad settings already by
:class:`~ringqa.pipeline.settings.CommissionSettings`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ringqa.errors import RingQAError, named_warning
from ringqa.units import m_to_mm

#: Air-kerma strength used when neither the settings nor an RT Plan give one, U (doses are
#: compared relative to each other, so they do not depend on it).
DEFAULT_SK_U = 40820.0


@dataclass(frozen=True, eq=False)
class LoadedInput:
    """The applicator (and RT Plan) an input names.

    Attributes
    ----------
    applicator : Applicator
    rtplan : RTPlan or None
        The RT Plan the applicator came from.
    kind : str
        ``"shipped"``, ``"file"``, ``"folder"``, ``"rtplan"`` or ``"object"``.
    files : tuple of Path
        The input files (checksummed into the provenance).
    notes : tuple of str
        For the report (an RT Structure Set's channel matches and lumen sources).
    """

    applicator: Any
    rtplan: Any
    kind: str
    files: tuple[Path, ...]
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class SourceChoice:
    """The TG-43 source and air-kerma strength of the run.

    Attributes
    ----------
    source : tg43.Source
    sk_U : float
        Air-kerma strength, U.
    notes : tuple of str
        For the report (the RT Plan's source has no TG-43 data; S_K not given).
    sk_given : bool
        S_K came from the option or the RT Plan, not from :data:`DEFAULT_SK_U`. The standard
        plans do not depend on it (their times are scaled to the prescription), but the check of
        the plan's own dwells against the TPS does, and is skipped without it.
    """

    source: Any
    sk_U: float
    notes: tuple[str, ...]
    sk_given: bool = True


def load_input(item, structures=None, lumen_mm: float | None = None) -> LoadedInput:
    """The applicator of a shipped name, folder, applicator JSON, RT Plan or Applicator object;
    with ``structures`` (an RT Structure Set) the RT Plan's channels are its open contours
    (:func:`ringqa.io.rtstruct.applicator_from_structures`, lumens ``lumen_mm`` or the lumen
    table).

    Raises
    ------
    RingQAError
        Not one of those, or unreadable (the readers' errors name the file and field).
    """
    if not isinstance(item, str | Path):
        if hasattr(item, "channels") and hasattr(item, "channel"):
            return LoadedInput(item, None, "object", ())
        raise RingQAError(
            f"input {item!r}: give a shipped applicator name, a folder, an applicator JSON file "
            "or an RT Plan (.dcm)"
        )
    if structures is not None and not str(item).lower().endswith(".dcm"):
        raise RingQAError(
            f"--structures {structures}: an RT Structure Set goes with an RT Plan (.dcm), not "
            f"with {item}"
        )
    path = Path(item).expanduser()
    if path.suffix.lower() == ".dcm" or (path.is_file() and _is_dicom(path)):
        if not path.is_file():
            raise RingQAError(f"input {path}: RT Plan file not found (check the path)")
        from ringqa.io.rtplan import applicator_from_rtplan, read_rtplan

        rtplan = read_rtplan(path)
        if structures is not None:
            from ringqa.io.rtstruct import applicator_from_structures, read_rtstruct

            built = applicator_from_structures(rtplan, read_rtstruct(structures), lumen_mm=lumen_mm)
            return LoadedInput(built.applicator, rtplan, "rtplan+rtstruct",
                               (path, Path(structures)), built.notes)  # fmt: skip
        return LoadedInput(applicator_from_rtplan(rtplan), rtplan, "rtplan", (path,))
    from ringqa.io.applicator_file import load_applicator

    app = load_applicator(item)
    if path.is_dir():
        files = tuple(sorted(p for p in path.iterdir() if p.is_file()))
        return LoadedInput(app, None, "folder", files)
    if path.is_file():
        return LoadedInput(app, None, "file", (path,))
    return LoadedInput(app, None, "shipped", _shipped_file(str(item)))


def _shipped_file(name: str) -> tuple[Path, ...]:
    try:
        from ringqa.paths import data_dir

        p = data_dir() / "applicators" / f"{name}.json"
        return (p,) if p.is_file() else ()
    except FileNotFoundError:
        return ()


def _is_dicom(path: Path) -> bool:
    try:
        with open(path, "rb") as fh:
            head = fh.read(132)
        return head[128:132] == b"DICM"
    except OSError:
        return False


def channel_of(app, name: str):
    """The applicator's channel ``name``.

    Raises
    ------
    RingQAError
        The applicator has no such channel (the message lists those it has).
    """
    names = [c.name for c in app.channels]
    if name not in names:
        raise RingQAError(
            f"applicator {app.name}: no channel {name!r} (it has {', '.join(names) or 'none'})"
        )
    return app.channel(name)


def check_measured_path(input, ring, channel: str, kind: str, require_measured) -> None:
    """Refuse a channel without a measured source path where one is required.

    ``require_measured`` None means: required for user files (folder, JSON, RT Plan), not for
    shipped applicators and Applicator objects.
    """
    if require_measured is None:
        require_measured = kind in ("folder", "file", "rtplan", "rtplan+rtstruct")
    if require_measured and getattr(ring, "measured_path_m", None) is None:
        raise RingQAError(
            f"{input}: no measured source path for channel {channel!r} (add the measured path, "
            "e.g. a CSV with x_mm,y_mm,z_mm, most distal position first, or allow the "
            "comparison with the centreline: --centreline-reference)"
        )


def choose_source(source, sk_U: float | None, rtplan) -> SourceChoice:
    """The TG-43 source and S_K: as given, else the RT Plan's, else Flexisource and 40820 U
    (then ``sk_given`` is False and, for an RT Plan, a note says what it means).

    Parameters
    ----------
    source : str, tg43.Source or None
    sk_U : float or None
        Air-kerma strength, U.
    rtplan : RTPlan or None

    Returns
    -------
    SourceChoice
    """
    import tg43

    sk_given = True
    notes: tuple[str, ...] = ()
    if sk_U is None:
        sk_U = getattr(getattr(rtplan, "source", None), "sk_U", None)
        if not sk_U:
            sk_given, sk_U = False, DEFAULT_SK_U
            if rtplan is not None:
                notes = (
                    "The RT Plan gives no source strength (ReferenceAirKermaRate): the standard "
                    "plans do not depend on it, but the plan's own dwells could not be dosed "
                    "against the TPS (give the strength with --sk-u).",
                )
    if isinstance(source, tg43.Source):
        return SourceChoice(source, float(sk_U), notes, sk_given)
    if source is not None:
        return SourceChoice(tg43.load_source(source), float(sk_U), notes, sk_given)
    if rtplan is not None:
        name = getattr(rtplan.source, "tg43_name", None)
        if name:
            return SourceChoice(tg43.load_source(name), float(sk_U), notes, sk_given)
        notes = (
            *notes,
            named_warning(
                "plan.source_model",
                f"The RT Plan's source ({getattr(rtplan.source, 'model', '?')}) has no TG-43 "
                "data in ringqa; the Flexisource data were used (choose one with --source).",
            ),
        )
    return SourceChoice(tg43.load_source("flexisource"), float(sk_U), notes, sk_given)


def kink_notes(app, channel) -> tuple[str, ...]:
    """One sentence per kink of ``channel``'s centreline (:mod:`ringqa.geometry.kinks`)."""
    from ringqa.geometry import Channel
    from ringqa.geometry.families import family_of
    from ringqa.geometry.kinks import find_kinks

    if not isinstance(channel, Channel):
        return ()
    family = family_of(app, channel)
    out = list(family.checks(app, channel))
    for k in find_kinks(channel, float(family.curvature_scale_m(app, channel))):
        rel = m_to_mm(channel.s_ref_m - k.s_m)
        out.append(
            f"The {channel.name} channel's centreline bends sharply at arc length "
            f"{m_to_mm(k.s_m):.1f} mm (relative position {rel:.1f} mm): curvature "
            f"{k.curvature_per_m:.0f} 1/m (radius {m_to_mm(1.0 / k.curvature_per_m):.1f} mm) over "
            f"{m_to_mm(k.length_m):.1f} mm, against {k.median_per_m:.0f} 1/m around it. This "
            "looks like a kink in the channel model, not the channel: a stiff cable sticks there "
            "and the dwells beyond it may settle in more than one place (see the numerical "
            "error). Straathof et al. corrected the library centreline from CT at the proximal "
            "ring: --centreline-correction."
        )
    return tuple(out)


def loaded_text(app, ring, kind: str) -> str:
    """One sentence: what was loaded (channels, lengths, lumen, measured path)."""
    parts = []
    for ch in app.channels:
        text = f"{ch.name} channel {m_to_mm(float(ch.centreline.length_m)):.1f} mm long"
        lumen = getattr(ch, "lumen", None)
        if lumen is not None and hasattr(lumen, "kernel_arrays"):
            rb = np.asarray(lumen.kernel_arrays()[1], dtype=float)
            if rb.size:
                lo, hi = 2 * m_to_mm(float(rb.min())), 2 * m_to_mm(float(rb.max()))
                text += (
                    f", lumen {lo:.2f} mm"
                    if abs(hi - lo) < 1e-9
                    else f", lumen {lo:.2f}-{hi:.2f} mm"
                )
        path = getattr(ch, "measured_path_m", None)
        if path is not None:
            step = getattr(ch, "measured_step_m", None)
            step_txt = f" at {m_to_mm(float(step)):g} mm" if step else ""
            text += f", measured path {len(path)} positions{step_txt}"
        else:
            text += ", no measured path"
        parts.append(text)
    from ringqa.geometry.families import family_of

    s_ref = m_to_mm(ring.s_ref_m)
    family = family_of(app, ring)
    if family.name == "ring":
        from ringqa.geometry.frame import frame_of

        radius = m_to_mm(float(frame_of(app).scale_m))
        frame = f"; ring centreline radius {radius:.2f} mm"
    else:
        frame = f"; {ring.name} is a {family.words.channel} ({family.name} family)"
    return (
        f"Loaded ({kind}): {app.name}; " + "; ".join(parts)
        + f"{frame}; s_ref ({ring.name}) = {s_ref:.2f} mm."
    )  # fmt: skip
