"""The compile notice (ringqa/cli/_jit.py) and ``ringqa warmup``."""

from __future__ import annotations

import io

from numba import njit

from ringqa.cli import main
from ringqa.cli._jit import compile_notice, kernel_label


def test_notice_printed_on_a_compile_and_silent_when_compiled():
    """A kernel compiled inside the block: the notice and one progress line naming it; the same
    kernel called again (compiled: what a warm cache looks like to numba's compile event): no
    output at all."""

    @njit(cache=False)
    def twice(x):
        return 2.0 * x

    out = io.StringIO()
    with compile_notice(out) as lis:
        assert twice(1.5) == 3.0
    text = out.getvalue()
    assert "compiling the numerical kernels once" in text
    assert "later runs" in text
    assert [label for label, _ in lis.compiled] == [f"{__name__}: twice"]
    assert text.count("compiled ") == 1

    out2 = io.StringIO()
    with compile_notice(out2) as lis2:
        assert twice(2.5) == 5.0
    assert out2.getvalue() == ""
    assert lis2.compiled == []


def test_kernel_label_names_the_effects_of_newton():
    """Newton's specialisation is named by the effects in its args tuple (each once, in order),
    other kernels by group and function."""

    class Disp:
        def __init__(self, fn):
            self.py_func = fn

    def newton():  # stands in for ringqa.simulation.solvers.newton.newton
        pass

    newton.__module__ = "ringqa.simulation.solvers.newton"
    args = "(Tuple((AxialArgs(array), ContactArgs(ChannelArgs(float64)), TetherArgs(f))), q)"
    assert kernel_label(Disp(newton), args) == "simulation: newton (axial, contact, tether)"

    def rows():
        pass

    rows.__module__ = "tg43._kernels"
    assert kernel_label(Disp(rows), "(int64,)") == "TG-43 dose: rows"


def test_warmup_command(capsys, monkeypatch):
    """``ringqa warmup`` runs the commissioning scene of both cable presets commission picks
    (Flexitron, microSelectron) and says so on stdout; it also runs commission's cross-check
    scene once through the flexible engine (whose kernels a first commission would otherwise
    compile: ~20 s of CPU), and afterwards that engine's Newton kernel has a cached
    signature. It writes the package's bytecode (:func:`write_bytecode`, tested on its own
    below; here a stand-in, so that the test leaves the checkout's ``__pycache__`` alone)."""
    import ringqa.cli._precompile as precompile
    import ringqa.simulation.flexible as flexible
    from ringqa.simulation.flexible import kernels

    seen = []
    real = flexible.run_flexible

    def spy(scene, advances_m, progress=False):
        seen.append(scene.model.formulation)
        return real(scene, advances_m, progress)

    monkeypatch.setattr(flexible, "run_flexible", spy)
    wrote = []
    monkeypatch.setattr(precompile, "write_bytecode", lambda folders=None: wrote.append(folders))
    assert main(["warmup"]) == 0
    out = capsys.readouterr().out
    assert "flexitron, microselectron cables" in out
    assert seen == ["flexible"]
    assert kernels.newton.signatures
    assert wrote == [None]  # every package of this distribution


#: a fresh interpreter that never writes bytecode imports ``probe_pkg.mod`` and prints how many
#: modules it compiled from source
_COUNT_COMPILES = """
import importlib._bootstrap_external as be, sys
n = []
real = be.SourceLoader.source_to_code
be.SourceLoader.source_to_code = lambda self, *a, **k: n.append(1) or real(self, *a, **k)
sys.path.insert(0, sys.argv[1])
import probe_pkg.mod
assert probe_pkg.mod.VALUE == 42
print(len(n))
"""


def test_write_bytecode_spares_later_runs_the_compile(tmp_path):
    """Under ``PYTHONDONTWRITEBYTECODE=1`` Python compiles a module without bytecode from source
    on every import (2 modules: the package and its module, each run); after
    :func:`write_bytecode` of the package's folder it compiles none (it reads the ``.pyc``
    files), and a second call leaves the written files as they are. A folder that does not
    exist raises nothing."""
    import subprocess
    import sys
    from importlib.util import cache_from_source
    from pathlib import Path

    from ringqa.cli._precompile import write_bytecode

    pkg = tmp_path / "probe_pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "mod.py").write_text("VALUE = 41 + 1\n")
    env = {"PYTHONDONTWRITEBYTECODE": "1", "PATH": ""}
    if sys.pycache_prefix:  # where this process writes bytecode, the child reads it
        env["PYTHONPYCACHEPREFIX"] = sys.pycache_prefix

    def compiles() -> int:
        cmd = [sys.executable, "-c", _COUNT_COMPILES, str(tmp_path)]
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=60)
        assert proc.returncode == 0, proc.stderr
        return int(proc.stdout)

    assert compiles() == 2
    assert compiles() == 2  # nothing was written by the first run
    write_bytecode([pkg])
    pycs = [Path(cache_from_source(str(pkg / f))) for f in ("__init__.py", "mod.py")]
    assert all(p.is_file() for p in pycs)
    stamps = [p.stat().st_mtime_ns for p in pycs]
    assert compiles() == 0
    write_bytecode([pkg])
    assert [p.stat().st_mtime_ns for p in pycs] == stamps
    write_bytecode([tmp_path / "no-such-folder"])


def test_precompile_leaves_match_the_kernels():
    """Every leaf the compile helper compiles exists and its signature has one type per
    parameter of the kernel (a kernel that gains or loses a parameter must update LEAVES, or the
    helper would compile a signature no run asks for); codes map to C-contiguous arrays."""
    import inspect

    from numba import types

    from ringqa.cli._precompile import LEAVES, leaf, numba_types

    for module, name, codes in LEAVES:
        fn = leaf(module, name).py_func
        assert len(inspect.signature(fn).parameters) == len(codes), name
    assert numba_types(("f2", "i1", "b1")) == (
        types.float64[:, ::1],
        types.int64[::1],
        types.boolean,
    )


def test_no_helper_on_a_warm_cache(monkeypatch):
    """The helper starts only on an empty cache: with Newton's cache index present (this test
    session has run the engine) or RINGQA_NO_PRECOMPILE set, start_helper starts nothing.
    The engine is run here on the example's first dwell with the commissioning settings (the
    kernels every commissioning test uses: loaded, or compiled once for all of them), not with
    ``warm_up()``, whose every-effect-on kernels no other test needs (~40 s of compiling)."""
    from ringqa.cli._precompile import start_helper
    from ringqa.datasets import example_plan
    from ringqa.pipeline.dwells import reference_dwells
    from ringqa.pipeline.inputs import load_input
    from ringqa.pipeline.simulate import simulate_dwells

    app = load_input(example_plan()).applicator
    ring = app.channel("ring")
    first = reference_dwells(app, ring, 5.0).relative_position_mm[:1]
    simulate_dwells(app, ring, first, cable="microselectron", scene_overrides={}, stem_mm=60.0,
                    cross_check=False, stem_check=False)  # fmt: skip
    assert start_helper() is None
    monkeypatch.setenv("RINGQA_NO_PRECOMPILE", "1")
    assert start_helper() is None
