"""Generate the bad-input corpus (issue 18) from the shipped examples.

    python tests/corpus/make_corpus.py DIR        # writes the input files into DIR, lists the cases

Every input is DERIVED from a shipped file at generation time (``data/examples`` RT Plan,
``data/applicators`` rings, ``data/scenes``): no binary file of the corpus is kept in git. The
cases are :class:`Case` records; ``tests/corpus/test_corpus.py`` runs each through
``ringqa.cli.main`` in-process and checks its outcome.

Argument placeholders: ``{c}`` is the corpus folder, ``{out}`` the case's output folder.
"""

from __future__ import annotations

import gzip
import json
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "data"
PLAN = DATA / "examples" / "oncentra_ring26x60" / "RP_ring26x60_oncentra43.dcm"
RING = DATA / "applicators" / "ring26x60.json"
SCENES = DATA / "scenes"

CATEGORIES = (
    "plans", "libraries", "folders", "scenes", "options", "config", "output", "signals", "export",
)  # fmt: skip
#: scene settings that make a commissioning run of the example plan take ~2 s instead of ~20 s
FAST = ("--set", "solver.increment_mm=1.0", "--set", "discretisation.element_length_mm.cable=3.0")
#: the same for the shipped rings' Flexitron cable (sections capsule, thin, thick)
FAST_RING = (
    "--set",
    "solver.increment_mm=1.0",
    "--set",
    "discretisation.element_length_mm.thin=3.0",
)


@dataclass(frozen=True)
class Case:
    """One corpus case and its expected outcome.

    Attributes
    ----------
    name : str
        Unique, also the output folder's name.
    category : str
        One of :data:`CATEGORIES`.
    argv : tuple of str
        The command line (placeholders ``{c}``, ``{out}``).
    exit_code : int
        Expected exit status (0 accepted, 2 refused, 143/130 signals).
    word : str
        A word the terminal output (stdout + stderr) must contain.
    warning : str
        For an accepted input: the check name of a warning that must appear on the terminal and
        in the output's ``results.json`` (``warnings``) or ``plan.json`` (``notices``).
    check : callable or None
        For "accepted and correct": ``check(out_dir)`` asserts a number of the output.
    setup : str
        A fault the test arranges (``enospc``, ``sigterm``, ``readonly``, ...; see the test).
    env : tuple of (str, str)
        Environment variables set for the case (``RINGQA_CONFIG``).
    slow : bool
        Marked ``slow`` (a full commissioning of more than one input).
    """

    name: str
    category: str
    argv: tuple[str, ...]
    exit_code: int
    word: str
    warning: str = ""
    check: Callable[[Path], None] | None = field(default=None, compare=False)
    setup: str = ""
    slow: bool = False
    env: tuple[tuple[str, str], ...] = ()

    @property
    def outcome(self) -> str:
        """``refused``, ``warning``, ``accepted`` or ``interrupted`` (counts in the docs)."""
        if self.exit_code in (129, 130, 143):
            return "interrupted"
        if self.exit_code != 0:
            return "refused"
        return "warning" if self.warning else "accepted"


# ---------------------------------------------------------------- helpers
def _ring_doc() -> dict:
    return json.loads(RING.read_text(encoding="utf-8"))


def _write_json(path: Path, doc) -> Path:
    path.write_text(json.dumps(doc, indent=1), encoding="utf-8")
    return path


def _scale_centreline(doc: dict, factor: float) -> None:
    ch = _ring_channel(doc)
    ch["centreline_mm"] = (np.array(ch["centreline_mm"]) * factor).tolist()


def _ring_channel(doc: dict) -> dict:
    return next(c for c in doc["channels"] if c["name"] == "ring")


def _csv(path: Path, pts_mm, header: str = "x_mm,y_mm,z_mm", pre: str = "",
         encoding: str = "utf-8") -> Path:  # fmt: skip
    rows = "\n".join(",".join(f"{v:.6f}" for v in p) for p in np.asarray(pts_mm, float))
    path.write_text(pre + header + "\n" + rows + "\n", encoding=encoding)
    return path


def _arclength(pts: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])


def _path_on(cl_mm: np.ndarray, s_ref_mm: float, n: int, step_mm: float) -> np.ndarray:
    """n source positions on the centreline, most distal first, ``step_mm`` apart in arc length."""
    s = _arclength(cl_mm)
    targets = s_ref_mm - step_mm * np.arange(n)
    return np.column_stack([np.interp(targets, s, cl_mm[:, k]) for k in range(3)])


def _bump(cl_mm: np.ndarray, s0_mm: float, width_mm: float, height_mm: float) -> np.ndarray:
    """The centreline with a smooth sideways bump (1 - cos) on its straight stem: largest
    curvature height/2 (2 pi / width)^2 (1/mm), i.e. bend radius 2 width^2 / (4 pi^2 height)."""
    cl = np.array(cl_mm, float)
    s = _arclength(cl)
    t = (cl[1] - cl[0]) / np.linalg.norm(cl[1] - cl[0])
    side = np.cross(t, [1.0, 0.0, 0.0])
    side /= np.linalg.norm(side)
    # resample the stem finely so the bump is resolved
    fine = np.arange(0.0, s0_mm + width_mm + 2.0, 0.1)
    stem = cl[0] + np.outer(fine, t)
    u = np.clip((fine - s0_mm) / width_mm, 0.0, 1.0)
    stem += np.outer(height_mm / 2 * (1 - np.cos(2 * np.pi * u)), side)
    rest = cl[s > fine[-1] + 0.05]
    return np.vstack([stem, rest])


def _folder(root: Path, name: str, cl_mm, path_mm, spec: dict, *, path_header="x_mm,y_mm,z_mm",
            cl_pre: str = "", cl_encoding: str = "utf-8") -> Path:  # fmt: skip
    d = root / name
    d.mkdir(parents=True, exist_ok=True)
    _csv(d / "centreline.csv", cl_mm, pre=cl_pre, encoding=cl_encoding)
    if path_mm is not None:
        _csv(d / "measured_path.csv", path_mm, header=path_header)
    _write_json(d / "applicator.json", spec)
    return d


