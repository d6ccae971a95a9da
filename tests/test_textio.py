"""Strict reading of users' JSON, CSV and TOML files (ringqa.textio) and terminal escaping."""

from __future__ import annotations

import pytest

from ringqa.errors import InputFileError
from ringqa.textio import (
    MAX_JSON_DEPTH,
    json_depth,
    read_csv_table,
    read_json,
    read_text,
    read_toml,
    terminal_text,
)


def test_json_key_given_twice_is_refused_naming_the_key_and_file(tmp_path):
    """{"s_ref_mm": 4, "s_ref_mm": 5}: refused (Python's json would keep 5 silently)."""
    p = tmp_path / "app.json"
    p.write_text('{"channels": [{"name": "ring", "s_ref_mm": 4, "s_ref_mm": 5}]}')
    with pytest.raises(InputFileError, match=r"app.json: key 's_ref_mm' is given twice"):
        read_json(p)


def test_deep_json_is_refused_without_recursion_error(tmp_path):
    """100 000 nested lists (past Python's recursion limit) and 65 (past MAX_JSON_DEPTH = 64):
    both a clean InputFileError; 64 levels are read."""
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(InputFileError, match="nested too deeply"):
        read_json(deep)
    over = tmp_path / "over.json"
    over.write_text("[" * (MAX_JSON_DEPTH + 1) + "]" * (MAX_JSON_DEPTH + 1))
    with pytest.raises(InputFileError, match="nested 65 levels deep"):
        read_json(over)
    ok = tmp_path / "ok.json"
    ok.write_text("[" * MAX_JSON_DEPTH + "]" * MAX_JSON_DEPTH)
    assert json_depth(read_json(ok)) == MAX_JSON_DEPTH


@pytest.mark.parametrize(
    ("codec", "bom", "name"),
    [
        ("utf-8", b"", "UTF-8"),
        ("utf-8", b"\xef\xbb\xbf", "UTF-8 with BOM"),
        ("utf-16-le", b"\xff\xfe", "UTF-16"),
        ("utf-16-be", b"\xfe\xff", "UTF-16"),
        ("utf-32-le", b"\xff\xfe\x00\x00", "UTF-32"),
    ],
)
def test_encodings_with_their_byte_order_mark_are_read(tmp_path, codec, bom, name):
    """The same JSON text saved in five encodings reads to the same value, naming the encoding."""
    p = tmp_path / "a.json"
    p.write_bytes(bom + '{"name": "Ring 60°"}'.encode(codec))
    assert read_text(p).encoding == name
    assert read_json(p) == {"name": "Ring 60°"}


def test_bytes_that_are_not_utf8_are_refused_unless_latin1_is_allowed(tmp_path):
    """0xb0 (a Latin-1 degree sign) at offset 10: refused for JSON naming the byte and offset;
    read as Latin-1 where allowed (CSV point files); UTF-16 without a BOM (NULs) refused."""
    p = tmp_path / "a.json"
    p.write_bytes(b'{"name": "\xb0"}')
    with pytest.raises(InputFileError, match="byte 0xb0 at offset 10"):
        read_json(p)
    assert read_text(p, latin1=True).encoding == "Latin-1"
    q = tmp_path / "b.json"
    q.write_bytes('{"a": 1}'.encode("utf-16-le"))
    with pytest.raises(InputFileError, match="NUL"):
        read_json(q)


def test_csv_column_given_twice_is_refused(tmp_path):
    """time_s,max_err_mm,time_s: refused naming the column and both positions."""
    p = tmp_path / "a.csv"
    p.write_text("time_s,max_err_mm,time_s\n1,2,3\n")
    with pytest.raises(InputFileError, match=r"column 'time_s' twice \(columns 1 and 3\)"):
        read_csv_table(p)
    p.write_text("time_s,max_err_mm\n1,2\n")
    assert list(read_csv_table(p).columns) == ["time_s", "max_err_mm"]


def test_toml_in_utf16_is_read_and_bad_toml_named(tmp_path):
    p = tmp_path / "s.toml"
    p.write_bytes(b"\xff\xfe" + "[solver]\nincrement_mm = 0.5\n".encode("utf-16-le"))
    assert read_toml(p) == {"solver": {"increment_mm": 0.5}}
    p.write_text("[solver\n")
    with pytest.raises(InputFileError, match=r"s\.toml: not valid TOML"):
        read_toml(p)
    p.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(InputFileError, match=r"s\.toml"):
        read_toml(p)


def test_terminal_text_escapes_control_characters():
    """ESC, CR, BEL, DEL, a C1 control and a right-to-left override become visible escapes;
    tab, newline and ordinary non-ASCII text (°) stay; progress output keeps its leading CR and
    cursor-up."""
    assert terminal_text("a\x1b[31mb\rc\x07\x7f\x9b\u202ed\t60°\n") == (
        "a\\x1b[31mb\\x0dc\\x07\\x7f\\x9b\\u202ed\t60°\n"
    )
    assert terminal_text("\r 10%|#\x1b[A", keep_cr=True) == "\r 10%|#\x1b[A"
    assert terminal_text("plain") == "plain"
