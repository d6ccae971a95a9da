"""What the person signing a report fills in: :class:`ReportFields`.

The fields come from the clinic configuration (``[report]`` table of ``--config FILE``) or are
left empty, in which case the report prints a blank line to fill in by hand.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ReportFields:
    """Free-text fields printed on the report's first page and signature block.

    Attributes
    ----------
    institution : str
        Hospital / department.
    physicist : str
        The physicist who ran and signs the commissioning.
    afterloader : str
        Afterloader model and serial number.
    applicator_serial : str
        Applicator serial or part number (the library's part ID is printed beside it when known).
    source_calibration : str
        Source serial and calibration (certificate, date) as the clinic records it.
    label : str
        A short label for this applicator in a batch (e.g. the serial number).
    notes : str
        Free notes ("Notes of the physicist"), printed above the signature block.
    strict : bool
        ``ringqa commission`` exits with status 1 when a verdict is FAIL or ACTION
        (``report.strict``, ``--strict``); not printed.
    """

    institution: str = ""
    physicist: str = ""
    afterloader: str = ""
    applicator_serial: str = ""
    source_calibration: str = ""
    label: str = ""
    notes: str = ""
    strict: bool = False
