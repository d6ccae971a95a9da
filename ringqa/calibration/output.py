"""The files of ``ringqa calibrate`` (contract, issue 26), written into a staging folder.

- ``calibration.json``: fitted values, standard errors, correlation matrix, ``identifiable`` per
  key (and the rule), residual median / max before and after (mm), number of points, the
  leave-one-out predictions, the inputs with their SHA-256, the settings;
- ``calibrated_cable.toml``: a configuration file (``[simulation] cable`` and ``[scene]`` with
  the identifiable fitted keys, and ``[calibration]``: the command, the date and the SHA-256 of
  calibration.json, which ``ringqa commission --config`` names in its report with the file's own
  SHA-256) that ``ringqa commission --config`` reads; its first lines give the same values as
  ``--set`` arguments for ``ringqa simulate``;
- ``residuals.csv``: ``applicator, point, relative_position_mm, measured_x_mm, measured_y_mm,
  measured_z_mm, simulated_before_x_mm, ..., simulated_after_z_mm, residual_before_mm,
  residual_after_mm, sd_mm`` and ``flag`` (empty, or why the point was left out of the fit);
- ``calibration.png``: measured vs simulated before/after, and the residuals;
- ``calibration.pdf``: the same on signed pages with the report's header, footer and fields;

and beside them ``calibration_sweep.toml``: a sweep spec (docs/sweeps.md) that varies the
identifiable fitted keys as one multivariate normal (means the fitted values, sds their standard
errors, and with two or more keys the fit's correlation matrix in its ``[correlation]`` table),
the other fitted values held, so that ``ringqa commission INPUT --config calibrated_cable.toml
--sweep calibration_sweep.toml`` propagates the fit's uncertainty, correlations kept, to every
dwell with the existing sweep machinery.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from ringqa.calibration.fit import MAX_DELTA_SE_MM, MAX_RELATIVE_SE, RCOND
from ringqa.calibration.model import applicator_of, base_key
from ringqa.calibration.run import Calibration
from ringqa.jsonio import csv_encoding, write_json
from ringqa.provenance import Provenance, sha256_of

__all__ = [
    "FILES",
    "cable_toml",
    "calibration_dict",
    "residual_rows",
    "write_outputs",
]

#: The files written (contract), and the sweep spec of the fitted uncertainty.
FILES = (
    "calibration.json",
    "calibrated_cable.toml",
    "residuals.csv",
    "calibration.png",
    "calibration.pdf",
    "calibration_sweep.toml",
)
#: Samples of the uncertainty sweep spec.
SWEEP_SAMPLES = 32
RESIDUAL_COLUMNS = (
    "applicator", "point", "relative_position_mm",
    "measured_x_mm", "measured_y_mm", "measured_z_mm",
    "simulated_before_x_mm", "simulated_before_y_mm", "simulated_before_z_mm",
    "simulated_after_x_mm", "simulated_after_y_mm", "simulated_after_z_mm",
    "residual_before_mm", "residual_after_mm", "sd_mm", "flag",
)  # fmt: skip
IDENTIFIABLE_RULE = (
    f"identifiable when the standard error is finite and at most {MAX_RELATIVE_SE:g} of the "
    f"value (lumen.diameter_delta_mm: at most {MAX_DELTA_SE_MM:g} mm); a direction of the "
    f"weighted Jacobian with a singular value below {RCOND:g} of the largest has an infinite "
    "error; a key that ends on the edge of its searched range is not identifiable"
)


def _stats(d: np.ndarray) -> dict:
    return {"median_mm": float(np.median(d)), "max_mm": float(np.max(d))} if d.size else {}


def calibration_dict(cal: Calibration, provenance: Provenance | None = None) -> dict:
    """The content of ``calibration.json``."""
    f = cal.fit
    keys = list(f.keys)
    params = {}
    own: dict[str, dict] = {}  # per applicator: its own keys (the lumen), by scene key
    for k in keys:
        entry = {
            "value": f.values[k],
            "standard_error": f.se[k] if math.isfinite(f.se[k]) else None,
            "start": f.start[k],
            "identifiable": f.identifiable[k],
        }
        if applicator_of(k):
            own.setdefault(applicator_of(k), {})[base_key(k)] = entry
        else:
            params[k] = entry
    moved = {k: v for k, v in f.values.items() if k not in keys}
    per_app = []
    before, after = cal.distances("before"), cal.distances("after")
    for m, b, a, e in zip(cal.measured, before, after, cal.numerical_error_mm, strict=True):
        per_app.append({
            "applicator": m.label,
            "input": m.input,
            "measured_file": m.file or None,
            "method": m.method or None,
            "sd_assumed": m.sd_assumed,
            "registration": m.registration,
            "n_points": int(m.relative_position_mm.size),
            "n_used": int(np.count_nonzero(m.used)),
            "excluded": [
                {"relative_position_mm": float(r), "flag": str(fl)}
                for r, fl in zip(m.relative_position_mm, m.flags, strict=True) if fl
            ],
            "residual_before": _stats(b[m.used]),
            "residual_after": _stats(a[m.used]),
            "max_numerical_error_mm": float(np.max(e)) if e.size else None,
            "notes": list(m.notes),
            "parameters": own.get(m.label, {}),
            "use": applicator_use(cal, m.label),
        })  # fmt: skip
    out = {
        "cable": cal.cable,
        "fitted_keys": keys,
        "parameters": params,
        "per_applicator_keys": sorted({base_key(k) for k in keys if applicator_of(k)}),
        "also_changed": moved,
        "correlation": {"keys": keys, "matrix": np.asarray(f.correlation).tolist()},
        "identifiable_rule": IDENTIFIABLE_RULE,
        "residual_before": _stats(cal.used_distances("before")),
        "residual_after": _stats(cal.used_distances("after")),
        "n_points": int(sum(int(np.count_nonzero(m.used)) for m in cal.measured)),
        "n_points_excluded": int(sum(int(np.count_nonzero(~m.used)) for m in cal.measured)),
        "chi2": f.chi2,
        "degrees_of_freedom": f.dof,
        "covariance_scale": f.scale,
        "singular_values": np.asarray(f.singular_values).tolist(),
        "evaluations": f.nfev,
        "optimiser_message": f.message,
        "fit_seconds": f.seconds,
        "seconds": cal.seconds,
        "applicators": per_app,
        "leave_one_out": [
            {
                "applicator": lo.label,
                "fitted_without": lo.values,
                "median_mm": lo.median_mm,
                "max_mm": lo.max_mm,
            }
            for lo in cal.left_out
        ],
        "scene_overrides": dict(cal.overrides),
        "stem_mm": cal.stem_mm,
        "register": cal.register,
        "notes": list(f.notes),
    }
    if provenance is not None:
        out["provenance"] = provenance
    return out


def cable_toml(cal: Calibration, command: str = "", created_utc: str = "",
               json_sha256: str = "") -> str:  # fmt: skip
    """``calibrated_cable.toml``: a configuration with the identifiable fitted values (the
    others stay at the cable's own values and are named in a comment)."""
    f = cal.fit
    kept = _kept(cal)
    left = [k for k in f.keys if not f.identifiable[k]]
    lines = [
        "# ringqa calibrate: the cable fitted to the measured source paths (calibration.json)",
    ]
    if command:
        lines.append(f"# command: {command}")
    lines += [
        "# Use: ringqa commission INPUT --config calibrated_cable.toml --out DIR",
        "# or:  ringqa simulate SCENE "
        + " ".join(f"--set {k}={v:.6g}" for k, v in kept.items())
        + " --out DIR",
    ]
    for k in left:
        lines.append(f"# {k}: not identifiable from these measurements; left at the cable's value")
    for m in cal.measured:  # each applicator's own lumen (not the cable's: not in [scene])
        use = applicator_use(cal, m.label)
        if use:
            lines.append(f"# {m.label}: its own fitted lumen; commission it with: {use}")
    lines += ["", "[simulation]", f'cable = "{cal.cable}"', "", "[scene]"]
    for k, v in kept.items():
        lines.append(f"{k} = {v:.6g}")
    for k, v in cal.overrides.items():
        if k not in kept and isinstance(v, int | float) and not isinstance(v, bool):
            lines.append(f"{k} = {v!r}")
    lines += [
        "",
        "# the commissioning report names this file (with its SHA-256) and these",
        "[calibration]",
        f"command = {json_str(command or 'ringqa calibrate')}",
    ]
    if created_utc:
        lines.append(f"created_utc = {json_str(created_utc)}")
    if json_sha256:
        lines.append(f"calibration_json_sha256 = {json_str(json_sha256)}")
    return "\n".join(lines) + "\n"


def applicator_use(cal: Calibration, label: str) -> str:
    """How to commission applicator ``label`` with its own fitted (identifiable) per-applicator
    keys: ``ringqa commission INPUT --config calibrated_cable.toml --set KEY=VALUE``; ``""``
    when it has none."""
    f = cal.fit
    sets = [f"--set {base_key(k)}={f.values[k]:.6g}" for k in f.keys
            if applicator_of(k) == label and f.identifiable[k]]  # fmt: skip
    if not sets:
        return ""
    item = next((m.input for m in cal.measured if m.label == label), label)
    return f"ringqa commission {item} --config calibrated_cable.toml {' '.join(sets)}"


def _kept(cal: Calibration) -> dict[str, float]:
    """The values calibrated_cable.toml sets (identifiable keys, mu_s raised to mu_k)."""
    f = cal.fit
    kept = {k: f.values[k] for k in f.keys if f.identifiable[k] and not applicator_of(k)}
    if "contact.mu_k" in kept and "contact.mu_s" not in kept:
        mu_s = f.start.get("contact.mu_s", f.values.get("contact.mu_s"))
        if mu_s is not None and mu_s < kept["contact.mu_k"]:
            kept["contact.mu_s"] = kept["contact.mu_k"]
    return kept


def sweep_spec_text(cal: Calibration) -> str:
    """``calibration_sweep.toml`` (module docstring)."""
    f = cal.fit
    kept = _kept(cal)
    first = cal.measured[0]
    # the spec commissions the first applicator: its own lumen key varies as the scene key
    varied = [k for k in f.keys if f.identifiable[k] and math.isfinite(f.se[k]) and f.se[k] > 0
              and applicator_of(k) in ("", first.label)]  # fmt: skip
    name = {k: base_key(k) for k in varied}
    lines = [
        "# ringqa calibrate: the fitted cable's uncertainty as a sweep (docs/sweeps.md):",
        "#   ringqa commission INPUT --config calibrated_cable.toml "
        "--sweep calibration_sweep.toml --out DIR",
        "# (ringqa commission sets the input and the commissioning settings)",
    ]
    if len(varied) > 1:
        lines.append("# the keys are drawn together from one multivariate normal with the fit's "
                     "correlation ([correlation], calibration.json)")  # fmt: skip
    lines += [
        'description = "the calibrated cable\'s parameter uncertainty (ringqa calibrate)"',
        f"input = {json_str(_resolved(first.input))}",
        f"samples = {SWEEP_SAMPLES}",
        "seed = 1",
        "",
        "[set]",
    ]
    lines += [f'"{k}" = {v:.6g}' for k, v in kept.items() if k not in varied]
    for k in varied:
        lines += ["", f'[parameters."{name[k]}"]', 'distribution = "normal"',
                  f"mean = {f.values[k]:.6g}", f"sd = {f.se[k]:.6g}",
                  'source = "ringqa calibrate: fitted value and its standard error"']  # fmt: skip
    if len(varied) > 1:
        idx = [f.keys.index(k) for k in varied]
        corr = np.asarray(f.correlation, dtype=float)[np.ix_(idx, idx)]
        corr = 0.5 * (corr + corr.T)
        np.fill_diagonal(corr, 1.0)
        rows = ", ".join("[" + ", ".join(f"{x:.12g}" for x in row) + "]" for row in corr)
        lines += ["", "[correlation]",
                  "keys = [" + ", ".join(json_str(name[k]) for k in varied) + "]",
                  f"matrix = [{rows}]",
                  'source = "ringqa calibrate: the fit\'s correlation matrix"']  # fmt: skip
    return "\n".join(lines) + "\n"


def _resolved(item: str) -> str:
    """An input path made absolute (the spec resolves paths against its own folder); a shipped
    name as it is."""
    p = Path(item)
    return str(p.resolve()) if p.exists() else str(item)


def json_str(text: str) -> str:
    """A TOML basic string."""
    import json

    return json.dumps(str(text))


def residual_rows(cal: Calibration) -> list[list]:
    """The rows of ``residuals.csv`` (after its header :data:`RESIDUAL_COLUMNS`)."""
    rows = []
    f = cal.fit
    for i, m in enumerate(cal.measured):
        b, a = f.positions_before[i], f.positions_after[i]
        for k in range(m.relative_position_mm.size):
            rb = float(np.linalg.norm(m.measured_mm[k] - b[k]))
            ra = float(np.linalg.norm(m.measured_mm[k] - a[k]))
            rows.append([
                m.label, k, f"{m.relative_position_mm[k]:.4f}",
                *(f"{v:.4f}" for v in m.measured_mm[k]),
                *(f"{v:.4f}" for v in b[k]), *(f"{v:.4f}" for v in a[k]),
                f"{rb:.4f}", f"{ra:.4f}", f"{m.sd_mm[k]:.4f}", m.flags[k],
            ])  # fmt: skip
    return rows


def figure(cal: Calibration):
    """Measured vs simulated before/after (in the plane of each path), and the residuals."""
    from matplotlib.figure import Figure

    n = len(cal.measured)
    fig = Figure(figsize=(10, 3.6 * n))
    f = cal.fit
    for i, m in enumerate(cal.measured):
        ax = fig.add_subplot(n, 2, 2 * i + 1)
        pts = m.measured_mm
        centre = pts.mean(axis=0)
        _, _, vt = np.linalg.svd(pts - centre, full_matrices=False)
        basis = vt[:2].T

        def proj(p, basis=basis, centre=centre):
            return (np.asarray(p) - centre) @ basis

        for data, style, label in (
            (pts, dict(marker="o", ls="", color="k"), "measured"),
            (f.positions_before[i], dict(marker="x", ls="--", color="tab:red"), "before"),
            (f.positions_after[i], dict(marker="+", ls="-", color="tab:blue"), "after"),
        ):
            q = proj(data)
            ax.plot(q[:, 0], q[:, 1], label=label, **style)
        bad = ~m.used
        if np.any(bad):
            q = proj(pts[bad])
            ax.plot(q[:, 0], q[:, 1], "s", mfc="none", color="tab:orange", ms=10,
                    label="left out")  # fmt: skip
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"{m.label}: source path (in its plane)", fontsize=9)
        ax.set_xlabel("mm")
        ax.set_ylabel("mm")
        ax.legend(fontsize=7)
        ax2 = fig.add_subplot(n, 2, 2 * i + 2)
        rel = m.relative_position_mm
        db = np.linalg.norm(pts - f.positions_before[i], axis=1)
        da = np.linalg.norm(pts - f.positions_after[i], axis=1)
        ax2.errorbar(rel, da, yerr=m.sd_mm, fmt="+-", color="tab:blue", label="after",
                     capsize=2)  # fmt: skip
        ax2.plot(rel, db, "x--", color="tab:red", label="before")
        ax2.set_xlabel("relative position, mm")
        ax2.set_ylabel("measured - simulated, mm")
        ax2.set_title(f"{m.label}: residuals (bars: the point's sd)", fontsize=9)
        ax2.legend(fontsize=7)
    fig.tight_layout()
    return fig


