"""Several applicators of one cable: shared cable keys, each applicator's own lumen (issue 26).

Synthetic clinic: ring26x60 and ring30x60 pushed with one Flexitron cable (mu_k 0.15, mu_s 0.19,
EI x 1.25) but lumens that differ from the nominal by +0.15 mm and -0.10 mm of diameter (two
rings machined differently), each measured at the 9 film positions. One shared lumen change
cannot fit both (they move the dwells outwards and inwards); the fit gives each ring its own
``lumen.diameter_delta_mm@LABEL`` and one mu_k.

Without noise the fit must return the truth to the accuracy the fit stops at (xtol 1e-4 in
theta, Jacobian steps 0.05 mm: measured 0.0033 / 0.0033 mm and mu_k 0.1498), so 0.01 mm and
2 %. With 0.2 mm noise each value must lie within 3 of its own standard errors (seed 1:
0.2506 +- 0.071, -0.1042 +- 0.076, mu_k 0.1398 +- 0.0115).
"""

from __future__ import annotations

import pytest

from ringqa.calibration.output import applicator_use, cable_toml, calibration_dict
from ringqa.calibration.run import calibrate
from tests.calibration.conftest import STEM_MM, TRUTH, synthetic

pytestmark = pytest.mark.slow

DELTA = {"ring26x60": 0.15, "ring30x60": -0.10}
KEYS = ("contact.mu_k", "lumen.diameter_delta_mm")


def _measured(noise_mm, seed):
    return [
        synthetic(name, truth={**TRUTH, "lumen.diameter_delta_mm": d}, noise_mm=noise_mm,
                  seed=seed + k)
        for k, (name, d) in enumerate(DELTA.items())
    ]  # fmt: skip


def test_each_applicator_gets_its_own_lumen_noise_free():
    cal = calibrate(_measured(0.0, 1), keys=KEYS, stem_mm=STEM_MM, leave_one_out=False)
    f = cal.fit
    assert f.keys == ("contact.mu_k", *(f"lumen.diameter_delta_mm@{n}" for n in DELTA))
    assert f.values["contact.mu_k"] == pytest.approx(0.15, rel=0.02)
    for name, d in DELTA.items():
        assert f.values[f"lumen.diameter_delta_mm@{name}"] == pytest.approx(d, abs=0.01)
    data = calibration_dict(cal)
    assert set(data["parameters"]) == {"contact.mu_k"}
    assert data["per_applicator_keys"] == ["lumen.diameter_delta_mm"]
    for app in data["applicators"]:
        own = app["parameters"]["lumen.diameter_delta_mm"]
        assert own["value"] == pytest.approx(DELTA[app["applicator"]], abs=0.01)
        assert app["use"] == applicator_use(cal, app["applicator"])
        assert f"--set lumen.diameter_delta_mm={own['value']:.6g}" in app["use"]
    toml = cable_toml(cal)
    assert "lumen.diameter_delta_mm =" not in toml.split("[scene]")[1]  # not the cable's
    assert all(f"# {n}: its own fitted lumen" in toml for n in DELTA)


def test_each_applicator_gets_its_own_lumen_with_noise():
    cal = calibrate(_measured(0.2, 1), keys=KEYS, stem_mm=STEM_MM, leave_one_out=False)
    f = cal.fit
    truth = {"contact.mu_k": 0.15, **{f"lumen.diameter_delta_mm@{n}": d for n, d in DELTA.items()}}
    for k, v in truth.items():
        assert f.identifiable[k], k
        assert abs(f.values[k] - v) <= 3 * f.se[k], (k, f.values[k], f.se[k])
