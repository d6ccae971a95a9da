"""Shared fixtures of the report tests: a commissioned stand-in ring and the text of a PDF."""

from __future__ import annotations

import pytest

from ringqa.pipeline import CommissionSettings, commission
from tests.pipeline.fakes import fake_engine, fake_simulator, make_applicator


@pytest.fixture(scope="session")
def fake_result():
    """The stand-in ring with a tandem, its reference path in the ring plane (no registration),
    simulated by the stand-in engine (source 0.2 mm cranial, 0.03 mm numerical error)."""
    engine = fake_engine(fake_simulator(z_m=2e-4, coarse_z_m=3e-5))
    return commission(make_applicator(tandem=True), CommissionSettings(), engine=engine)


def pdf_pages_text(path) -> list[str]:
    """The text of each page of the PDF at ``path`` (pypdfium2's text layer)."""
    import pypdfium2 as pdfium

    pdf = pdfium.PdfDocument(str(path))
    try:
        return [pdf[k].get_textpage().get_text_range() for k in range(len(pdf))]
    finally:
        pdf.close()