def _pdf(cal: Calibration, data: dict, path: Path, provenance: Provenance, fields) -> None:
    from ringqa.report import layout
    from ringqa.report.pdf import signature_block

    f = cal.fit
    names = ", ".join(m.label for m in cal.measured)
    inputs = layout.inputs_digest_text(
        list(provenance.inputs.values()), "inputs: shipped applicators"
    )
    stamp = layout.PageStamp(
        title=f"ringqa cable calibration: {names}",
        software=provenance.software,
        date=provenance.created_utc[:10],
        inputs=inputs,
    )
    story = [layout.heading(f"Cable calibration: the {cal.cable} cable on {names}", 1)]
    if fields is not None:
        rows = [(label, value) for label, value in (
            ("Institution", getattr(fields, "institution", "")),
            ("Physicist", getattr(fields, "physicist", "")),
            ("Afterloader", getattr(fields, "afterloader", "")),
        ) if value]  # fmt: skip
        if rows:
            story.append(layout.grid_table([list(r) for r in rows], None, header_rows=0,
                                           align="LEFT"))  # fmt: skip
    rb, ra = data["residual_before"], data["residual_after"]
    story.append(layout.para(
        f"{data['n_points']} measured points fitted ({data['n_points_excluded']} left out); "
        f"measured vs simulated median {rb.get('median_mm', float('nan')):.2f} / max "
        f"{rb.get('max_mm', float('nan')):.2f} mm before, {ra.get('median_mm', float('nan')):.2f}"
        f" / {ra.get('max_mm', float('nan')):.2f} mm after the fit ({f.nfev} evaluations, "
        f"{cal.seconds:.0f} s)."))  # fmt: skip
    table = [["key", "start", "fitted", "standard error", "identifiable"]]
    for k in f.keys:
        se = f.se[k]
        table.append([k, f"{f.start[k]:.4g}", f"{f.values[k]:.4g}",
                      f"{se:.2g}" if math.isfinite(se) else "undetermined",
                      "yes" if f.identifiable[k] else "NO"])  # fmt: skip
    story.append(layout.grid_table(table, None))
    story.append(layout.para(f"Rule: {IDENTIFIABLE_RULE}."))
    for lo in cal.left_out:
        story.append(layout.para(
            f"Left out {lo.label}: predicted by the fit on the others within median "
            f"{lo.median_mm:.2f} / max {lo.max_mm:.2f} mm."))  # fmt: skip
    for m in cal.measured:
        sd = "assumed" if m.sd_assumed else "as measured"
        story.append(layout.para(
            f"{m.label}: {m.relative_position_mm.size} points ({m.method or 'method not stated'};"
            f" uncertainty {sd}, median {float(np.median(m.sd_mm)):.2f} mm); registration "
            f"{m.registration}"))  # fmt: skip
    for note in f.notes:
        story.append(layout.para(note))
    story.append(layout.figure_image(figure(cal)))
    story.append(signature_block(fields))
    layout.build_pdf(path, story, stamp, title=stamp.title, subject="ringqa calibrate")


def write_outputs(stage: Path, cal: Calibration, provenance: Provenance, *, command: str = "",
                  fields=None) -> list[Path]:  # fmt: skip
    """Write :data:`FILES` into ``stage`` (a staging folder of
    :func:`ringqa.outdir.staged_output`).

    Returns
    -------
    list of Path
    """
    stage = Path(stage)
    data = calibration_dict(cal, provenance)
    write_json(stage / "calibration.json", data)
    (stage / "calibrated_cable.toml").write_text(
        cable_toml(cal, command, provenance.created_utc, sha256_of(stage / "calibration.json")),
        encoding="utf-8",
    )
    buf = io.StringIO(newline="")
    w = csv.writer(buf)
    w.writerow(RESIDUAL_COLUMNS)
    w.writerows(residual_rows(cal))
    text = buf.getvalue()
    (stage / "residuals.csv").write_text(text, encoding=csv_encoding(text), newline="")
    fig = figure(cal)
    fig.savefig(stage / "calibration.png", dpi=120)
    _pdf(cal, data, stage / "calibration.pdf", provenance, fields)
    (stage / "calibration_sweep.toml").write_text(sweep_spec_text(cal), encoding="utf-8")
    return [stage / name for name in FILES]
