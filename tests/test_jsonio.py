"""The one JSON writer (ringqa.jsonio): its NaN policy, numpy types, dataclasses, round trips."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from ringqa.jsonio import json_text, to_jsonable, write_json


@dataclass(frozen=True)
class _Point:
    name: str
    xyz_mm: np.ndarray
    limits: tuple[float, ...]


def test_non_finite_floats_become_null():
    """NaN, +inf and -inf (Python and numpy, scalars and inside arrays) are written as null, and
    the text is standard JSON: it has no NaN/Infinity token, so a strict parser reads it."""
    data = {"a": math.nan, "b": np.float64("inf"), "c": [1.5, -math.inf], "d": np.array([np.nan])}
    text = json_text(data, indent=None)
    assert text == '{"a": null, "b": null, "c": [1.5, null], "d": [null]}'

    def strict(token):
        raise ValueError(f"non-standard token {token}")

    assert json.loads(text, parse_constant=strict) == {
        "a": None,
        "b": None,
        "c": [1.5, None],
        "d": [None],
    }


def test_numpy_types_become_python_types():
    """np.float64 / np.int64 / np.bool_ become float / int / bool (exactly the same values);
    arrays nested lists; tuples lists; keys strings; dataclasses dicts in field order; paths
    strings."""
    out = to_jsonable(
        {
            1: np.int64(7),
            "f": np.float32(0.5),
            "b": np.bool_(True),
            "arr": np.arange(6).reshape(2, 3),
            "t": (np.float64(0.1), "x"),
            "p": Path("a") / "b.json",
            "dc": _Point("A", np.array([1.0, 2.0, 3.0]), (1.0, 2.0)),
        }
    )
    assert out == {
        "1": 7,
        "f": 0.5,
        "b": True,
        "arr": [[0, 1, 2], [3, 4, 5]],
        "t": [0.1, "x"],
        "p": "a/b.json",
        "dc": {"name": "A", "xyz_mm": [1.0, 2.0, 3.0], "limits": [1.0, 2.0]},
    }
    assert type(out["1"]) is int and type(out["b"]) is bool and type(out["t"][0]) is float


def test_unknown_types_are_refused():
    """A value with no JSON meaning is an error naming its type, never silently str()'ed."""
    with pytest.raises(TypeError, match="a set cannot be written as JSON"):
        to_jsonable({"s": {1, 2}})


def test_round_trip_is_exact(tmp_path):
    """Finite floats come back bit for bit (json writes repr, the shortest exact form); NaN comes
    back as None, which numpy reads as NaN again."""
    values = np.array([0.1, 1 / 3, 2.0**-30, 1e300, -0.0, np.nan])
    path = write_json(tmp_path / "v.json", {"v": values}, indent=2, end="\n")
    text = path.read_text()
    assert text.endswith("}\n")
    back = np.asarray(json.loads(text)["v"], dtype=float)
    np.testing.assert_array_equal(back, values)  # NaN == NaN in assert_array_equal
    assert np.signbit(back[4])


def test_write_json_matches_json_dumps_for_plain_data(tmp_path):
    """For data that is already plain and finite, the bytes are exactly json.dumps's (the
    contract files keep their layout)."""
    data = {"schema": "x/1", "n": [1, 2.5, None], "nested": {"ok": True}}
    write_json(tmp_path / "a.json", data, indent=2)
    assert (tmp_path / "a.json").read_text() == json.dumps(data, indent=2)
