"""Strict reading of the text files users give ringqa (JSON, CSV, TOML), in one place.

Every JSON, CSV or TOML file a user hands ringqa (applicator files, point files, scenes,
clinic configurations, sweep specs, accuracy tables) is read through this module, so that the
same damaged file is refused the same way, in one line naming the file and what is wrong:

- **Encodings.** UTF-8 with or without a byte-order mark, UTF-16 and UTF-32 with their BOM (as
  Windows' "Unicode" text is saved) are decoded; any other bytes that are not UTF-8 are refused
  naming the file and the first bad byte's offset (CSV point files may instead fall back to
  Latin-1 with a note: ``latin1=True``). Text holding NUL characters is refused as not text.
- **JSON.** A key given twice in one object is refused naming the key (the last one used to
  win without a word: a changed ``s_ref_mm`` moved the max deviation from 4.53 to 2.52 mm);
  nesting deeper than :data:`MAX_JSON_DEPTH` is refused (no ``RecursionError``). (``NaN`` and
  ``Infinity`` tokens are read as floats, so that the reader's finiteness check names the field
  that holds one.)
- **CSV.** A header naming a column twice is refused naming the column (the first one used to
  win).
- **TOML.** Decoded as above (a scene saved as UTF-16 reads), the parser's errors and a
  nesting too deep for it name the file.

Also here: :func:`terminal_text`, which shows control characters of text that came from a file
(an ANSI escape in an applicator name) as escapes before it reaches a terminal.
"""

from __future__ import annotations

import csv
import io
import json
import tomllib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ringqa.errors import InputFileError

__all__ = [
    "MAX_JSON_DEPTH",
    "TextFile",
    "check_columns",
    "decode_text",
    "json_depth",
    "loads_json",
    "read_csv_table",
    "read_json",
    "read_text",
    "read_toml",
    "terminal_text",
]

#: the deepest nesting of arrays/objects accepted in a JSON file (ringqa's own files need 4)
MAX_JSON_DEPTH = 64

#: byte-order marks, longest first (UTF-32's LE mark starts with UTF-16's)
_BOMS: tuple[tuple[bytes, str, str], ...] = (
    (b"\xff\xfe\x00\x00", "utf-32", "UTF-32"),
    (b"\x00\x00\xfe\xff", "utf-32", "UTF-32"),
    (b"\xef\xbb\xbf", "utf-8-sig", "UTF-8 with BOM"),
    (b"\xff\xfe", "utf-16", "UTF-16"),
    (b"\xfe\xff", "utf-16", "UTF-16"),
)

ErrorFactory = Callable[[Path, str, str], Exception]


@dataclass(frozen=True)
class TextFile:
    """A decoded text file.

    Attributes
    ----------
    text : str
        The content (no byte-order mark).
    encoding : str
        How it was decoded: ``UTF-8``, ``UTF-8 with BOM``, ``UTF-16``, ``UTF-32`` or
        ``Latin-1``.
    """

    text: str
    encoding: str


def decode_text(
    raw: bytes,
    path: str | Path,
    *,
    what: str = "text",
    latin1: bool = False,
    error: ErrorFactory = InputFileError,
) -> TextFile:
    """Decode the bytes of a user's text file (see the module docstring).

    Parameters
    ----------
    raw : bytes
        The file's bytes.
    path : str or Path
        The file (named in errors).
    what : str
        What the file should be (``JSON``, ``TOML``, ``CSV``), for the messages.
    latin1 : bool
        Decode bytes that are not UTF-8 as Latin-1 (CSV point files) instead of refusing them.
    error : callable
        ``error(path, problem, fix)`` builds the exception (an :class:`InputFileError`
        subclass of the caller's module).

    Raises
    ------
    Exception
        From ``error``: bytes that are not text in a known encoding, or NUL characters.
    """
    p = Path(path)
    for bom, codec, name in _BOMS:
        if raw.startswith(bom):
            try:
                text = raw.decode(codec)
            except UnicodeDecodeError as exc:
                raise error(
                    p,
                    f"starts with a {name} byte-order mark but is not valid {name} "
                    f"(byte offset {exc.start})",
                    f"save it again as {what} in UTF-8",
                ) from None
            return _no_nul(TextFile(text.lstrip("\ufeff"), name), p, what, error)
    try:
        return _no_nul(TextFile(raw.decode("utf-8"), "UTF-8"), p, what, error)
    except UnicodeDecodeError as exc:
        if latin1 and b"\x00" not in raw:
            return TextFile(raw.decode("latin-1"), "Latin-1")
        bad = raw[exc.start : exc.start + 1].hex()
        raise error(
            p,
            f"is not UTF-8 text: byte 0x{bad} at offset {exc.start} "
            f"(not {what}, or saved in another encoding)",
            f"save it as {what} in UTF-8 (or UTF-16 with its byte-order mark)",
        ) from None


def _no_nul(tf: TextFile, p: Path, what: str, error: ErrorFactory) -> TextFile:
    if "\x00" in tf.text:
        raise error(p, f"contains NUL characters: not a {what} text file", f"give the {what} file")
    return tf


def read_text(
    path: str | Path,
    *,
    what: str = "text",
    latin1: bool = False,
    error: ErrorFactory = InputFileError,
) -> TextFile:
    """Read and decode a user's text file (:func:`decode_text`); an unreadable file (missing,
    a folder, no permission) is refused through ``error`` too."""
    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise error(p, f"cannot be read ({exc.strerror or exc})", "check the path") from None
    return decode_text(raw, p, what=what, latin1=latin1, error=error)


class _DuplicateKey(ValueError):
    def __init__(self, key: str) -> None:
        super().__init__(key)
        self.key = key


