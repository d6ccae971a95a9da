"""The sweep spec: bad specs are refused with one line naming file, key and value, exit 2, and
nothing written; ``--set`` reaches every key."""

from __future__ import annotations

from pathlib import Path

import pytest

from ringqa.cli import main
from ringqa.sweep import SweepSpecError, load_spec

GOOD = Path(__file__).resolve().parents[2] / "data" / "sweeps" / "ring26-uncertainty.toml"


def test_shipped_spec_loads_with_its_sources():
    """The shipped example is valid, resolves its input relative to itself and says where every
    number comes from."""
    spec = load_spec(GOOD)
    assert Path(spec.input).is_file() and spec.input.endswith(".dcm")
    assert spec.samples == 256
    assert all(len(p.source) > 20 for p in spec.parameters)
    mu = {p.key: p for p in spec.parameters}
    # mu_k <= mu_s in every sample: mu_k's range ends where mu_s's starts
    assert mu["contact.mu_k"].args["high"] <= mu["contact.mu_s"].args["low"]


def test_set_overrides_top_level_and_parameter_fields():
    spec = load_spec(GOOD, {"samples": 24, "seed": 5, "parameters.contact.mu_k.high": 0.22})
    assert (spec.samples, spec.seed) == (24, 5)
    assert {p.key: p for p in spec.parameters}["contact.mu_k"].args["high"] == 0.22


BAD = [
    (
        "samples = 4\nseed = 1\ninput = 'ring26x60'\nsampels = 3\n"
        "[parameters.'contact.mu_k']\ndistribution = 'normal'\nmean = 0.2\nsd = 0.02\n",
        "sampels: unknown key (did you mean 'samples'?",
    ),
    (
        "samples = 4\nseed = 1\ninput = 'ring26x60'\n"
        "[parameters.'contact.mu_kk']\ndistribution = 'normal'\nmean = 0.2\nsd = 0.02\n",
        "parameters.contact.mu_kk: unknown key (did you mean 'contact.mu_k'?",
    ),
    (
        "samples = 4\nseed = 1\ninput = 'ring26x60'\n"
        "[parameters.'contact.mu_k']\ndistribution = 'normal'\nmean = 0.2\nsd = -0.02\n",
        "parameters.contact.mu_k.sd = -0.02: a standard deviation must be > 0",
    ),
    (
        "samples = 4\nseed = 1\ninput = 'ring26x60'\n"
        "[parameters.'contact.mu_k']\ndistribution = 'uniform'\nlow = 0.3\nhigh = 0.2\n",
        "low = 0.3 >= high = 0.2: an impossible uniform distribution",
    ),
    (
        "samples = 4\nseed = 1\ninput = 'ring26x60'\n"
        "[parameters.'contact.mu_k']\ndistribution = 'uniform'\nlow = -0.1\nhigh = 0.2\n",
        "reaches outside the key's range (>= 0)",
    ),
    (
        "samples = 4\nseed = 1\ninput = 'ring26x60'\n"
        "[parameters.'instrument.ei_scale']\ndistribution = 'lognormal'\nmedian = -1.0\n"
        "sigma = 0.1\n",
        "a lognormal distribution needs median > 0",
    ),
    (
        "samples = 4\nseed = 1\ninput = 'ring26x60'\nmethod = 'sobol'\n"
        "[parameters.'contact.mu_k']\ndistribution = 'grid'\nvalues = [0.1, 0.2]\n",
        "a grid cannot be part of a Sobol design",
    ),
    (
        "samples = 4\nseed = 1\ninput = 'ring26x60'\n"
        "[parameters.'motion.backward']\ndistribution = 'normal'\nmean = 0.2\nsd = 0.02\n",
        'is a flag: vary it with distribution = "grid"',
    ),
    (
        "samples = 0\nseed = 1\ninput = 'ring26x60'\n"
        "[parameters.'contact.mu_k']\ndistribution = 'normal'\nmean = 0.2\nsd = 0.02\n",
        "samples = 0: give a whole number of samples",
    ),
]


@pytest.mark.parametrize(("text", "expected"), BAD)
def test_bad_spec_one_line_exit_2_nothing_written(tmp_path, capsys, text, expected):
    """Each bad spec: exit 2, ONE line on stderr naming the spec file and the problem, and the
    --out folder is not created."""
    spec = tmp_path / "bad.toml"
    spec.write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    assert main(["sweep", str(spec), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert str(spec) in err and expected in err, err
    assert not out.exists()
    with pytest.raises(SweepSpecError):
        load_spec(spec)


def test_set_of_unknown_parameter_is_refused(small_spec):
    with pytest.raises(SweepSpecError, match=r"no parameter 'contact\.mu_q'"):
        load_spec(small_spec, {"parameters.contact.mu_q.sd": 0.1})


def test_unreachable_scheduler_one_line_exit_2(small_spec, tmp_path, capsys, monkeypatch):
    """Nothing listens on port 9 of localhost: exit 2, one line naming the address, no --out."""
    from ringqa.sweep import execute

    monkeypatch.setattr(execute, "CONNECT_TIMEOUT_S", 2)
    out = tmp_path / "out"
    code = main(
        ["sweep", str(small_spec), "--out", str(out), "--scheduler", "tcp://127.0.0.1:9", "--quiet"]
    )
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and "--scheduler tcp://127.0.0.1:9: cannot reach" in err
    assert not out.exists()
