"""Render the pages of a report PDF to PNG images (for docs/figures/report_page<k>.png).

Usage::

    python tools/render_report_pages.py reports/example/report.pdf docs/figures --dpi 60

Writes ``<out>/report_page<k>.png`` for every page k = 1..N and removes stale
``report_page*.png`` beyond N. Needs pypdfium2 (the ``test`` extra).
"""

from __future__ import annotations

import argparse
from pathlib import Path


def render(pdf_path: Path, out_dir: Path, dpi: float = 60.0) -> list[Path]:
    """Render every page of ``pdf_path`` at ``dpi`` into ``out_dir``; return the PNG paths."""
    import pypdfium2 as pdfium

    out_dir.mkdir(parents=True, exist_ok=True)
    pdf = pdfium.PdfDocument(str(pdf_path))
    try:
        paths = []
        for k in range(len(pdf)):
            path = out_dir / f"report_page{k + 1}.png"
            image = pdf[k].render(scale=dpi / 72.0).to_pil()
            image.convert("P", palette=1, colors=128).save(path, optimize=True)  # small files
            paths.append(path)
    finally:
        pdf.close()
    for stale in out_dir.glob("report_page*.png"):
        if stale not in paths:
            stale.unlink()
    return paths


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("pdf", type=Path)
    parser.add_argument("out", type=Path)
    parser.add_argument("--dpi", type=float, default=60.0)
    args = parser.parse_args(argv)
    for path in render(args.pdf, args.out, args.dpi):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