def _pairs(pairs: list[tuple[str, Any]]) -> dict:
    out: dict = {}
    for key, value in pairs:
        if key in out:
            raise _DuplicateKey(key)
        out[key] = value
    return out


def json_depth(obj: Any) -> int:
    """The nesting depth of parsed JSON (a scalar 0, ``[]`` 1, ``[[1]]`` 2), without recursion."""
    deepest = 0
    stack = [(obj, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, dict):
            deepest = max(deepest, depth)
            stack.extend((v, depth + 1) for v in item.values())
        elif isinstance(item, list):
            deepest = max(deepest, depth)
            stack.extend((v, depth + 1) for v in item)
    return deepest


def loads_json(text: str, path: str | Path, *, error: ErrorFactory = InputFileError) -> Any:
    """Parse JSON text strictly (duplicate keys and depth refused; see the module).

    Raises
    ------
    Exception
        From ``error``, naming the file and the key, line or depth.
    """
    p = Path(path)
    try:
        doc = json.loads(text, object_pairs_hook=_pairs)
    except _DuplicateKey as exc:
        raise error(
            p,
            f"key {exc.key!r} is given twice in the same object (JSON keeps only one of them)",
            f"keep the one value you mean for {exc.key!r} and delete the other",
        ) from None
    except json.JSONDecodeError as exc:
        raise error(
            p,
            f"not valid JSON: invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}",
            "fix the file's syntax",
        ) from None
    except RecursionError:
        raise error(
            p,
            f"JSON nested too deeply (more than {MAX_JSON_DEPTH} levels of [ and {{)",
            "give the file ringqa's format",
        ) from None
    depth = json_depth(doc)
    if depth > MAX_JSON_DEPTH:
        raise error(
            p,
            f"JSON nested {depth} levels deep (at most {MAX_JSON_DEPTH} are read)",
            "give the file ringqa's format",
        )
    return doc


def read_json(path: str | Path, *, error: ErrorFactory = InputFileError) -> Any:
    """Read a user's JSON file strictly: :func:`read_text` then :func:`loads_json`."""
    tf = read_text(path, what="JSON", error=error)
    return loads_json(tf.text, path, error=error)


def check_columns(
    header: Sequence[str], path: str | Path, *, error: ErrorFactory = InputFileError
) -> None:
    """Refuse a CSV header that names a column twice (names compared after stripping spaces).

    Raises
    ------
    Exception
        From ``error``, naming the column and the positions it appears at.
    """
    seen: dict[str, int] = {}
    for i, name in enumerate(header, start=1):
        key = str(name).strip()
        if key in seen:
            raise error(
                Path(path),
                f"the header names column {key!r} twice (columns {seen[key]} and {i}): "
                "ringqa cannot tell which one you mean",
                f"rename or delete one of the two {key!r} columns",
            )
        seen[key] = i


def read_csv_table(path: str | Path, *, error: ErrorFactory = InputFileError):
    """Read a user's CSV table into a pandas DataFrame strictly: decoded as above, the header
    checked for repeated columns (pandas would rename the second ``x.1``).

    Returns
    -------
    pandas.DataFrame
    """
    import pandas as pd

    p = Path(path)
    tf = read_text(p, what="CSV", error=error)
    first = next(csv.reader(io.StringIO(tf.text)), [])
    check_columns(first, p, error=error)
    try:
        return pd.read_csv(io.StringIO(tf.text))
    except (ValueError, csv.Error) as exc:
        raise error(p, f"cannot be read as CSV ({exc})", "give a comma-separated table") from None


def read_toml(path: str | Path, *, error: ErrorFactory = InputFileError) -> dict:
    """Read a user's TOML file: decoded as above (a UTF-16 file reads), the parser's errors and
    a nesting too deep for it refused naming the file."""
    p = Path(path)
    tf = read_text(p, what="TOML", error=error)
    try:
        return tomllib.loads(tf.text)
    except tomllib.TOMLDecodeError as exc:
        raise error(p, f"not valid TOML: {exc}", "fix the syntax there") from None
    except RecursionError:
        raise error(p, "TOML nested too deeply", "give the file ringqa's format") from None


#: characters shown as escapes by :func:`terminal_text`: C0 controls but tab and newline, DEL,
#: C1 controls, and the bidirectional overrides that reorder text on screen
_SHOWN = {
    **{c: f"\\x{c:02x}" for c in range(0x20) if c not in (0x09, 0x0A)},
    0x7F: "\\x7f",
    **{c: f"\\x{c:02x}" for c in range(0x80, 0xA0)},
    **{c: f"\\u{c:04x}" for c in (*range(0x202A, 0x202F), *range(0x2066, 0x206A))},
}


def terminal_text(text: str, *, keep_cr: bool = False) -> str:
    """``text`` with control characters shown as escapes (``\\x1b``), safe to print.

    Text from files (an applicator name in an RT Plan, a key in a user's file) can hold an ANSI
    escape or a carriage return that would repaint the terminal; the command line passes every
    line it prints through this function (:mod:`ringqa.cli`). Tab and newline are kept.

    Parameters
    ----------
    text : str
        What is about to be printed.
    keep_cr : bool
        Progress-bar output (standard error): keep a carriage return at the very start and the
        cursor-up sequence ``ESC [ A`` with which a bar redraws its line.
    """
    if not any(ord(ch) in _SHOWN for ch in text):
        return text
    if keep_cr:
        head = "\r" if text.startswith("\r") else ""
        parts = text[len(head) :].split(_CURSOR_UP)
        return head + _CURSOR_UP.join(part.translate(_SHOWN) for part in parts)
    return text.translate(_SHOWN)


_CURSOR_UP = "\x1b[A"
