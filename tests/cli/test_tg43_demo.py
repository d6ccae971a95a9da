"""`ringqa tg43-demo` in-process: files written, consensus met, bad input exits 2."""

from __future__ import annotations

import pandas as pd

from ringqa.cli import main


def test_demo_writes_table_and_plot(tmp_path, capsys):
    """Flexisource ships a QA table: every row agrees with it within 0.12 %."""
    out = tmp_path / "demo"
    assert main(["tg43-demo", "--out", str(out)]) == 0
    table = pd.read_csv(out / "along_away.csv")
    assert {"z_cm", "y_cm", "dose_rate_cGy_h_U", "diff_pct"} <= set(table.columns)
    assert len(table) > 100
    assert table["diff_pct"].abs().max() < 0.12
    assert (out / "isodose.png").stat().st_size > 10_000
    assert "max |diff|" in capsys.readouterr().out


def test_demo_unknown_source_is_one_line_exit_2(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["tg43-demo", "--source", "nope", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "unknown source 'nope'" in err and err.count("\n") == 1
    assert not out.exists()
