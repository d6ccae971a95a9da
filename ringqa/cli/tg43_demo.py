"""``ringqa tg43-demo``: the TG-43 engine on one source, as an along-away table and an isodose plot.

Writes ``DIR/along_away.csv`` (dose rate per unit S_K on the consensus along-away grid, with the
consensus value and the difference where the source ships a QA table) and ``DIR/isodose.png``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ringqa.cli._options import plain_help

# numpy, pandas, matplotlib and the output helpers are imported where they are used, so that
# building the command line (``ringqa --help``) does not import them

Z_CM = (-7.0, -5.0, -3.0, -2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0, 3.0, 5.0, 7.0)
Y_CM = (0.0, 0.25, 0.5, 1.0, 2.0, 3.0, 5.0, 7.0)


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "tg43-demo",
        help="TG-43 dose-rate table and isodose plot for one source",
        description=plain_help(__doc__),
    )
    p.add_argument("--source", default="flexisource", help="source name or folder (flexisource)")
    p.add_argument("--out", required=True, type=Path, help="output folder")
    p.set_defaults(func=run)


def along_away_rows(source) -> list[dict]:
    """Rows of the along-away table: engine value, consensus value and difference in %."""
    import numpy as np

    import tg43

    if source.has_qa_table:
        z_cm, y_cm = source.qa_z_cm, source.qa_y_cm
    else:
        z_cm, y_cm = np.array(Z_CM), np.array(Y_CM)
    rows = []
    for i, z in enumerate(z_cm):
        for j, y in enumerate(y_cm):
            if y == 0 and abs(z) <= 0.5 * source.active_length_cm + 0.05:
                continue  # on or next to the active core
            rate = tg43.dose_rate_per_sk(source, [[0, 0, 0]], [[0, 0, 1]], [[10 * y, 0, 10 * z]])
            row = {"z_cm": float(z), "y_cm": float(y), "dose_rate_cGy_h_U": float(rate[0, 0])}
            if source.has_qa_table:
                ref = float(source.qa_dose_rate[i, j])
                row["consensus_cGy_h_U"] = ref
                row["diff_pct"] = 100.0 * (row["dose_rate_cGy_h_U"] / ref - 1.0)
            rows.append(row)
    return rows


def _isodose_png(source, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    import tg43

    y = np.linspace(-40, 40, 161)
    z = np.linspace(-40, 40, 161)
    yy, zz = np.meshgrid(y, z)
    pts = np.column_stack([yy.ravel(), np.zeros(yy.size), zz.ravel()])
    r = np.linalg.norm(pts, axis=1)
    keep = r > 2.0
    rate = np.full(yy.size, np.nan)
    rate[keep] = tg43.dose_rate_per_sk(source, [[0, 0, 0]], [[0, 0, 1]], pts[keep])[:, 0]
    rate = rate.reshape(yy.shape) / source.dose_rate_constant * 100.0  # % of the rate at 1 cm
    fig, ax = plt.subplots(figsize=(6, 6))
    levels = [5, 10, 25, 50, 100, 200, 400]
    cs = ax.contour(yy, zz, rate, levels=levels, cmap="viridis")
    ax.clabel(cs, fmt="%d %%", fontsize=8)
    ax.plot([0, 0], [-0.5 * 10 * source.active_length_cm, 0.5 * 10 * source.active_length_cm],
            "r-", lw=3, label="active core")  # fmt: skip
    ax.annotate("tip", (0, 8), ha="center", color="r")
    ax.annotate("cable", (0, -9), ha="center", color="r")
    ax.set_xlabel("y (mm), away from the source axis")
    ax.set_ylabel("z (mm), along the source axis (+z = tip)")
    ax.set_title(f"TG-43 2D isodose lines, {source.name}\n(% of the dose rate at 1 cm, 90 deg)")
    ax.set_aspect("equal")
    ax.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def run(args: argparse.Namespace) -> int:
    import pandas as pd

    import tg43
    from ringqa.jsonio import write_json
    from ringqa.outdir import staged_output
    from ringqa.provenance import Provenance

    source = tg43.load_source(args.source)
    rows = along_away_rows(source)
    table = pd.DataFrame(rows)
    prov = Provenance.now(settings={"source": source.name, "L_cm": source.active_length_cm})
    with staged_output(args.out) as stage:
        table.to_csv(stage / "along_away.csv", index=False, float_format="%.6g")
        _isodose_png(source, stage / "isodose.png")
        write_json(stage / "provenance.json", prov.as_dict(), indent=2)
    msg = f"ringqa tg43-demo: {source.name}: {len(rows)} points -> {args.out}/along_away.csv"
    if "diff_pct" in table:
        msg += f" (max |diff| to consensus {table['diff_pct'].abs().max():.3f} %)"
    print(msg)
    return 0
