"""The one way ringqa writes JSON: plain data from numpy, dataclasses and paths, one NaN policy.

Every JSON file ringqa writes (``results.json``, ``batch.json``, ``study.json``, ``runs.jsonl``,
``run.json``, ``plan.json``, ``provenance.json``, applicator and point files) goes through
:func:`to_jsonable` and :func:`json_text` (or :func:`write_json`).

Conversions (applied recursively)
---------------------------------
- ``None``, ``bool``, ``int``, ``str``: unchanged.
- ``float`` and numpy floating scalars: unchanged when finite.
- **NaN policy**: a non-finite float (NaN, +inf, -inf) is written as JSON ``null``. The output is
  standard JSON (RFC 8259, which has no NaN or Infinity), so any reader can parse it;
  :func:`json_text` passes ``allow_nan=False`` to :func:`json.dumps`, so a non-finite value that
  escaped the conversion is an error, never a non-standard ``NaN`` token. A reader that needs NaN
  back reads ``null`` as NaN (``numpy.asarray(values, dtype=float)`` does).
- numpy scalars (``np.float64``, ``np.int64``, ``np.bool_``): the Python value (``.item()``).
- numpy arrays: nested lists (``.tolist()``), elements converted as above.
- ``dict`` and other mappings: keys as ``str(key)``, values converted, order kept.
- ``list`` and ``tuple``: lists.
- dataclass instances: a dict of their fields, in field order.
- paths (``os.PathLike``): ``os.fspath(path)``.
- anything else: :class:`TypeError` naming the type (convert it before writing; a value is never
  written as its ``str()`` by accident).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ringqa.outdir import atomic_write_text

__all__ = ["csv_encoding", "json_text", "to_jsonable", "write_json"]

#: the encoding of a CSV file holding non-ASCII text: UTF-8 with a byte-order mark, so that
#: Excel (which reads a CSV without one in the system's code page) keeps the degree signs of
#: applicator names ("60°"); pandas, the csv module with ``encoding="utf-8-sig"`` and ringqa's
#: readers skip the mark.
CSV_ENCODING_NON_ASCII = "utf-8-sig"


def csv_encoding(table) -> str:
    """The encoding to write a CSV of ``table`` with: ``"utf-8-sig"`` when any column name or
    text value is not ASCII (Excel then reads it correctly), else ``"utf-8"`` (byte for byte
    what ASCII files always were).

    Parameters
    ----------
    table : pandas.DataFrame or iterable of rows
        The header and values (rows: iterables of values).
    """
    if hasattr(table, "columns"):
        texts = [str(c) for c in table.columns]
        for col in table.columns:
            if table[col].dtype == object or str(table[col].dtype).startswith("str"):
                texts += [v for v in table[col].tolist() if isinstance(v, str)]
    else:
        texts = [v for row in table for v in row if isinstance(v, str)]
    return CSV_ENCODING_NON_ASCII if any(not t.isascii() for t in texts) else "utf-8"


def to_jsonable(obj: Any) -> Any:
    """Plain JSON data (dict, list, str, int, float, bool, None) from ``obj``.

    Parameters
    ----------
    obj : Any
        Nested dicts, lists, tuples, dataclasses, numpy scalars and arrays, paths, numbers,
        strings, booleans and None.

    Returns
    -------
    Any
        The same structure made of JSON types only; non-finite floats are None (JSON ``null``).

    Raises
    ------
    TypeError
        A value of a type not listed in the module docstring.
    """
    if obj is None or isinstance(obj, bool | int | str):
        return obj
    if isinstance(obj, np.generic):
        return to_jsonable(obj.item())
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Mapping):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    raise TypeError(
        f"to_jsonable: a {type(obj).__name__} cannot be written as JSON (convert it to numbers, "
        "strings, lists or dicts first)"
    )


def json_text(obj: Any, *, indent: int | None = 2) -> str:
    """``obj`` as standard JSON text (see :func:`to_jsonable` for the conversions).

    Parameters
    ----------
    obj : Any
        What to write.
    indent : int or None
        Indentation (None: one line, as in ``runs.jsonl``).

    Returns
    -------
    str
        The JSON text, without a trailing newline.
    """
    return json.dumps(to_jsonable(obj), indent=indent, allow_nan=False)


def write_json(path: str | os.PathLike, obj: Any, *, indent: int | None = 2, end: str = "") -> Path:
    """Write ``obj`` as JSON to ``path`` atomically (:func:`ringqa.outdir.atomic_write_text`).

    Parameters
    ----------
    path : str or path
        The file to write (replaced if it exists).
    obj : Any
        What to write (see :func:`to_jsonable`).
    indent : int or None
        Indentation.
    end : str
        Appended after the JSON text (``"\\n"`` for a final newline).

    Returns
    -------
    Path
        The file written.
    """
    return atomic_write_text(path, json_text(obj, indent=indent) + end)
