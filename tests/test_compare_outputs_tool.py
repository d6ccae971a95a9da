"""tools/compare_outputs.py: the PDF content streams it compares, and the timings it leaves out."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def tool(load_script):
    return load_script("tools/compare_outputs.py")


def test_every_stream_of_a_ringqa_pdf_is_read(tool):
    """reports/example/report.pdf (reportlab): as many content streams as ``endstream``
    keywords in the file (the pattern used to need a line break before ``endstream``, which
    reportlab's binary streams do not have, and read 0 of them); the first page's stream
    decompresses to drawing operators (``BT`` begins a text object)."""
    pdf = ROOT / "reports" / "example" / "report.pdf"
    streams = tool._pdf_streams(pdf)
    n = len(re.findall(rb"endstream", pdf.read_bytes()))
    assert n > 0 and len(streams) == n
    assert any(b"BT" in s for s in streams)


def test_a_changed_stream_is_found_and_timings_are_left_out(tool, tmp_path):
    """Two PDFs that differ in one stream's content (the second of two): ``differing streams
    [1]``. Two results.json that differ only in refined_solve_time_s, total_solve_time_s and
    added_wall_s (the timings the list missed): 'volatile-only', not DIFFERENT."""

    def pdf(text: bytes) -> bytes:
        return (b"%PDF-1.4\n1 0 obj\n<< /Length 3 >>\nstream\nabcendstream\nendobj\n"
                b"2 0 obj\n<< /Length 3 >>\nstream\n" + text + b"endstream\nendobj\n")  # fmt: skip

    a, b = tmp_path / "a" / "report.pdf", tmp_path / "b" / "report.pdf"
    for path, text in ((a, b"xyz"), (b, b"xyw")):
        path.parent.mkdir(exist_ok=True)
        path.write_bytes(pdf(text))
    kind, details = tool.compare_file(a, b)
    assert kind == "info" and "2 vs 2 streams; differing streams [1]" in details[0]
    common = {"dwell_mm": 1.0}
    ja, jb = tmp_path / "a" / "results.json", tmp_path / "b" / "results.json"
    ja.write_text(json.dumps({**common, "refined_solve_time_s": 1.0, "total_solve_time_s": 2.0,
                              "added_wall_s": 0.1}))  # fmt: skip
    jb.write_text(json.dumps({**common, "refined_solve_time_s": 1.5, "total_solve_time_s": 2.5,
                              "added_wall_s": 0.2}))  # fmt: skip
    assert tool.compare_file(ja, jb)[0] == "volatile-only"
    jb.write_text(json.dumps({**common, "dwell_mm": 1.1, "refined_solve_time_s": 1.0,
                              "total_solve_time_s": 2.0, "added_wall_s": 0.1}))  # fmt: skip
    assert tool.compare_file(ja, jb)[0] == "DIFFERENT"


def test_output_record_and_quoted_times_are_volatile(tool, tmp_path):
    """The folder's .ringqa-output.json with another pid, times and hashes but the same command
    and files: 'volatile-only'; a file missing from its list: DIFFERENT. A results.json sentence
    that differs only in the cross-check's quoted times ("(0.17 s; the command waited 0.01 s for
    it)" vs "(0.50 s; ... 0.04 s ...)", or the serial form "it took 0.16 s"): 'volatile-only'; the
    same sentence with another distance: DIFFERENT."""

    def record(pid: int, files: list[str]) -> str:
        listed = [{"path": f, "size": pid, "sha256": str(pid), "mtime_ns": pid} for f in files]
        return json.dumps({"software": "ringqa", "version": "0.1.0", "command": "simulate",
                           "created_utc": str(pid), "pid": pid, "files": listed})  # fmt: skip

    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    ma, mb = tmp_path / "a" / tool.MANIFEST, tmp_path / "b" / tool.MANIFEST
    ma.write_text(record(1, ["dwells.csv", "run.json"]))
    mb.write_text(record(2, ["dwells.csv", "run.json"]))
    assert tool.compare_file(ma, mb)[0] == "volatile-only"
    mb.write_text(record(2, ["dwells.csv"]))
    assert tool.compare_file(ma, mb)[0] == "DIFFERENT"

    def sentence(mm: str, ran: str, waited: str) -> str:
        return (f"the dwells agree to {mm} mm; it ran beside the rigid runs on the second core "
                f"({ran} s; the command waited {waited} s for it).")  # fmt: skip

    ja, jb = tmp_path / "a" / "results.json", tmp_path / "b" / "results.json"
    ja.write_text(json.dumps({"text": sentence("0.043", "0.17", "0.01")}))
    jb.write_text(json.dumps({"text": sentence("0.043", "0.50", "0.04")}))
    assert tool.compare_file(ja, jb)[0] == "volatile-only"
    jb.write_text(json.dumps({"text": sentence("0.044", "0.17", "0.01")}))
    assert tool.compare_file(ja, jb)[0] == "DIFFERENT"
    # the same cross-check run in the command's own process (a loaded machine): "it took 0.16 s"
    serial = "the dwells agree to {} mm; it took {} s."
    jb.write_text(json.dumps({"text": serial.format("0.043", "0.16")}))
    assert tool.compare_file(ja, jb)[0] == "volatile-only"
    jb.write_text(json.dumps({"text": serial.format("0.044", "0.16")}))
    assert tool.compare_file(ja, jb)[0] == "DIFFERENT"
