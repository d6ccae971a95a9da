"""What one commissioning run returns: every part typed, as the report and ``results.json`` read it.

:class:`CommissioningResult` holds the tables, the :class:`Verdict` s, the notes and typed parts:
the ring :class:`RingGeometry`, the :class:`SimulationInfo` of the engine run, the
:class:`RunSettings` used, the :class:`Summary` (one row of ``summary.csv``) and the
:class:`Timings`. Each part's ``as_dict()`` is its ``results.json`` section (stable keys, in the
order other tools have always read).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from ringqa.pipeline.settings import results_keys
from ringqa.plan import DosePointSpec
from ringqa.provenance import Provenance


@dataclass(frozen=True)
class Verdict:
    """One tolerance check, shown in the report.

    Attributes
    ----------
    check : str
        What is compared (``"position: simulated vs measured"``).
    value : float
        The checked value (max distance in mm, or max |dose difference| in %).
    unit : str
        ``"mm"`` or ``"%"``.
    limits : tuple of float
        (recommended, required) for positions; (action level,) for doses.
    status : str
        ``"PASS"``, ``"WARN"`` (within the required 2 mm but above the recommended 1 mm),
        ``"FAIL"`` (position beyond 2 mm) or ``"ACTION"`` (dose beyond the action level).
    text : str
        One sentence for the report.
    role : str
        What kind of finding: ``"TPS model"`` (centreline vs reference), ``"simulation check"``
        (simulated vs reference) or ``"numerics"`` (the simulation's numerical error).
    """

    check: str
    value: float
    unit: str
    limits: tuple[float, ...]
    status: str
    text: str
    role: str = ""

    def as_dict(self) -> dict:
        """The ``results.json`` entry."""
        return {
            "check": self.check,
            "value": float(self.value),
            "unit": self.unit,
            "limits": [float(x) for x in self.limits],
            "status": self.status,
            "text": self.text,
            "role": self.role,
        }


@dataclass(frozen=True, eq=False)
class RingGeometry:
    """The applicator frame (``ring_*``: results.json's names) and the channels' centrelines,
    for the report's plots (mm).

    Attributes
    ----------
    ring_centre_mm : (3,) ndarray
        Centre of the ring channel's circle.
    ring_normal : (3,) ndarray
        Unit ring-plane normal, cranial.
    ring_lateral : (3,) ndarray
        Unit in-plane vector towards the patient's left.
    ring_radius_mm : float
        Radius of the ring channel's centreline circle.
    s_ref_mm : float
        Arc length of the ring channel's relative position 0.
    centrelines_mm : dict of str to (k, 3) ndarray
        Every channel's centreline, sampled every 0.5 mm (not in ``results.json``).
    metadata : dict
        The applicator's metadata.
    """

    ring_centre_mm: np.ndarray
    ring_normal: np.ndarray
    ring_lateral: np.ndarray
    ring_radius_mm: float
    s_ref_mm: float
    centrelines_mm: dict[str, np.ndarray]
    metadata: dict[str, Any]

    def as_dict(self) -> dict:
        """The ``results.json`` ``geometry`` section (without the centrelines)."""
        return {
            "ring_centre_mm": self.ring_centre_mm.tolist(),
            "ring_normal": self.ring_normal.tolist(),
            "ring_lateral": self.ring_lateral.tolist(),
            "ring_radius_mm": self.ring_radius_mm,
            "s_ref_mm": self.s_ref_mm,
            "metadata": self.metadata,
        }


@dataclass(frozen=True, eq=False)
class SimulationInfo:
    """How the engine run went.

    Attributes
    ----------
    status : int
        0 success (a failed or jammed run raises before a result exists).
    message : str
        The engine's message.
    warnings : tuple of str
        The engine's warnings.
    solve_time_s : float
        The engine's solve time (JIT compilation excluded), s.
    wall_time_s : float
        Wall time of the run(s), retries included, s.
    n_elements : int
        Cable elements simulated.
    settings : dict
        The engine's own account of its settings (SI).
    """

    status: int
    message: str
    warnings: tuple[str, ...]
    solve_time_s: float
    wall_time_s: float
    n_elements: int
    settings: dict[str, Any]

    def as_dict(self) -> dict:
        """The ``results.json`` ``simulation`` section."""
        return {
            "status": self.status,
            "message": self.message,
            "warnings": list(self.warnings),
            "solve_time_s": self.solve_time_s,
            "wall_time_s": self.wall_time_s,
            "n_elements": self.n_elements,
            "settings": self.settings,
        }


#: The order of results.json ``settings`` as readers have always seen it (the keys themselves
#: come from the settings table: :func:`ringqa.pipeline.settings.results_keys`; a key the table
#: no longer records is not written, a new one goes after these).
SETTINGS_KEY_ORDER = (
    "source", "sk_U", "prescription_gy", "cable", "channel", "plan_step_mm", "tandem_dwells",
    "position_limits_mm", "dose_action_pct", "dose_points", "scene_overrides", "scene",
    "register", "stem_mm", "centreline_correction",
)  # fmt: skip


@dataclass(frozen=True, eq=False)
class RunSettings:
    """The settings a run used (resolved: the source by name, S_K as a number).

    Attributes
    ----------
    source : str
        TG-43 source name.
    sk_U : float
        Air-kerma strength, U.
    prescription_gy : float
        Mean Point A dose of the standard plan, Gy.
    cable : str
        Instrument preset simulated.
    channel : str
        The channel simulated.
    register : str
        Registration mode of the reference path.
    stem_mm : float or None
        Straight channel simulated before the first bend, mm (None: the whole channel).
    plan_step_mm : float
        Dwell spacing of the standard plan, mm.
    tandem_dwells : int
        Tandem dwells of the standard plan (without a measured tandem path).
    position_limits_mm : (float, float)
        Recommended and required position tolerance, mm.
    dose_action_pct : float
        Dose-difference action level, %.
    dose_points : DosePointSpec
        Where the standard dose points are.
    scene_overrides : dict
        The ``--set`` overrides (dotted keys, user units).
    scene : dict
        The simulated scene in user units (empty if it could not be written).
    centreline_correction : str or None
        The centreline correction file spliced over the channel, if any.
    calibration : dict or None
        The cable calibration file whose values the scene uses (``file``, ``sha256``,
        ``command``, ...; :attr:`CommissionSettings.calibration`); in ``as_dict`` only when
        there is one.
    cross_check : bool or None
        Whether the flexible-element cross-check was asked for (``simulation.cross_check``;
        None: not recorded). Not in ``as_dict``: results.json records its outcome
        (``numerical_check.cross_check``).
    """

    source: str
    sk_U: float
    prescription_gy: float
    cable: str
    channel: str
    register: str
    stem_mm: float | None
    plan_step_mm: float
    tandem_dwells: int
    position_limits_mm: tuple[float, float]
    dose_action_pct: float
    dose_points: DosePointSpec
    scene_overrides: dict[str, Any]
    scene: dict[str, Any]
    centreline_correction: str | None = None
    calibration: dict[str, Any] | None = None
    cross_check: bool | None = None

    def as_dict(self) -> dict:
        """The ``results.json`` ``settings`` section (also the provenance's settings): every
        setting the settings table records there (:func:`ringqa.pipeline.settings.results_keys`,
        each under its results.json key, which is this object's attribute), then the simulated
        ``scene`` and, when one is used, the ``calibration`` file."""
        values = {key: _recorded(getattr(self, key)) for key in results_keys()}
        values["scene"] = self.scene
        out = {key: values.pop(key) for key in SETTINGS_KEY_ORDER if key in values}
        out.update(values)  # a setting newer than the order below: after the others
        if self.calibration is not None:
            out["calibration"] = dict(self.calibration)
        return out


def _recorded(value):
    """A setting's value as results.json records it: a pair as a list, a spec as its dict."""
    if hasattr(value, "as_dict"):
        return value.as_dict()
    if isinstance(value, tuple):
        return list(value)
    if isinstance(value, dict):
        return dict(value)
    return value


@dataclass(frozen=True)
class PathNumbers:
    """The summary numbers of one compared path (simulated or centreline) against the reference.

    Attributes
    ----------
    median_dist_mm, max_dist_mm : float
        Median and largest 3D distance, mm.
    max_along_mm, max_radial_mm, max_out_of_plane_mm : float
        Largest |component| of the distance, mm (NaN without dwells).
    max_angle_deg : float
        Largest angle between the source directions, deg.
    """

    median_dist_mm: float
    max_dist_mm: float
    max_along_mm: float
    max_radial_mm: float
    max_out_of_plane_mm: float
    max_angle_deg: float

    def columns(self, tag: str) -> dict[str, float]:
        """The ``summary.csv`` columns of this path (``median_dist_<tag>_mm``, ...)."""
        return {
            f"median_dist_{tag}_mm": self.median_dist_mm,
            f"max_dist_{tag}_mm": self.max_dist_mm,
            f"max_along_{tag}_mm": self.max_along_mm,
            f"max_radial_{tag}_mm": self.max_radial_mm,
            f"max_out_of_plane_{tag}_mm": self.max_out_of_plane_mm,
            f"max_angle_{tag}_deg": self.max_angle_deg,
        }


@dataclass(frozen=True, eq=False)
class Summary:
    """The per-applicator numbers: one row of ``summary.csv`` (:meth:`as_row`).

    Attributes
    ----------
    applicator, reference, source : str
        Applicator name, ``"measured"`` or ``"centreline"``, TG-43 source name.
    n_dwells : int
        Reference dwells.
    n_plan_dwells_ring, n_plan_dwells_tandem : int
        Ring and tandem dwells of the standard plan.
    s_ref_mm : float
        Arc length of the ring channel's relative position 0, mm.
    simulated : PathNumbers
        Simulated path vs reference.
    max_angle_sim_vs_centreline_deg : float
        Largest angle between simulated and centreline source directions, deg.
    centreline : PathNumbers or None
        Centreline path vs the measured reference (None when the centreline is the reference).
    max_abs_diff_pct : dict of str to dict of str to float
        Plan (``simulated``, ``centreline``) -> point kind (``point_a``, ``surface``,
        ``depth5``) -> largest |dose difference| to the reference plan, %.
    point_a_mean_gy : float
        Mean Point A dose of the reference plan, Gy.
    simulation_status : int
        The engine's status.
    solve_time_s : float
        The engine's solve time, s (both runs of the numerical check).
    verdict : str
        ``"PASS"``, ``"WARN"`` or ``"FAIL"`` (any FAIL or ACTION).
    registration : str
        Registration mode of the reference path (``none``, ``plane-height``, ``rigid``).
    n_reference_infeasible : int
        Reference positions (as compared, i.e. registered) that cannot lie in the lumen.
    n_reference_infeasible_raw : int
        The same for the path as supplied.
    n_reference_outside : int
        Reference positions not along the channel (left out of the checks).
    simulated_registered, centreline_registered : PathNumbers or None
        As ``simulated`` / ``centreline``, against the registered reference (equal to them with
        registration ``none``).
    max_abs_diff_registered_pct : dict
        As ``max_abs_diff_pct``, against the same times on the registered reference path.
    max_numerical_error_mm, median_numerical_error_mm : float
        The simulation's numerical error over the dwells, mm.
    median_radial : dict of str to float
        Path (``reference``, ``sim``, ``centreline``) -> median signed in-plane radial offset
        from the channel centreline on the ring's circle, mm (outward positive).
    median_height : dict of str to float
        The same for the height above the centreline (cranial positive), mm.
    """

    applicator: str
    reference: str
    source: str
    n_dwells: int
    n_plan_dwells_ring: int
    n_plan_dwells_tandem: int
    s_ref_mm: float
    simulated: PathNumbers
    max_angle_sim_vs_centreline_deg: float
    centreline: PathNumbers | None
    max_abs_diff_pct: dict[str, dict[str, float]]
    point_a_mean_gy: float
    simulation_status: int
    solve_time_s: float
    verdict: str
    registration: str = "none"
    n_reference_infeasible: int = 0
    n_reference_infeasible_raw: int = 0
    n_reference_outside: int = 0
    simulated_registered: PathNumbers | None = None
    centreline_registered: PathNumbers | None = None
    max_abs_diff_registered_pct: dict[str, dict[str, float]] | None = None
    max_numerical_error_mm: float = 0.0
    median_numerical_error_mm: float = 0.0
    median_radial: dict[str, float] | None = None
    median_height: dict[str, float] | None = None

    def as_row(self) -> dict[str, Any]:
        """Column -> value of ``summary.csv`` (and ``results.json``'s ``summary``), in order."""
        row: dict[str, Any] = {
            "applicator": self.applicator,
            "reference": self.reference,
            "source": self.source,
            "n_dwells": self.n_dwells,
            "n_plan_dwells_ring": self.n_plan_dwells_ring,
            "n_plan_dwells_tandem": self.n_plan_dwells_tandem,
            "s_ref_mm": self.s_ref_mm,
            **self.simulated.columns("sim"),
            "max_angle_sim_vs_centreline_deg": self.max_angle_sim_vs_centreline_deg,
        }
        if self.centreline is not None:
            row.update(self.centreline.columns("centreline"))
        for plan, per_kind in self.max_abs_diff_pct.items():
            for kind, value in per_kind.items():
                row[f"max_abs_diff_{kind}_{plan}_pct"] = value
        row["point_a_mean_gy"] = self.point_a_mean_gy
        row["simulation_status"] = self.simulation_status
        row["solve_time_s"] = self.solve_time_s
        row["verdict"] = self.verdict
        row["registration"] = self.registration
        row["n_reference_infeasible"] = self.n_reference_infeasible
        row["n_reference_infeasible_raw"] = self.n_reference_infeasible_raw
        row["n_reference_outside"] = self.n_reference_outside
        for tag, numbers in (("sim", self.simulated_registered),
                             ("centreline", self.centreline_registered)):  # fmt: skip
            if numbers is not None:
                row.update(numbers.columns(f"{tag}_registered"))
        for plan, per_kind in (self.max_abs_diff_registered_pct or {}).items():
            for kind, value in per_kind.items():
                row[f"max_abs_diff_{kind}_{plan}_registered_pct"] = value
        row["max_numerical_error_mm"] = self.max_numerical_error_mm
        row["median_numerical_error_mm"] = self.median_numerical_error_mm
        for tag, value in (self.median_radial or {}).items():
            row[f"median_radial_{tag}_mm"] = value
        for tag, value in (self.median_height or {}).items():
            row[f"median_height_{tag}_mm"] = value
        return row


@dataclass(frozen=True)
class Timings:
    """Wall times of the run's steps, s.

    Attributes
    ----------
    load_s : float
        Reading the input.
    simulation_s : float
        The engine run(s).
    dose_s : float
        Dose points, plans and dose tables.
    total_s : float
        The whole run.
    """

    load_s: float
    simulation_s: float
    dose_s: float
    total_s: float

    def as_dict(self) -> dict[str, float]:
        """The ``results.json`` ``timings_s`` section."""
        return {
            "load_s": self.load_s,
            "simulation_s": self.simulation_s,
            "dose_s": self.dose_s,
            "total_s": self.total_s,
        }


#: named input checks that are notes (the file was read correctly; shown, not alarming)
NOTE_CHECKS = ("csv.encoding",)

#: The report's writers of a result, by kind (``"pdf"``: ``writer(result, path, fields=,
#: notes=, accuracy=, sections=)``; ``"html"``: ``writer(result, path)``; ``"figure.positions"``,
#: ``"figure.deviations"``, ``"figure.doses"``: ``draw(result, title)`` -> a matplotlib Figure,
#: the ``plot_*`` methods). The pipeline names
#: this seam and the report layer fills it when imported (:mod:`ringqa.report` registers its
#: writers), so the data still flows one way and no module is looked up by its name.
REPORT_WRITERS: dict[str, Any] = {}


def register_report_writer(kind: str, writer) -> None:
    """Register the report layer's writer of ``kind`` (``"pdf"``, ``"html"``) in
    :data:`REPORT_WRITERS` (replacing an earlier one)."""
    REPORT_WRITERS[str(kind)] = writer


def report_writer(kind: str):
    """The registered writer of ``kind``.

    Raises
    ------
    RingQAError
        None registered: ``ringqa.report`` has not been imported (the message says so).
    """
    writer = REPORT_WRITERS.get(kind)
    if writer is None:
        from ringqa.errors import RingQAError

        direct = "" if kind.startswith("figure.") else f", or call ringqa.report.write_{kind}" \
            "(result, path)"  # fmt: skip
        raise RingQAError(
            f"no {kind} report writer registered: import ringqa.report first (it registers its "
            f"writers){direct}"
        )
    return writer


@dataclass(frozen=True, eq=False)
class CommissioningResult:
    """Everything one commissioning run produced (tables in mm, deg, Gy, %).

    Attributes
    ----------
    applicator : str
        Applicator name.
    input : str
        What the user gave (name or path).
    input_kind : str
        ``shipped``, ``file``, ``folder``, ``rtplan`` or ``object``.
    reference : str
        ``"measured"`` (a measured source path) or ``"centreline"`` (none shipped: the comparison
        is simulated vs centreline).
    dwells : pandas.DataFrame
        One row per dwell and path (``measured``, ``registered`` when registration moved it,
        ``simulated``, ``centreline``): columns ``applicator, dwell, relative_position_mm, path,
        x_mm, y_mm, z_mm, dir_x, dir_y, dir_z, dist_to_measured_mm`` (to the path as supplied),
        ``dist_to_reference_mm`` (to the reference as compared, i.e. registered),
        ``along_mm, radial_mm, out_of_plane_mm`` (its components), ``angle_deg, in_plan,
        radial_from_centreline_mm`` (signed in-plane offset from the channel centreline, outward
        positive), ``height_mm`` (above the centreline along the ring normal),
        ``numerical_error_mm`` (the simulation's; 0 on the other paths) and ``reference_flag``
        (``""``, ``infeasible``, ``outside_channel``).
    doses : pandas.DataFrame
        One row per dose point and plan: ``applicator, point, kind, plan, dose_gy, diff_pct``
        (vs the standard plan on the reference path as supplied), ``diff_registered_pct`` (vs
        the same times on the registered path), ``x_mm, y_mm, z_mm, tps_dose_gy``.
    plan_dwells : pandas.DataFrame
        The three standard plans' dwells with their (equal) times.
    summary : Summary
        Per-applicator numbers (one row of summary.csv).
    verdicts : tuple of Verdict
    geometry : RingGeometry
        The applicator frame and centrelines, for the plots.
    simulation : SimulationInfo
        How the engine run went.
    settings : RunSettings
        Source, S_K, prescription, cable, tolerances, dose point definitions, scene settings.
    notes : tuple of str
        Statements the report must show (reference used, cable vs afterloader, ...).
    provenance : Provenance
    timings : Timings
    reference_check : ReferenceReview
        The reference path's checks and registration (report page 1).
    numerics : NumericalCheck
        The simulation's numerical error (commissioning vs refined run).
    conclusion : str
        One line: what the verdicts mean together.
    settings_origin : dict of str to str
        Where each setting came from (configuration key -> ``"default"``, ``"user config
        <path>"``, ``"--config <path>"`` or ``"command line"``; :mod:`ringqa.config`).
    warnings : tuple of str
        Named warnings of the input checks (``"[name] message"``,
        :func:`ringqa.errors.named_warning`): printed by the command line, in results.json
        ``warnings`` and first in the notes (report page 1).
    channel : str
        The channel commissioned, as the CSV tables' ``channel`` column names it: the plan's
        channel number, or the channel's name for file inputs (``""``: ``settings.channel``).
    measured_points : dict or None
        A measured path that is a subset (:mod:`ringqa.pipeline.measured_points`): which path
        the standard plan was built on and each measured position with its distance, sd and
        status (results.json ``measured_points``); None for a dense reference.
    family : str
        The channel's applicator family (:mod:`ringqa.geometry.families`: its report words).
    frame_family : str
        The applicator's family, whose frame the positions are projected in (its words name
        the frame's plane and axis: a ring applicator's tandem is shown in the ring plane).
    """

    applicator: str
    input: str
    input_kind: str
    reference: str
    dwells: pd.DataFrame
    doses: pd.DataFrame
    plan_dwells: pd.DataFrame
    summary: Summary
    verdicts: tuple[Verdict, ...]
    geometry: RingGeometry
    simulation: SimulationInfo
    settings: RunSettings
    notes: tuple[str, ...]
    provenance: Provenance
    timings: Timings
    reference_check: Any = None
    numerics: Any = None
    conclusion: str = ""
    settings_origin: dict[str, str] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    channel: str = ""
    measured_points: dict | None = None
    family: str = "ring"
    frame_family: str = "ring"

    def warning_records(self) -> list[dict]:
        """The results.json ``warnings``: ``name``, ``severity`` (``note`` for
        :data:`NOTE_CHECKS`, else ``warning``) and ``message`` of each."""
        from ringqa.errors import split_warning

        out = []
        for w in self.warnings:
            name, message = split_warning(w)
            severity = "note" if name in NOTE_CHECKS else "warning"
            out.append({"name": name, "severity": severity, "message": message})
        return out

    @property
    def input_label(self) -> str:
        """The input as outputs name it: ``ringqa:data/...`` for a shipped file (never an
        install path), else as the user gave it (:func:`ringqa.provenance.display_path`)."""
        from ringqa.provenance import display_path

        if self.input_kind in ("shipped", "object"):
            return self.input
        return display_path(self.input)

    def summary_row(self) -> dict[str, Any]:
        """The ``summary.csv`` row: :meth:`Summary.as_row` and the ``input`` (two inputs of the
        same model are told apart by it)."""
        return {**self.summary.as_row(), "input": self.input_label}

    def compared_dwells(self, path: str) -> pd.DataFrame:
        """The rows of ``dwells`` of one path that the verdicts judge (reference positions
        outside the channel left out); ``dist_to_reference_mm`` is then the distance judged."""
        d = self.dwells[self.dwells["path"] == path]
        if "reference_flag" in d:
            d = d[d["reference_flag"].astype(str) != "outside_channel"]
        return d

    @property
    def passed(self) -> bool:
        """True when no verdict is FAIL or ACTION."""
        return all(v.status in ("PASS", "WARN") for v in self.verdicts)

    # -- notebook conventions (pylinac-like): tables, figures, the signed PDF ----------------

    def to_frames(self) -> dict[str, pd.DataFrame]:
        """The run's tables as pandas DataFrames (copies; units in the column names).

        Returns
        -------
        dict of str to pandas.DataFrame
            ``dwells`` (one row per dwell and path), ``doses`` (per dose point and plan),
            ``plan_dwells`` (the standard plans' dwells and times), ``summary`` (one row, the
            columns of summary.csv), ``verdicts`` (one row per verdict: ``check, value, unit,
            status, role, text``) and ``notes`` (one column ``note``).
        """
        return {
            "dwells": self.dwells.copy(),
            "doses": self.doses.copy(),
            "plan_dwells": self.plan_dwells.copy(),
            "summary": pd.DataFrame([self.summary.as_row()]),
            "verdicts": pd.DataFrame(
                [
                    {
                        "check": v.check,
                        "value": v.value,
                        "unit": v.unit,
                        "status": v.status,
                        "role": v.role,
                        "text": v.text,
                    }
                    for v in self.verdicts
                ],
                columns=["check", "value", "unit", "status", "role", "text"],
            ),
            "notes": pd.DataFrame({"note": list(self.notes)}),
        }

    def plot_positions(self, title: str | None = None):
        """Dwell positions in the ring plane and orthogonal to it (the paper's Figure 6).

        Returns a :class:`matplotlib.figure.Figure` (no pyplot, the backend is left alone);
        ``title`` defaults to the applicator's name.
        """
        return report_writer("figure.positions")(self, self.applicator if title is None else title)

    def plot_deviations(self, title: str | None = None):
        """Deviation per dwell (3D distance, components in mm, angle in deg) as a
        :class:`matplotlib.figure.Figure` (no pyplot)."""
        return report_writer("figure.deviations")(self, self.applicator if title is None else title)

    def plot_doses(self, title: str | None = None):
        """The dose points beside the standard plan's dwells (ring plane, orthogonal view) as
        a :class:`matplotlib.figure.Figure` (no pyplot); the doses are in ``to_frames()``."""
        return report_writer("figure.doses")(self, self.applicator if title is None else title)

    def publish_pdf(self, path, fields=None, notes=None, *, accuracy=None, sections=()):
        """Write the signed report PDF of this result (as ``ringqa commission`` does).

        Parameters
        ----------
        path : str or pathlib.Path
            The PDF to write.
        fields : ringqa.report.ReportFields, optional
            Institution, physicist, serial, afterloader, source calibration (blank lines to fill
            by hand when not given).
        notes : str or sequence of str, optional
            Free notes printed above the signature block.
        accuracy : pandas.DataFrame, optional
            ``ringqa accuracy``'s table for an extra page.
        sections : sequence of callables, optional
            Extra pages, see :func:`ringqa.report.pdf.write_pdf`.

        Returns
        -------
        pathlib.Path
        """
        # The report layer sits after the pipeline (DEVELOPERS.md): it registers its writer in
        # REPORT_WRITERS when imported (ringqa.report), so the data still flows one way.
        writer = report_writer("pdf")
        return writer(
            self, path, fields=fields, notes=notes or (), accuracy=accuracy, sections=sections
        )

    def publish_html(self, path):
        """Write ``report.html`` of this result (the 3D view, verdicts and dose table; as
        ``ringqa commission`` does beside report.pdf; :mod:`ringqa.report.html`).

        Parameters
        ----------
        path : str or pathlib.Path

        Returns
        -------
        pathlib.Path
        """
        return report_writer("html")(self, path)
