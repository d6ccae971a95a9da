"""A real dask.distributed LocalCluster of PROCESSES, reached through its scheduler address as a
remote cluster would be: a small sweep runs, streams to samples.h5, resumes, and each sample's
numbers do not depend on the worker that ran it."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest

from ringqa.cli import main
from ringqa.sweep import load_spec
from ringqa.sweep.analysis import SUMMARY_COLUMNS
from ringqa.sweep.fast import cheap_sample
from ringqa.sweep.sampling import design
from ringqa.sweep.store import read_samples
from ringqa.sweep.study import job_of


def test_sweep_through_scheduler_address_resumes_and_is_worker_independent(
    local_cluster, tmp_path, spec_writer, capsys
):
    """3 samples, then the same command with samples=5: the second run computes only samples 3
    and 4 (resumed, the first three untouched). Sample 1 re-run here in the test process (one
    engine run at the commissioning settings, as the workers ran it) gives
    bit-identical positions to the worker's (the seed of a sample is (seed, i) only), and the
    outputs hold the contract columns."""
    spec = spec_writer(tmp_path, samples=3)
    out = tmp_path / "out"
    addr = local_cluster.scheduler_address
    assert main(["sweep", str(spec), "--out", str(out), "--scheduler", addr, "--quiet"]) == 0
    first = read_samples(out / "samples.h5")
    assert list(first.index) == [0, 1, 2] and first.ok.all()
    assert (
        main(
            [
                "sweep",
                str(spec),
                "--out",
                str(out),
                "--scheduler",
                addr,
                "--quiet",
                "--set",
                "samples=5",
            ]
        )
        == 0
    )
    assert "5 of 5 samples ok (0 failed, 2 computed now)" in capsys.readouterr().out
    s = read_samples(out / "samples.h5")
    assert list(s.index) == [0, 1, 2, 3, 4]
    with h5py.File(out / "samples.h5") as f:
        assert f["index"].shape == (5,)  # nothing recomputed or duplicated
    for k in ("x_mm", "deviation_mm", "dose_diff_pct"):
        np.testing.assert_array_equal(s.arrays[k][:3], first.arrays[k])
    # the workers are other processes than this one
    assert all(not w.endswith(f":{__import__('os').getpid()}") for w in s.worker)

    sp = load_spec(spec, {"samples": 5})
    rec = cheap_sample(job_of(sp), 1, design(sp)[1])  # the default numerics = "calibrated"
    np.testing.assert_array_equal(rec.positions_mm[:, 0], s.arrays["x_mm"][1])
    np.testing.assert_array_equal(rec.dwell["deviation_mm"], s.arrays["deviation_mm"][1])

    summ = pd.read_csv(out / "summary.csv")
    assert tuple(summ.columns) == SUMMARY_COLUMNS
    dev = summ[summ["quantity"] == "deviation_mm"]
    assert (dev["n_ok"] == 5).all() and (dev["n_failed"] == 0).all()
    assert (dev["p2_5"] <= dev["mean"]).all() and (dev["mean"] <= dev["p97_5"]).all()
    sens = pd.read_csv(out / "sensitivity.csv")
    assert set(sens["parameter"]) == set(sp.names)
    record = json.loads((out / "sweep.json").read_text())
    assert record["resumed_from"] == 3 and record["computed_now"] == 2
    assert record["seed"] == 11 and record["versions"]["distributed"]
    # calibrated numerics: the bound every sample reports is the calibration's (kept in the file
    # for the resumed run), the intervals say whether they are conditional on success
    check = record["numerical_check"]
    assert check["mode"] == "calibrated" and check["calibration_samples"][0] == -1
    np.testing.assert_array_equal(s.arrays["numerical_error_mm"][4], check["error_mm_per_dwell"])
    assert record["intervals"] == "every sample succeeded"
    assert record["failure_report"]["n_failed"] == 0 and record["sensitivity_note"] == ""
    assert (out / "uncertainty.png").stat().st_size > 10_000

    # --partial with samples=7: nothing runs (no scheduler needed), the outputs cover the 5
    # stored samples and say the sweep is partial
    capsys.readouterr()
    args = ["sweep", str(spec), "--out", str(out), "--quiet", "--partial", "--set", "samples=7"]
    assert main(args) == 0
    assert "5 of 7 samples ok (0 failed, 0 computed now)" in capsys.readouterr().out
    record = json.loads((out / "sweep.json").read_text())
    assert record["partial"] is True and record["n_ok"] == 5


@pytest.mark.slow
def test_full_numerics_bar_moves_per_sample(local_cluster, tmp_path, spec_writer, capsys,
                                            monkeypatch):  # fmt: skip
    """numerics = "full" with 3 samples in ONE task (batch_size = 3): the bar shows a count
    below 3/3 (1/3 or 2/3), which only the samples' ticks from the worker can produce (the
    stored task moves it 0 -> 3 at once), so it is not 0/3 until the task is done; then 3/3.
    (Not every count: the ticks are polled every 0.2 s and the last sample's tick can arrive
    after the task's result.) The nominal run is announced before it starts."""
    monkeypatch.setenv("RINGQA_PROGRESS_INTERVAL_S", "0")
    spec = spec_writer(tmp_path, samples=3)
    addr = local_cluster.scheduler_address
    args = ["sweep", str(spec), "--out", str(tmp_path / "out"), "--scheduler", addr,
            "--set", "numerics=full", "--set", "batch_size=3"]  # fmt: skip
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "ringqa sweep: the nominal run" in err
    assert "ringqa sweep: 1/3 sample" in err or "ringqa sweep: 2/3 sample" in err, err
    assert "ringqa sweep: 3/3 sample" in err, err


def test_a_different_spec_does_not_mix_into_finished_samples(
    local_cluster, tmp_path, spec_writer, capsys
):
    """Re-running into the folder with another seed is refused (one line, exit 2) and
    samples.h5 is unchanged."""
    spec = spec_writer(tmp_path, samples=2)
    out = tmp_path / "out"
    addr = local_cluster.scheduler_address
    assert main(["sweep", str(spec), "--out", str(out), "--scheduler", addr, "--quiet"]) == 0
    before = (out / "samples.h5").read_bytes()
    capsys.readouterr()
    code = main(
        ["sweep", str(spec), "--out", str(out), "--scheduler", addr, "--quiet", "--set", "seed=12"]
    )
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "different spec" in err
    assert (out / "samples.h5").read_bytes() == before


@pytest.mark.slow
def test_killing_a_worker_mid_sweep_loses_nothing(
    local_cluster, tmp_path, spec_writer, monkeypatch
):
    """SIGKILL one worker process right after the first batch was stored: Dask reruns the lost
    task on the other worker (its nanny restarts the killed one), every sample ends in
    samples.h5 exactly once, and the batch stored before the kill is kept."""
    import os
    import signal
    import threading

    from distributed import Client

    from ringqa.sweep import run_sweep
    from ringqa.sweep.store import SampleStore

    spec = load_spec(spec_writer(tmp_path, samples=8), {"batch_size": 1})
    out = tmp_path / "out"
    first_stored = threading.Event()
    original = SampleStore.append

    def append(self, records):
        original(self, records)
        first_stored.set()

    monkeypatch.setattr(SampleStore, "append", append)
    with Client(local_cluster.scheduler_address) as client:
        pids = list(client.run(os.getpid).values())
        result = {}
        t = threading.Thread(
            target=lambda: result.update(r=run_sweep(spec, out, client=client)), daemon=True
        )
        t.start()
        assert first_stored.wait(300)
        os.kill(pids[0], signal.SIGKILL)
        t.join(600)
    s = result["r"].samples
    assert list(s.index) == list(range(8)) and s.ok.all()


@pytest.mark.slow
def test_interrupted_sweep_resumes_without_recomputing(tmp_path, spec_writer):
    """A real ``ringqa sweep`` process stopped with SIGINT after its first samples exits
    130 and keeps samples.h5; the same command again computes only the samples not stored
    (computed now = 40 - stored), each index once. (40 cheap samples of ~0.1 s: with 6 the
    sweep finished before the signal came.)"""
    import os
    import re
    import signal
    import subprocess
    import sys

    n = 40
    spec = spec_writer(tmp_path, samples=n)
    out = tmp_path / "out"
    cmd = [
        sys.executable,
        "-m",
        "ringqa",
        "sweep",
        str(spec),
        "--out",
        str(out),
        "--workers",
        "1",
        "--set",
        "batch_size=1",
        "--set",
        "calibration_samples=2",
    ]
    # a progress line per sample into the pipe (not a terminal: plain lines, ringqa.progress)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2]),
           "RINGQA_PROGRESS_INTERVAL_S": "0"}  # fmt: skip
    # A shell starts background jobs with SIGINT ignored, a child inherits that, and ringqa
    # keeps an ignored signal ignored (as it should: nohup, `cmd &`): give the child the
    # interactive disposition, as a terminal's Ctrl-C finds it (with SIGINT ignored in the
    # test's own process the sweep ran all 40 samples and exited 0).
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.PIPE, env=env,
                            preexec_fn=_interactive_sigint)  # fmt: skip
    seen = b""
    # the bar moves per sample finished on the worker, a little ahead of samples.h5: wait
    # for 5 (the first tasks of one sample each are stored by then)
    while not re.search(rb"\b([5-9]|[1-2][0-9])/40", seen):
        ch = proc.stderr.read(1)
        assert ch, seen.decode(errors="replace")
        seen += ch
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, (seen + err).decode(errors="replace")
    stored = len(read_samples(out / "samples.h5").index)
    assert 1 <= stored < n
    done = subprocess.run([*cmd, "--quiet"], capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr
    assert f"{n} of {n} samples ok (0 failed, {n - stored} computed now)" in done.stdout
    assert list(read_samples(out / "samples.h5").index) == list(range(n))


def _interactive_sigint() -> None:
    """In the child before exec: SIGINT back to its default, which Python turns into
    KeyboardInterrupt."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)
