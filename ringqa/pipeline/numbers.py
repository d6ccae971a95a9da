"""One printed form per quantity: every page, table, log line and conclusion that prints a number
formats it here, so the same number never reads differently in two places (15.6 in the
conclusion beside 15.96 in the dose table).

=====================  ==========  ===========================================
quantity               form        used for
=====================  ==========  ===========================================
distance               ``1.50``    dwell deviations, verdict values (mm)
numerical error        ``0.012``   the simulation's numerical error (mm)
dose difference        ``15.96``   \\|dose difference\\| (%), verdict values
signed dose diff.      ``+15.96``  a dose point's difference (%)
signed offset          ``+0.25``   along / radial / out-of-plane components (mm)
angle                  ``2.1``     source orientation (deg)
dose                   ``7.000``   Gy
=====================  ==========  ===========================================

CSV and JSON files keep full precision (6 significant digits / float); a printed number is the
file's number rounded to its form.
"""

from __future__ import annotations

import math

__all__ = [
    "ANGLE_DEG",
    "DIST_MM",
    "DOSE_GY",
    "DOSE_PCT",
    "ERROR_MM",
    "OFFSET_MM",
    "SIGNED_PCT",
    "fmt",
    "fmt_verdict_value",
]

DIST_MM = "{:.2f}"
ERROR_MM = "{:.3f}"
DOSE_PCT = "{:.2f}"
SIGNED_PCT = "{:+.2f}"
OFFSET_MM = "{:+.2f}"
ANGLE_DEG = "{:.1f}"
DOSE_GY = "{:.3f}"


def fmt(value, form: str = DIST_MM, missing: str = "-") -> str:
    """``value`` in its printed ``form``; ``missing`` for None, NaN or infinity (never "nan"),
    never ``-0.00``.

    Parameters
    ----------
    value : float or None
    form : str
        One of this module's forms (a ``str.format`` pattern).
    missing : str
        What a missing number prints as.
    """
    if value is None:
        return missing
    try:
        x = float(value)
    except (TypeError, ValueError):
        return str(value)
    if not math.isfinite(x):
        return missing
    text, zero = form.format(x), form.format(0.0)
    return zero if text.lstrip("+-") == zero.lstrip("+-") else text


def fmt_verdict_value(value: float, unit: str, check: str = "") -> str:
    """A verdict's value with its unit in the verdict's form (``"1.50 mm"``, ``"15.96 %"``,
    ``"0.012 mm"`` for the numerics verdict)."""
    form = ERROR_MM if check.startswith("numerics") else DOSE_PCT if unit == "%" else DIST_MM
    return f"{fmt(value, form)} {unit}"
