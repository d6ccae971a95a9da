"""Fixtures for the importer tests: synthetic brachytherapy RT Plans written with pydicom.

``rtplan_factory(channels=..., ...)`` writes a small, valid HDR RT Plan to a temporary folder and
returns its path; keyword arguments change one thing at a time (modality, treatment type, source,
dose points, orientations, a hook to edit the dataset before saving). No real patient data.

Channel specs are dicts: ``{"number": 1, "dwells": [(rel_mm, (x, y, z), time_s), ...]}`` with
optional ``"weights"`` (explicit CumulativeTimeWeight per control point, overriding the paired
cumulative weights the factory computes from the times), ``"positions"`` / ``"rel"`` per control
point (when ``"weights"`` is given), ``"total_time_s"``, ``"final_weight"``, ``"orient"`` (one
(3,) vector per dwell), ``"weight_scale"`` (weights = times x scale, e.g. PDR weights that are not
seconds).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pydicom.dataset import Dataset, FileDataset, FileMetaDataset
from pydicom.uid import ExplicitVRLittleEndian, generate_uid

RT_PLAN = "1.2.840.10008.5.1.4.1.1.481.5"

#: Two channels: a 3-dwell "ring" channel and a 2-dwell "tandem", times in s.
DEFAULT_CHANNELS = (
    {
        "number": 1,
        "dwells": [
            (0.0, (10.0, 0.0, -100.0), 10.0),
            (5.0, (8.0, 5.0, -100.0), 20.0),
            (10.0, (4.0, 8.0, -100.0), 30.0),
        ],
    },
    {
        "number": 2,
        "dwells": [(0.0, (0.0, 0.0, -60.0), 15.0), (10.0, (0.0, 0.0, -70.0), 5.0)],
    },
)
DEFAULT_POINTS = (("A1", (-20.0, 0.0, -80.0), 7.0), ("A2", (20.0, 0.0, -80.0), 7.1))


def _channel_item(spec: dict, orientation: bool) -> Dataset:
    ch = Dataset()
    ch.ChannelNumber = spec["number"]
    ch.ChannelLength = spec.get("length_mm", 1500.0)
    ch.SourceMovementType = "STEPWISE"
    ch.SourceApplicatorStepSize = spec.get("step_mm", 2.5)
    ch.SourceApplicatorID = str(spec["number"])
    ch.ReferencedSourceNumber = 0
    dwells = spec["dwells"]
    times = np.array([t for _, _, t in dwells], dtype=float)
    scale = spec.get("weight_scale", 1.0)
    cps = []
    if "weights" in spec:
        weights = spec["weights"]
        rels = spec["rel"]
        positions = spec["positions"]
    else:
        weights, rels, positions = [], [], []
        cum = 0.0
        for rel, xyz, t in dwells:
            weights += [cum, cum + t * scale]
            cum += t * scale
            rels += [rel, rel]
            positions += [xyz, xyz]
    orient_per_dwell = spec.get("orient")
    dwell_of_cp = []
    k = -1
    for j in range(len(weights)):
        if j == 0 or (rels[j], tuple(positions[j])) != (rels[j - 1], tuple(positions[j - 1])):
            k += 1
        dwell_of_cp.append(k)
    for j, (w, rel, xyz) in enumerate(zip(weights, rels, positions, strict=True)):
        cp = Dataset()
        cp.ControlPointIndex = j
        if rel is not None:
            cp.ControlPointRelativePosition = rel
        if xyz is not None:
            cp.ControlPoint3DPosition = list(xyz)
        if w is not None:
            cp.CumulativeTimeWeight = w
        if orientation and orient_per_dwell is not None:
            cp.ControlPointOrientation = list(orient_per_dwell[dwell_of_cp[j]])
        cps.append(cp)
    ch.NumberOfControlPoints = len(cps)
    ch.BrachyControlPointSequence = cps
    ch.ChannelTotalTime = spec.get("total_time_s", float(times.sum()))
    final = spec.get("final_weight", float(times.sum() * scale))
    if final is not None:
        ch.FinalCumulativeTimeWeight = final
    return ch


@pytest.fixture
def rtplan_factory(tmp_path: Path):
    """Return ``make(**options) -> Path`` writing a synthetic brachytherapy RT Plan."""
    counter = {"n": 0}

    def make(
        channels=DEFAULT_CHANNELS,
        *,
        modality: str = "RTPLAN",
        sop_class: str = RT_PLAN,
        treatment_type: str | None = "HDR",
        brachy: bool = True,
        sk_U: float | None = 40000.0,
        isotope: str = "Ir-192",
        source_manufacturer: str | None = "Nucletron",
        source_model: str | None = "mHDR-v2",
        reference_date: str | None = "20240101",
        points=DEFAULT_POINTS,
        orientation: bool = False,
        edit=None,
        name: str | None = None,
    ) -> Path:
        counter["n"] += 1
        path = tmp_path / (name or f"RP_synthetic_{counter['n']}.dcm")
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = sop_class
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds = FileDataset(str(path), {}, file_meta=meta, preamble=b"\0" * 128)
        ds.SOPClassUID = sop_class
        ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
        ds.Modality = modality
        ds.PatientName = "SYNTHETIC^PLAN"
        ds.RTPlanLabel = "synthetic"
        if brachy:
            if treatment_type is not None:
                ds.BrachyTreatmentType = treatment_type
            ds.BrachyTreatmentTechnique = "INTRACAVITARY"
            src = Dataset()
            src.SourceNumber = 0
            src.SourceIsotopeName = isotope
            src.SourceStrengthUnits = "AIR_KERMA_RATE"
            if sk_U is not None:
                src.ReferenceAirKermaRate = sk_U
            if reference_date is not None:
                src.SourceStrengthReferenceDate = reference_date
            if source_manufacturer is not None:
                src.SourceManufacturer = source_manufacturer
            if source_model is not None:
                src.SourceModelID = source_model
            ds.SourceSequence = [src]
            setup = Dataset()
            setup.ApplicationSetupNumber = 1
            setup.ApplicationSetupType = "CERVICAL"
            setup.ChannelSequence = [_channel_item(c, orientation) for c in channels]
            ds.ApplicationSetupSequence = [setup]
        if points is not None:
            refs = []
            for k, (pname, xyz, dose) in enumerate(points):
                r = Dataset()
                r.DoseReferenceNumber = k + 1
                r.DoseReferenceStructureType = "COORDINATES"
                r.DoseReferenceDescription = pname
                r.DoseReferencePointCoordinates = list(xyz)
                r.DoseReferenceType = "UNSPECIFIED"
                if dose is not None:
                    r.TargetPrescriptionDose = dose
                refs.append(r)
            ds.DoseReferenceSequence = refs
        if edit is not None:
            edit(ds)
        ds.save_as(path, enforce_file_format=True)
        return path

    return make