# ------------------------------------------------------------- RT Plans
def _plan_ds():
    import pydicom

    return pydicom.dcmread(PLAN)


def _save(ds, path: Path) -> Path:
    ds.save_as(path, enforce_file_format=True)
    return path


def _library_edit(ds, old: str, new: str, count: int = 1):
    """Replace text in the embedded Oncentra library (gzip UTF-16 XML, tag (300B,100D))."""
    from ringqa.io import oncentra

    setup = ds.ApplicationSetupSequence[0]
    el = setup[oncentra.LIBRARY_TAG]
    text = oncentra.decode_library(el.value)
    assert old in text, old
    text = text.replace(old, new, count)
    # level 1: the same XML once decompressed; level 9 took ~1 s a library, at every
    # collection in every test process (the corpus is built on import)
    el.value = gzip.compress(text.encode("utf-16"), compresslevel=1)
    return ds


def _plans(c: Path) -> list[Case]:
    cases: list[Case] = []
    imp = ("import",)

    def add(name, argv, code, word, **kw):
        cases.append(Case(name, "plans", tuple(argv), code, word, **kw))

    raw = PLAN.read_bytes()
    (c / "plan_truncated.dcm").write_bytes(raw[: len(raw) // 3])
    add("plan_truncated", [*imp, "{c}/plan_truncated.dcm", "--out", "{out}"], 2, "truncated")
    (c / "plan_header_only.dcm").write_bytes(raw[:200])
    add(
        "plan_header_only",
        [*imp, "{c}/plan_header_only.dcm", "--out", "{out}"],
        2,
        "plan_header_only.dcm",
    )
    (c / "plan_not_dicom.dcm").write_text("this is a text file, not DICOM\n")
    add("plan_not_dicom", [*imp, "{c}/plan_not_dicom.dcm", "--out", "{out}"], 2, "DICOM")
    (c / "plan_empty.dcm").write_bytes(b"")
    add("plan_empty", [*imp, "{c}/plan_empty.dcm", "--out", "{out}"], 2, "plan_empty.dcm")
    add(
        "plan_missing_file", [*imp, "{c}/no_such_plan.dcm", "--out", "{out}"], 2, "no_such_plan.dcm"
    )

    ds = _plan_ds()
    ds.Modality = "RTSTRUCT"
    ds.SOPClassUID = "1.2.840.10008.5.1.4.1.1.481.3"
    _save(ds, c / "rtstruct_as_plan.dcm")
    add("plan_rtstruct", [*imp, "{c}/rtstruct_as_plan.dcm", "--out", "{out}"], 2, "RTSTRUCT")
    add("plan_rtstruct_commission", ["commission", "{c}/rtstruct_as_plan.dcm", "--out", "{out}"],
        2, "RTSTRUCT")  # fmt: skip

    ds = _plan_ds()
    ds.ApplicationSetupSequence[0].ChannelSequence[0].ChannelTotalTime = "0"
    _save(ds, c / "plan_ring_time0.dcm")
    add("plan_ring_time0", [*imp, "{c}/plan_ring_time0.dcm", "--out", "{out}"], 0,
        "ChannelTotalTime",
        warning="plan.channel_time")  # fmt: skip

    ds = _plan_ds()
    ch = ds.ApplicationSetupSequence[0].ChannelSequence[0]
    ch.ChannelTotalTime = f"{float(ch.ChannelTotalTime) * 10:.6f}"
    _save(ds, c / "plan_ring_time_x10.dcm")

    def tps_action(out: Path) -> None:
        """Ring time x10 (202 -> 2023 s) with the tandem unchanged: the plan's own dose at the
        TPS points rises by several times, far beyond the 5 % action level."""
        data = json.loads((out / "results.json").read_text())
        v = next(v for v in data["verdicts"] if v["check"] == "dose: plan's own dwells vs TPS")
        assert v["status"] == "ACTION" and v["value"] > 100.0, v

    add("plan_ring_time_x10", ["commission", "{c}/plan_ring_time_x10.dcm", "--out", "{out}",
        "--no-pdf", "--quiet", *FAST], 0, "ACTION dose: plan's own dwells vs TPS",
        warning="plan.tps_dose", check=tps_action)  # fmt: skip

    ds = _plan_ds()
    ds.ApplicationSetupSequence[0].ChannelSequence[0].ChannelTotalTime = "-5"
    _save(ds, c / "plan_negative_time.dcm")
    add("plan_negative_time", [*imp, "{c}/plan_negative_time.dcm", "--out", "{out}"], 2, "negative")

    ds = _plan_ds()
    del ds.SourceSequence[0].ReferenceAirKermaRate
    _save(ds, c / "plan_no_sk.dcm")
    add("plan_no_sk", ["commission", "{c}/plan_no_sk.dcm", "--out", "{out}", "--no-pdf",
        "--quiet", *FAST], 0, "--sk-u", warning="plan.no_sk")  # fmt: skip

    def tps_pass(out: Path) -> None:
        """With --sk-u equal to the plan's original 40 820 U, the TPS check is made and passes
        (the example's own dwells reproduce its TPS doses within the 5 % action level)."""
        data = json.loads((out / "results.json").read_text())
        assert data["settings"]["sk_U"] == 40820.0
        v = next(v for v in data["verdicts"] if v["check"] == "dose: plan's own dwells vs TPS")
        assert v["status"] == "PASS" and v["value"] < 5.0, v

    add("plan_no_sk_given", ["commission", "{c}/plan_no_sk.dcm", "--out", "{out}", "--no-pdf",
        "--quiet", "--sk-u", "40820", *FAST], 0, "PASS dose: plan's own dwells vs TPS",
        check=tps_pass)  # fmt: skip

    ds = _plan_ds()
    src = ds.SourceSequence[0]
    src.SourceIsotopeName = "Co-60"
    src.SourceIsotopeHalfLife = "1925.2"
    src.SourceManufacturer = "Eckert & Ziegler BEBIG"
    src.SourceModelID = "Co0.A86"
    if "SourceDescription" in src:
        src.SourceDescription = "Co-60 Co0.A86"
    _save(ds, c / "plan_co60.dcm")
    add("plan_co60", ["commission", "{c}/plan_co60.dcm", "--out", "{out}", "--no-pdf", "--quiet",
        "--cable", "microselectron", *FAST], 0, "Co-60", warning="plan.isotope")  # fmt: skip
    add("plan_co60_import", [*imp, "{c}/plan_co60.dcm", "--out", "{out}"], 0, "Co-60",
        warning="plan.isotope")  # fmt: skip

    ds = _plan_ds()
    for s in ds.ApplicationSetupSequence:
        for ch in s.ChannelSequence:
            for cp in ch.BrachyControlPointSequence:
                if "ControlPoint3DPosition" in cp:
                    cp.ControlPoint3DPosition = [float(v) * 1e6 for v in cp.ControlPoint3DPosition]
    _save(ds, c / "plan_coords_x1e6.dcm")
    add("plan_coords_x1e6", [*imp, "{c}/plan_coords_x1e6.dcm", "--out", "{out}"], 2, "mm")

    ds = _plan_ds()
    del ds.ApplicationSetupSequence
    _save(ds, c / "plan_no_setups.dcm")
    add(
        "plan_no_setups",
        [*imp, "{c}/plan_no_setups.dcm", "--out", "{out}"],
        2,
        "ApplicationSetupSequence",
    )

    ds = _plan_ds()
    cps = ds.ApplicationSetupSequence[0].ChannelSequence[0].BrachyControlPointSequence
    cps[-1].CumulativeTimeWeight = "0"
    _save(ds, c / "plan_weights_fall.dcm")
    add(
        "plan_weights_fall",
        [*imp, "{c}/plan_weights_fall.dcm", "--out", "{out}"],
        2,
        "CumulativeTimeWeight",
    )

    # issue 25: plan content that used to pass without a word
    ds = _plan_ds()
    ds.BrachyTreatmentType = "LDR"
    _save(ds, c / "plan_ldr.dcm")
    add("plan_ldr", [*imp, "{c}/plan_ldr.dcm", "--out", "{out}"], 0, "LDR",
        warning="plan.treatment_type")  # fmt: skip
    ds = _plan_ds()
    ds.ApplicationSetupSequence[0].ChannelSequence[0].ReferencedSourceNumber = 5
    _save(ds, c / "plan_missing_source.dcm")
    add("plan_missing_source", [*imp, "{c}/plan_missing_source.dcm", "--out", "{out}"], 0,
        "ReferencedSourceNumber 5", warning="plan.source_reference")  # fmt: skip
    ds = _plan_ds()
    ref = ds.DoseReferenceSequence[2]
    del ref.DoseReferencePointCoordinates
    ref.DoseReferenceDescription = "Bladder\x1b[31m PASS\x1b[0m"  # an ANSI escape in the name
    _save(ds, c / "plan_point_no_coordinates.dcm")
    add("plan_point_no_coordinates", [*imp, "{c}/plan_point_no_coordinates.dcm", "--out",
        "{out}"], 0, "Bladder\\x1b[31m", warning="plan.dose_point",
        setup="no_raw_escape")  # fmt: skip
    ds = _plan_ds()
    for cp in ds.ApplicationSetupSequence[0].ChannelSequence[0].BrachyControlPointSequence:
        x, y, z = (float(v) for v in cp.ControlPoint3DPosition)
        cp.ControlPoint3DPosition = [x, y, z + 0.3]
    _save(ds, c / "plan_library_mismatch.dcm")
    add("plan_library_mismatch", [*imp, "{c}/plan_library_mismatch.dcm", "--out", "{out}"], 0,
        "library may not belong", warning="plan.library_match")  # fmt: skip
    return cases


def _libraries(c: Path) -> list[Case]:
    """Applicator files and the Oncentra library embedded in a plan."""
    cases: list[Case] = []

    def add(name, argv, code, word, **kw):
        cases.append(Case(name, "libraries", tuple(argv), code, word, **kw))

    def app(name: str, edit, code: int, word: str, **kw) -> None:
        doc = _ring_doc()
        edit(doc)
        _write_json(c / f"{name}.json", doc)
        add(name, ["commission", f"{{c}}/{name}.json", "--out", "{out}", "--quiet",
            "--centreline-reference"], code, word, **kw)  # fmt: skip

    def rename(key_from, key_to, where="ring"):
        def edit(doc):
            ch = _ring_channel(doc) if where == "ring" else doc
            ch[key_to] = ch.pop(key_from)

        return edit

    app("lib_sref_mm", rename("s_ref_mm", "sref_mm"), 2, "did you mean 's_ref_mm'")
    app("lib_lumen_diameter_mm",
        lambda d: _ring_channel(d)["lumen"].update(lumen_diameter_mm=3.0), 2, "r_b_mm")  # fmt: skip
    app("lib_length_mm_wrong", lambda d: _ring_channel(d).update(length_mm=1500.0), 2, "length_mm")
    app("lib_length_mm_text", lambda d: _ring_channel(d).update(length_mm="long"), 2, "length_mm")
    app("lib_top_level_typo", rename("ring_frame", "ringframe", where="top"), 2, "ring_frame")
    app("lib_negative_lumen", lambda d: _ring_channel(d)["lumen"].update(r_b_mm=-1.5), 2, "r_b_mm")
    app("lib_centreline_cm",
        lambda d: _scale_centreline(d, 0.1),
        2, "centimetres")  # fmt: skip
    app("lib_tip_first",
        lambda d: _ring_channel(d).update(centreline_mm=_ring_channel(d)["centreline_mm"][::-1]),
        2, "tip")  # fmt: skip
    app("lib_coords_x1e6",
        lambda d: _scale_centreline(d, 1e6),
        2, "10 m")  # fmt: skip

    def stepped(doc):
        _ring_channel(doc)["lumen"] = {"kind": "stepped", "r_b_mm": [1.5, 1.4, 1.5],
                                       "s_breaks_mm": [100.0, 60.0]}  # fmt: skip

    app("lib_s_breaks_decreasing", stepped, 2, "do not increase")

    def nan_point(doc):
        _ring_channel(doc)["centreline_mm"][40][1] = float("nan")

    app("lib_nan_point", nan_point, 2, "finite")

    def bent(height_mm, width_mm, channel="ring"):
        def edit(doc):
            ch = next(c for c in doc["channels"] if c["name"] == channel)
            ch["centreline_mm"] = _bump(
                np.array(ch["centreline_mm"]), 20.0, width_mm, height_mm
            ).tolist()
            ch.pop("length_mm", None)  # the bump lengthens the channel

        return edit

    # bend radius 2 w^2 / (4 pi^2 h): w 6 mm, h 2 mm -> 0.91 mm, tighter than the 1.5 mm lumen
    app("lib_bend_1mm", bent(2.0, 6.0), 2, "channel.curvature")
    # in the tandem (lumen radius 1.25 mm): w 6 mm, h 1.2 mm -> 1.52 mm, wider than the lumen
    # radius, but the Flexitron's 4.6 mm capsule (radius 0.425 mm) passes only bends of radius
    # 4.6^2 / (16 x 0.825) = 1.60 mm or more
    app("lib_bend_capsule", bent(1.2, 6.0, "tandem"), 0, "channel.tight_bend",
        warning="channel.tight_bend")  # fmt: skip

    def loop(doc):
        """The ring's circle (radius 13 mm, z = 0, counter-clockwise, tip at 265.5 deg) run on
        for 200 deg more, rising 1 mm: the extra part passes 0.3-1 mm above the circle's start,
        ~150 mm further along the channel (a second turn)."""
        ch = _ring_channel(doc)
        cl = np.array(ch["centreline_mm"])
        tip = np.degrees(np.arctan2(cl[-1, 1], cl[-1, 0])) % 360.0
        phi = np.radians(tip + np.arange(1.0, 201.0))
        rise = np.linspace(0.0, 1.0, phi.size)
        extra = np.column_stack([13.0 * np.cos(phi), 13.0 * np.sin(phi), cl[-1, 2] + rise])
        ch["centreline_mm"] = np.vstack([cl, extra]).tolist()
        ch["s_ref_mm"] = float(_arclength(np.array(ch["centreline_mm"]))[-1] - 5.0)
        ch.pop("length_mm", None)

    app("lib_self_overlap", loop, 2, "channel.self_intersection")
    (c / "lib_not_json.json").write_text("{ this is: not json, ]")
    add("lib_not_json", ["commission", "{c}/lib_not_json.json", "--out", "{out}"], 2, "JSON")
    _write_json(c / "lib_list.json", [1, 2, 3])
    add("lib_json_list", ["commission", "{c}/lib_list.json", "--out", "{out}"], 2, "lib_list.json")
    (c / "lib_empty.json").write_text("")
    add(
        "lib_empty_json",
        ["commission", "{c}/lib_empty.json", "--out", "{out}"],
        2,
        "lib_empty.json",
    )

    # strict JSON (issue 25): a key twice, deep nesting, NaN, encodings
    text = json.dumps(_ring_doc(), indent=1)
    dup = text.replace('"s_ref_mm":', '"s_ref_mm": 100.0,\n   "s_ref_mm":', 1)
    (c / "lib_duplicate_key.json").write_text(dup)
    add("lib_duplicate_key", ["commission", "{c}/lib_duplicate_key.json", "--out", "{out}"], 2,
        "key 's_ref_mm' is given twice")  # fmt: skip
    (c / "lib_deep.json").write_text("[" * 200_000 + "]" * 200_000)
    add("lib_deep_json", ["commission", "{c}/lib_deep.json", "--out", "{out}"], 2,
        "nested too deeply")  # fmt: skip
    (c / "lib_cp1252.json").write_bytes(text.replace('"ring26x60"', '"ring 26\u00b0"', 1)
                                        .encode("cp1252"))  # fmt: skip
    add("lib_cp1252_json", ["commission", "{c}/lib_cp1252.json", "--out", "{out}"], 2,
        "not UTF-8 text: byte 0xb0")  # fmt: skip
    (c / "lib_utf16.json").write_bytes(text.encode("utf-16"))

    def utf16_read(out: Path) -> None:
        """The ring26x60 file saved as UTF-16 (with its BOM) reads like the original: the
        applicator's name and 147.90 mm ring channel (docs/validation.md)."""
        data = json.loads((out / "results.json").read_text())
        assert data["applicator"] == "ring26x60", data["applicator"]

    add("lib_utf16_json", ["commission", "{c}/lib_utf16.json", "--out", "{out}", "--quiet",
        "--no-pdf", "--centreline-reference", *FAST_RING], 0, "centreline reference",
        check=utf16_read)  # fmt: skip

    # the Oncentra library inside the example plan
    ds = _library_edit(_plan_ds(), '<transform jointAddress="@" matrix="-0.9944154088620123 ',
                       '<transform jointAddress="@" matrix="NaN ')  # fmt: skip
    _save(ds, c / "oncentra_nan_transform.dcm")
    add("oncentra_nan_transform", ["import", "{c}/oncentra_nan_transform.dcm", "--out", "{out}"],
        0, "non-finite", warning="plan.library")  # fmt: skip
    add("oncentra_nan_transform_commission", ["commission", "{c}/oncentra_nan_transform.dcm",
        "--out", "{out}"], 2, "non-finite")  # fmt: skip
    ds = _library_edit(_plan_ds(), '<lumen diameter="3" />', '<lumen diameter="-3" />')
    _save(ds, c / "oncentra_negative_lumen.dcm")
    add("oncentra_negative_lumen", ["commission", "{c}/oncentra_negative_lumen.dcm", "--out",
        "{out}"],
        2, "lumen diameter")  # fmt: skip
    ds = _library_edit(_plan_ds(), 'stepsize="2.5"', 'stepsize="5"')
    _save(ds, c / "oncentra_step5.dcm")
    add(
        "oncentra_step5", ["commission", "{c}/oncentra_step5.dcm", "--out", "{out}"], 2, "says 5 mm"
    )
    ds = _library_edit(_plan_ds(), '<lumen diameter="3" />', '<lumen diameter="0.8" />')
    _save(ds, c / "oncentra_narrow_lumen.dcm")
    add("oncentra_narrow_lumen", ["commission", "{c}/oncentra_narrow_lumen.dcm", "--out", "{out}",
        "--quiet"], 2, "cannot pass")  # fmt: skip
    return cases


def _folders(c: Path) -> list[Case]:
    cases: list[Case] = []

    def add(name, argv, code, word, **kw):
        cases.append(Case(name, "folders", tuple(argv), code, word, **kw))

    doc = _ring_doc()
    ring = _ring_channel(doc)
    cl = np.array(ring["centreline_mm"])
    s_ref = float(ring["s_ref_mm"])
    path = _path_on(cl, s_ref, 12, 2.5)
    spec = {"name": "corpus-ring", "lumen": ring["lumen"], "s_ref_mm": s_ref,
            "measured_step_mm": 2.5}  # fmt: skip
    base = ["commission", "--out", "{out}", "--quiet", "--no-pdf"]

    def folder(name, cl_mm=cl, path_mm=path, spec=spec, **kw):
        _folder(c, name, cl_mm, path_mm, spec, **kw)
        return f"{{c}}/{name}"

    (c / "empty_folder").mkdir(exist_ok=True)
    add("folder_empty", [*base, "{c}/empty_folder"], 2, "no applicator")
    junk = c / "junk_folder"
    junk.mkdir(exist_ok=True)
    (junk / "notes.txt").write_text("nothing here")
    add("folder_only_junk", [*base, "{c}/junk_folder"], 2, "no applicator")
    add("folder_missing", [*base, "{c}/no_such_folder"], 2, "no_such_folder")

    def n_positions(n: int):
        def check(out: Path) -> None:
            """The folder's 12-position path (2.5 mm apart) gives 12 measured dwells."""
            dw = (out / "dwells.csv").read_text().splitlines()
            head = dw[0].split(",")
            k = head.index("path")
            assert sum(1 for r in dw[1:] if r.split(",")[k] == "measured") == n

        return check

    add("folder_ok", [*base, folder("ok")], 0, "measured reference", check=n_positions(12))
    add("folder_latin1_csv", [*base, folder("latin1", cl_pre="# Kanal für den Ring, gemessen\n",
        cl_encoding="latin-1")], 0, "Latin-1", warning="csv.encoding",
        check=n_positions(12))  # fmt: skip
    add("folder_bom_csv", [*base, folder("bom", cl_encoding="utf-8-sig")], 0, "measured reference",
        check=n_positions(12))  # fmt: skip
    arg = folder("empty_csv")
    (c / "empty_csv" / "centreline.csv").write_text("")
    add("folder_empty_csv", [*base, arg], 2, "centreline.csv")
    arg = folder("header_only_csv")
    (c / "header_only_csv" / "measured_path.csv").write_text("x_mm,y_mm,z_mm\n")
    add("folder_header_only_csv", [*base, arg], 2, "measured_path.csv")
    arg = folder("missing_column")
    _csv(c / "missing_column" / "centreline.csv", cl[:, :2], header="x_mm,y_mm")
    add("folder_missing_column", [*base, arg], 2, "z_mm")
    add("folder_path_reversed", [*base, folder("reversed", path_mm=path[::-1])], 2, "reverse")
    up20 = path + np.array([0.0, 0.0, 20.0])
    add("folder_path_shifted", [*base, folder("shifted", path_mm=up20)], 2,
        "20.0 mm")  # fmt: skip
    add("folder_step_declared_5", [*base, folder("step5", spec={**spec, "measured_step_mm": 5.0})],
        2, "measured_step_mm")  # fmt: skip
    add("folder_unknown_key", [*base, folder("typo", spec={**spec, "lumen_diameter_mm": 3.0})], 2,
        "lumen_diameter_mm")  # fmt: skip
    add("folder_path_metres", [*base, folder("metres", path_mm=path / 1000)], 2, "metres")
    arg = folder("dup_column")
    dup = np.column_stack([cl, cl[:, 0] + 5.0])
    _csv(c / "dup_column" / "centreline.csv", dup, header="x_mm,y_mm,z_mm,x_mm")
    add("folder_duplicate_column", [*base, arg], 2, "column 'x_mm' twice")
    add("folder_utf16_csv", [*base, folder("utf16", cl_encoding="utf-16")], 0, "UTF-16",
        warning="csv.encoding", check=n_positions(12))  # fmt: skip
    arg = folder("dup_key")
    text = json.dumps(spec).replace('"s_ref_mm":', '"s_ref_mm": 50.0, "s_ref_mm":', 1)
    (c / "dup_key" / "applicator.json").write_text(text)
    add("folder_duplicate_key", [*base, arg], 2, "given twice")

    # a folder of two applicators with the same name, plus one broken: three rows, two folders
    batch = c / "batch_same_name"
    for sub in ("a", "b"):
        _folder(batch, sub, cl, path, {**spec, "name": "same"})

    def two_same(out: Path) -> None:
        """Two applicators both named 'same': two subfolders (same, same-2), each marked, and
        summary.csv one row per input."""
        subs = sorted(p.name for p in out.iterdir() if p.is_dir())
        assert subs == ["same", "same-2"], subs
        for s in subs:
            assert (out / s / ".ringqa-output.json").is_file()
        rows = (out / "summary.csv").read_text().strip().splitlines()
        assert len(rows) == 3, rows

    add("folder_two_same_name", [*base, "{c}/batch_same_name"], 0, "2 of 2", check=two_same,
        slow=True)  # fmt: skip
    mixed = c / "batch_mixed"
    _folder(mixed, "good", cl, path, {**spec, "name": "good"})
    _folder(mixed, "bad", cl, path[::-1], {**spec, "name": "bad"})

    def one_failed(out: Path) -> None:
        """One of two inputs fails: the good one is written, summary.csv has both rows."""
        rows = (out / "summary.csv").read_text().strip().splitlines()
        assert len(rows) == 3 and sum("ERROR" in r for r in rows) == 1, rows
        assert (out / "good" / "results.json").is_file() and not (out / "bad").exists()

    add("folder_batch_one_bad", [*base, "{c}/batch_mixed"], 2, "reverse", check=one_failed,
        slow=True)  # fmt: skip
    return cases


def _scenes(c: Path) -> list[Case]:
    cases: list[Case] = []
    arc = (SCENES / "arc-frictionless.toml").read_text()

    def add(name, text, code, word, extra=(), **kw):
        if text is not None:
            (c / f"{name}.toml").write_text(text)
        cases.append(Case(name, "scenes", ("simulate", f"{{c}}/{name}.toml", "--out", "{out}",
                                            "--quiet", *extra), code, word, **kw))  # fmt: skip

    def run_ok(out: Path) -> None:
        """arc-frictionless: 2 mm steps over a 60 mm span = 31 advances, all reached."""
        run = json.loads((out / "run.json").read_text())
        assert run["status"] == 0 and len((out / "dwells.csv").read_text().splitlines()) == 32

    add("scene_ok", arc, 0, "reached all 31", check=run_ok)
    add("scene_arc_tighter_than_lumen", arc.replace("radius_mm = 13.0", "radius_mm = 1.0"), 2,
        "channel.curvature")  # fmt: skip
    helix = (SCENES / "helix-torsion.toml").read_text()
    add("scene_helix_pitch0", helix.replace("pitch_mm = 20.0", "pitch_mm = 0.0").replace(
        "angle_deg = 360.0", "angle_deg = 540.0"), 2, "channel.self_intersection")  # fmt: skip
    add("scene_helix_tight_pitch", helix.replace("pitch_mm = 20.0", "pitch_mm = 2.0").replace(
        "angle_deg = 360.0", "angle_deg = 720.0"), 2, "channel.self_intersection")  # fmt: skip
    add("scene_not_toml", "name = [unclosed\n", 2, "scene_not_toml.toml")
    add("scene_unknown_key", arc.replace("radius_mm = 13.0", "radius_mm = 13.0\nradious_mm = 2"),
        2, "radious_mm")  # fmt: skip
    add(
        "scene_negative_radius",
        arc.replace("radius_mm = 13.0", "radius_mm = -13.0"),
        2,
        "radius_mm",
    )
    add("scene_lumen_narrower_than_rod", arc.replace("r_b_mm = 1.5", "r_b_mm = 0.4").replace(
        "r_a_mm = 1.4", "r_a_mm = 0.3"), 2, "does not fit")  # fmt: skip
    add("scene_increment_1e-4", arc.replace("increment_mm = 0.5", "increment_mm = 1e-4"), 2,
        "steps")  # fmt: skip
    add("scene_missing_file", None, 2, "scene_missing_file.toml")
    add("scene_negative_step", arc.replace("step_mm = 2.0", "step_mm = -2.0"), 2, "step_mm")
    add("scene_nan_radius", arc.replace("radius_mm = 13.0", "radius_mm = nan"), 2, "radius_mm")
    (c / "scene_utf16.toml").write_bytes(arc.encode("utf-16"))
    add("scene_utf16", None, 0, "reached all 31", check=run_ok)
    (c / "scene_not_utf8.toml").write_bytes(arc.encode("utf-8") + b"# \xff\xfe\n")
    add("scene_not_utf8", None, 2, "not UTF-8")
    add("scene_deep_toml", "x = " + "[" * 50_000 + "]" * 50_000 + "\n", 2, "scene_deep_toml")
    return cases


def _config(c: Path) -> list[Case]:
    """Clinic configuration files (issue 25): missing, misplaced tables, encodings."""
    cases: list[Case] = []
    com = ("commission", "ring26x60", "--out", "{out}", "--quiet", "--no-pdf", *FAST_RING)

    def add(name, extra, code, word, **kw):
        cases.append(Case(name, "config", (*com, *extra), code, word, **kw))

    add("config_env_missing", [], 2, "RINGQA_CONFIG",
        env=(("RINGQA_CONFIG", str(c / "unmounted-share" / "site.toml")),))  # fmt: skip
    (c / "site_scene_tables.toml").write_text(
        "[solver]\nincrement_mm = 0.5\n[contact]\nmu_k = 0.3\nmu_s = 0.35\n"
    )
    add("config_scene_tables", ["--config", "{c}/site_scene_tables.toml"], 2, "[scene.solver]")
    (c / "site_contact_beside_plan.toml").write_text("[plan]\nstep_mm = 5\n[contact]\nmu_k = 0.3\n")
    add("config_contact_beside_plan", ["--config", "{c}/site_contact_beside_plan.toml"], 2,
        "[scene.contact]")  # fmt: skip
    (c / "site_dup.toml").write_text("[plan]\nprescription_gy = 7\nprescription_gy = 8\n")
    add("config_duplicate_key", ["--config", "{c}/site_dup.toml"], 2, "site_dup.toml")
    add("config_missing_file", ["--config", "{c}/no_such_site.toml"], 2, "no_such_site.toml")
    (c / "site_utf16.toml").write_bytes("[plan]\nprescription_gy = 7.5\n".encode("utf-16"))

    def prescription(out: Path) -> None:
        """The UTF-16 site file's plan.prescription_gy = 7.5 is in force, with its origin."""
        data = json.loads((out / "results.json").read_text())
        assert data["settings"]["prescription_gy"] == 7.5, data["settings"]
        assert data["settings_origin"]["plan.prescription_gy"].startswith("--config")

    add("config_utf16", ["--config", "{c}/site_utf16.toml"], 0, "centreline reference",
        check=prescription)  # fmt: skip
    return cases


def _export(c: Path) -> list[Case]:
    """``--export`` of the example plan (issue 25, issue 27 item 9)."""
    cases: list[Case] = []
    com = ("commission", "--out", "{out}", "--quiet", "--no-pdf", "--export", *FAST)

    def add(name, argv, code, word, **kw):
        cases.append(Case(name, "export", tuple(argv), code, word, **kw))

    def exported(out: Path) -> None:
        """results.json lists both export files with the SHA-256 of their bytes; the exported
        plan names ringqa as its maker (not Nucletron / OTP V4.3.0.410)."""
        import hashlib

        import pydicom

        data = json.loads((out / "results.json").read_text())
        names = [e["path"] for e in data["export"]]
        assert names == ["export/source_path_ring.csv", "export/RP_simulated.dcm"], names
        for e in data["export"]:
            assert hashlib.sha256((out / e["path"]).read_bytes()).hexdigest() == e["sha256"]
        ds = pydicom.dcmread(out / "export" / "RP_simulated.dcm")
        assert ds.Manufacturer == "ringqa" and str(ds.SoftwareVersions).startswith("ringqa ")

    add("export_ok", [*com, str(PLAN)], 0, "(measured reference)", check=exported)
    ds = _plan_ds()
    for cp in ds.ApplicationSetupSequence[0].ChannelSequence[0].BrachyControlPointSequence:
        cp.ControlPointRelativePosition = float(cp.ControlPointRelativePosition) + 2.5
    _save(ds, c / "plan_relative_shifted.dcm")
    add("export_relative_disagrees", [*com, "{c}/plan_relative_shifted.dcm"], 2,
        "disagrees with its 3D position")  # fmt: skip
    return cases


def _options(c: Path) -> list[Case]:
    cases: list[Case] = []
    com = ("commission", "ring26x60", "--out", "{out}", "--quiet", "--no-pdf")

    def add(name, extra, code, word, argv=com, **kw):
        cases.append(Case(name, "options", (*argv, *extra), code, word, **kw))

    add("opt_unknown_set_key", ["--set", "solver.incremnt_mm=0.5"], 2, "incremnt_mm")
    add("opt_set_not_number", ["--set", "solver.increment_mm=fast"], 2, "increment_mm")
    add("opt_set_no_equals", ["--set", "solver.increment_mm"], 2, "KEY=VALUE")
    add("opt_negative_step", ["--set", "motion.step_mm=-1"], 2, "step_mm")
    add("opt_increment_1e-4", ["--set", "solver.increment_mm=1e-4"], 2, "steps")
    add("opt_prescription_zero", ["--prescription-gy", "0"], 2, "prescription")
    add("opt_dose_action_negative", ["--dose-action-pct", "-1"], 2, "action")
    add("opt_sk_negative", ["--sk-u", "-5"], 2, "sk")
    add("opt_stem_negative", ["--stem-mm", "-5"], 2, "stem")
    add("opt_unknown_source", ["--source", "co60-unknown"], 2, "co60-unknown")
    add("opt_unknown_cable", ["--cable", "rope"], 2, "rope")
    add("opt_unknown_register", ["--register", "affine"], 2, "affine")
    add("opt_not_a_float", ["--prescription-gy", "seven"], 2, "invalid float")
    add("opt_no_input", [], 2, "no INPUT", argv=("commission", "--out", "{out}"))
    add("opt_unknown_applicator", [], 2, "ring99x99",
        argv=("commission", "ring99x99", "--out", "{out}"))  # fmt: skip
    add("opt_correction_in_batch", ["--all-shipped", "--centreline-correction", "x.csv"], 2,
        "give one applicator")  # fmt: skip
    add("opt_set_nested_deep", ["--set", "solver.tol=" + "[" * 50_000 + "]" * 50_000], 2,
        "solver.tol")  # fmt: skip
    (c / "accuracy_dup_column.csv").write_text("time_s,max_err_mm,status,time_s\n1,0.1,0,2\n")
    add("opt_accuracy_csv_dup_column", ["--accuracy-csv", "{c}/accuracy_dup_column.csv",
        *FAST_RING], 2, "column 'time_s' twice")  # fmt: skip

    def centreline_run(out: Path) -> None:
        """ring26x60 with the centreline reference: dwells every 5 mm (the plan step) from
        relative position 0, and the simulated source at relative position 0 inside the ring's
        lumen: in the ring plane (|z| < r_b = 1.5 mm) at 13 +- 1.5 mm from the ring's centre
        (the origin of the shipped rings' frame)."""
        import csv

        with open(out / "dwells.csv", newline="") as fh:
            rows = [r for r in csv.DictReader(fh) if r["path"] == "simulated"]
        rel = np.array([float(r["relative_position_mm"]) for r in rows])
        assert rel[0] == 0.0 and np.allclose(np.diff(rel), 5.0), rel
        x, y, z = (float(rows[0][k]) for k in ("x_mm", "y_mm", "z_mm"))
        assert abs(z) < 1.5 and abs(np.hypot(x, y) - 13.0) < 1.5, (x, y, z)

    add("opt_shipped_ok", [], 0, "centreline reference", check=centreline_run)
    return cases


def _output(c: Path) -> list[Case]:
    cases: list[Case] = []
    imp = ("import", str(PLAN), "--out")
    com = ("commission", "ring26x60", "--quiet", "--no-pdf", "--out")

    def add(name, argv, code, word, **kw):
        cases.append(Case(name, "output", tuple(argv), code, word, **kw))

    add("out_under_proc", [*imp, "/proc/ringqa-corpus/out"], 2, "cannot write")
    add("out_under_sys", [*imp, "/sys/ringqa-corpus/out"], 2, "cannot write")
    add("out_is_a_file", [*imp, "{out}"], 2, "{out}", setup="out_is_file")
    add("out_foreign_folder", [*imp, "{out}"], 2, "did not write", setup="foreign")
    add("out_is_the_input_folder", ["commission", "{out}", "--out", "{out}"], 2, "did not write",
        setup="input_folder")  # fmt: skip
    add("out_earlier_output_replaced", [*imp, "{out}"], 0, "7 files", setup="earlier")
    add("out_leftover_staging", [*imp, "{out}"], 0, "removed left-over staging", setup="staging")
    add("out_leftover_old_restored", [*imp, "{out}"], 0, "restored", setup="old_leftover")
    add("out_readonly_parent", [*imp, "{out}"], 2, "cannot write", setup="readonly")
    add("out_enospc_import", [*imp, "{out}"], 2, "No space left", setup="enospc")
    add("out_enospc_commission", [*com, "{out}"], 2, "No space left", setup="enospc")
    add("out_eacces_simulate", ["simulate", str(SCENES / "arc-frictionless.toml"), "--quiet",
        "--out", "{out}"], 2, "Permission denied", setup="eacces")  # fmt: skip
    add("out_parent_is_file", [*imp, "{out}/sub"], 2, "is a file", setup="out_is_file")
    # issue 25: files the physicist saved into an earlier output are never deleted
    add("out_earlier_with_user_file", [*imp, "{out}"], 2, "notes.txt", setup="earlier_user_file")
    add("out_earlier_report_signed", [*imp, "{out}"], 2, "changed since ringqa wrote it",
        setup="earlier_signed")  # fmt: skip
    add("out_file_saved_during_run", [*imp, "{out}"], 2, "appeared in it while the command ran",
        setup="saved_during")  # fmt: skip
    add("out_file_saved_during_rerun", [*imp, "{out}"], 2, "scan.tif",
        setup="saved_during_rerun")  # fmt: skip
    add("out_symlink", [*imp, "{out}"], 2, "symbolic link", setup="symlink")
    add("out_dot", [*imp, "."], 2, "current folder")
    add("out_name_too_long", [*imp, "{c}/" + "o" * 240], 2, "240 bytes long")
    add("out_log_inside", ["--log-file", "{out}/run.log", *imp, "{out}"], 2, "inside --out")
    add("out_log_dev_full", ["--log-file", "/dev/full", *imp, "{out}"], 2, "No space left")
    (c / "log_target.dcm").write_bytes(PLAN.read_bytes())
    add("out_log_is_the_input", ["--log-file", "{c}/log_target.dcm", "import",
        "{c}/log_target.dcm", "--out", "{out}"], 2, "also an input",
        setup="log_target")  # fmt: skip
    add("out_stdout_closed", [*imp, "{out}"], 0, "standard output could not be written",
        setup="stdout_epipe", check=_has_plan_json)  # fmt: skip

    def modes(out: Path) -> None:
        """umask 022: the folder 0755, its files (plan.json, the marker) 0644 (issue 27.7)."""
        assert out.stat().st_mode & 0o777 == 0o755
        for name in ("plan.json", ".ringqa-output.json", "dwells.csv"):
            assert (out / name).stat().st_mode & 0o777 == 0o644, name

    add("out_umask_022", [*imp, "{out}"], 0, "7 files", setup="umask022", check=modes)
    return cases


def _has_plan_json(out: Path) -> None:
    """The import finished: plan.json lists the example's two channels."""
    data = json.loads((out / "plan.json").read_text())
    assert [ch["number"] for ch in data["channels"]] == [1, 2]


def _signals(c: Path) -> list[Case]:
    cases: list[Case] = []
    imp = ("import", str(PLAN), "--out", "{out}")
    com = ("commission", "ring26x60", "--quiet", "--no-pdf", "--out", "{out}")
    sim = ("simulate", str(SCENES / "arc-frictionless.toml"), "--quiet", "--out", "{out}")

    def add(name, argv, code, word, **kw):
        cases.append(Case(name, "signals", tuple(argv), code, word, **kw))

    add("sig_term_import", imp, 143, "interrupted by SIGTERM", setup="sigterm")
    add("sig_int_import", imp, 130, "interrupted by SIGINT", setup="sigint")
    add("sig_term_commission", com, 143, "interrupted by SIGTERM", setup="sigterm")
    add("sig_int_simulate", sim, 130, "interrupted by SIGINT", setup="sigint")
    add("sig_term_keeps_earlier", imp, 143, "nothing written", setup="sigterm_earlier")
    add("sig_killed_run_leftover", com, 0, "removed left-over staging", setup="staging")
    add("sig_hup_import", imp, 129, "interrupted by SIGHUP", setup="sighup")
    return cases


def build(folder: str | Path) -> list[Case]:
    """Write the corpus inputs into ``folder`` (created) and return the cases."""
    c = Path(folder)
    c.mkdir(parents=True, exist_ok=True)
    cases = [*_plans(c), *_libraries(c), *_folders(c), *_scenes(c), *_options(c), *_config(c),
             *_output(c), *_signals(c), *_export(c)]  # fmt: skip
    names = [k.name for k in cases]
    assert len(set(names)) == len(names), "case names must be unique"
    assert all(k.category in CATEGORIES for k in cases)
    return cases


def main(argv: list[str] | None = None) -> int:
    """Write the corpus into the folder named on the command line and list the cases."""
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python tests/corpus/make_corpus.py DIR", file=sys.stderr)
        return 2
    cases = build(args[0])
    for k in cases:
        print(f"{k.category:10s} {k.name:32s} exit {k.exit_code:3d}  {k.outcome}")
    print(f"{len(cases)} cases in {args[0]}")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(REPO))
    sys.exit(main())


__all__ = ["CATEGORIES", "Case", "build"]
