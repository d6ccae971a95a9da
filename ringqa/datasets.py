"""Example data shipped with ringqa, for notebooks and first runs.

``example_plan()`` is the path of the shipped Oncentra RT Plan (a 26 mm / 60 degree
tandem-and-ring plan with the vendor's library source path; MIT licence, notice in
``data/examples/oncentra_ring26x60/README.md``). It works in a checkout, an editable install and
a wheel install (the wheel carries ``data/examples`` as ``ringqa/_data/examples``:
:func:`ringqa.paths.data_dir`)::

    from ringqa.datasets import example_plan
    from ringqa.pipeline import commission
    result = commission(example_plan())
"""

from __future__ import annotations

from pathlib import Path

from ringqa.paths import data_dir

#: the example plan, relative to the data folder
EXAMPLE_PLAN = Path("examples") / "oncentra_ring26x60" / "RP_ring26x60_oncentra43.dcm"


def example_plan() -> Path:
    """Path of the shipped example RT Plan (Oncentra, 26 mm / 60 degree ring and tandem).

    Raises
    ------
    FileNotFoundError
        The installation is incomplete (reinstall ringqa).
    """
    path = data_dir() / EXAMPLE_PLAN
    if not path.is_file():
        raise FileNotFoundError(
            f"{path}: the example plan is missing; reinstall ringqa from a complete checkout"
        )
    return path
