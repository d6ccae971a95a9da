"""The lean loads of numba's cached kernels (``ringqa.cli._numba_loads``): the same machine code
and the same results as numba's own loader, without numba's lowering modules or
``scipy.linalg``'s package; a compile after them works as before."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: three cached kernels: a plain loop, np.dot (numba's helper library imports
#: scipy.linalg.cython_blas for BLAS ddot on its first call) and a parallel loop (its cached
#: code starts numba's threading layer when it is loaded, as tg43's rows_parallel does)
KERNELS = textwrap.dedent(
    """
    import numpy as np
    from numba import njit, prange

    @njit(cache=True, parallel=True)
    def squares(x):
        out = np.empty_like(x)
        for i in prange(x.shape[0]):
            out[i] = x[i] * x[i] + 1.0
        return out

    @njit(cache=True)
    def loop(x):
        s = 0.0
        for v in x:
            s += v * v
        return s

    @njit(cache=True)
    def dotted(a, b):
        return np.dot(a, b)
    """
)

#: what a process reports: the kernels' results (exact, as float.hex) and which modules it has
PROBE = textwrap.dedent(
    """
    import json, sys
    import numpy as np
    lean = sys.argv[1] == "lean"
    if lean:
        from ringqa.cli._numba_loads import lean_cache_loads
        assert lean_cache_loads()
    import kernels_for_test as k
    x = np.linspace(0.1, 2.3, 1001)
    y = np.sin(np.arange(1001.0))
    out = {"loop": float(k.loop(x)).hex(), "dot": float(k.dotted(x, y)).hex(),
           "squares": float(np.sum(k.squares(x))).hex()}
    out["hits"] = [sum(d.stats.cache_hits.values()) for d in (k.loop, k.dotted, k.squares)]
    out["arraymath"] = "numba.np.arraymath" in sys.modules
    out["scipy.linalg"] = "scipy.linalg" in sys.modules
    out["cython_blas"] = "scipy.linalg.cython_blas" in sys.modules
    if lean:  # a compile after lean loads: numba's full set-up, then the usual compile
        from numba import njit
        out["compiled"] = njit(lambda v: np.sum(v) + 1.0)(np.ones(3))
        out["arraymath after compile"] = "numba.np.arraymath" in sys.modules
    print(json.dumps(out))
    """
)


def _probe(tmp_path: Path, mode: str) -> dict:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), str(ROOT), env.get("PYTHONPATH", "")])
    env.pop("RINGQA_LEAN_NUMBA", None)
    proc = subprocess.run([sys.executable, "-c", PROBE, mode], capture_output=True, text=True,
                          env=env, cwd=tmp_path, timeout=300)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.mark.slow  # compiles np.dot and a parallel loop into an empty cache: about 9 s of CPU
def test_lean_loads_same_results_fewer_modules(tmp_path):
    """A first process compiles the kernels into the cache (numba's own set-up: its lowering
    modules and scipy.linalg are imported). A second process with the lean loads gets each from
    the cache (a cache hit each), computes bit for bit the same sum, BLAS dot product and
    parallel loop, and has imported neither ``numba.np.arraymath`` nor ``scipy.linalg`` - only
    the BLAS extension module itself; a function compiled afterwards in that process works
    (1 + 1 + 1 + 1 = 4.0) and brings numba's full set-up in."""
    (tmp_path / "kernels_for_test.py").write_text(KERNELS)
    full = _probe(tmp_path, "full")
    assert full["arraymath"] and full["scipy.linalg"]
    lean = _probe(tmp_path, "lean")
    assert lean["hits"] == [1, 1, 1]
    keys = ("loop", "dot", "squares")
    assert [lean[k] for k in keys] == [full[k] for k in keys]
    assert not lean["arraymath"] and not lean["scipy.linalg"] and lean["cython_blas"]
    assert lean["compiled"] == 4.0
    assert lean["arraymath after compile"]
    # and numba's own loader in a third process still gives the same numbers from the cache
    again = _probe(tmp_path, "full")
    assert again["hits"] == [1, 1, 1] and [again[k] for k in keys] == [full[k] for k in keys]


def test_switched_off_by_environment(monkeypatch):
    """``RINGQA_LEAN_NUMBA=0`` leaves numba's loader as it is."""
    from ringqa.cli import _numba_loads

    monkeypatch.setenv(_numba_loads.ENV, "0")
    assert _numba_loads.lean_cache_loads() is False


def test_only_the_checked_numba_releases():
    """The lean loader is installed only on numba releases it was checked on (0.68.x, the
    clinical pin): 0.68.1 and 0.68.0 yes; 0.69.0, 0.59.1, 1.0.0 and a malformed version no.
    The installed numba (0.68.1 in constraints/clinical.txt) counts as checked."""
    from ringqa.cli._numba_loads import numba_checked

    assert numba_checked("0.68.1") and numba_checked("0.68.0")
    assert not any(numba_checked(v) for v in ("0.69.0", "0.59.1", "1.0.0", "dev"))
    assert numba_checked()


@pytest.mark.parametrize("config_file", [False, True])
def test_numba_imported_without_yaml_unless_its_config_file_is_there(tmp_path, config_file):
    """With the hook (the ``ringqa`` script's), numba is imported without PyYAML when the
    working folder has no ``.numba_config.yaml`` (numba reads only that file with it), and
    PyYAML is importable afterwards as usual; with the file there numba reads it as before
    (``.numba_config.yaml`` setting ``developer_mode: 1`` shows as
    ``numba.config.DEVELOPER_MODE == 1``)."""
    if config_file:
        (tmp_path / ".numba_config.yaml").write_text("developer_mode: 1\n", encoding="utf-8")
    code = textwrap.dedent(
        """
        import sys
        from ringqa.cli._numba_loads import numba_config_without_yaml
        assert numba_config_without_yaml()
        import numba
        print("YAML", "yaml" in sys.modules, numba.core.config._HAVE_YAML,
              int(numba.config.DEVELOPER_MODE))
        import yaml
        print("LATER", yaml.safe_load("a: 1") == {"a": 1})
        """
    )
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_DEVELOPER_MODE"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=tmp_path, env=env, timeout=120)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    lines = [x.split() for x in proc.stdout.splitlines()]
    if config_file:
        assert lines[0] == ["YAML", "True", "True", "1"]
    else:
        assert lines[0][:3] == ["YAML", "False", "False"]
    assert lines[1] == ["LATER", "True"]


#: a process that loads KERNELS' plain loop from the cache with the lean loads and compares the
#: JIT engine's lazy answers with numba's own walk of every module added
SYMBOLS_PROBE = textwrap.dedent(
    """
    import json, sys
    import numpy as np
    from ringqa.cli._numba_loads import lean_cache_loads
    assert lean_cache_loads()
    import kernels_for_test as k
    k.loop(np.ones(4))
    from numba.core import codegen
    engine = k.loop.targetctx.codegen()._engine
    modules = [d.module for d in engine.__dict__["_ringqa_modules"]]
    eager, names = set(), set()
    for mod in modules:  # numba's own JitEngine._load_defined_symbols
        for gsets in (mod.functions, mod.global_variables):
            for gv in gsets:
                names.add(gv.name)
                if not gv.is_declaration:
                    eager.add(gv.name)
    fresh = codegen.JitEngine.__new__(codegen.JitEngine)
    fresh._defined_symbols = set()
    fresh.__dict__["_ringqa_modules"] = list(engine.__dict__["_ringqa_modules"])
    lazy = {n for n in names if fresh.is_symbol_defined(n)}
    print(json.dumps({"modules": len(modules), "names": len(names), "eager": len(eager),
                      "same": lazy == eager, "unknown": fresh.is_symbol_defined("no_such_fn"),
                      "hits": sum(k.loop.stats.cache_hits.values())}))
    """
)


def test_lazy_defined_symbols_answer_as_numbas_walk(tmp_path):
    """After a kernel is loaded from the cache with the lean loads, the JIT engine's lazy
    ``is_symbol_defined`` says yes for exactly the names numba's own walk of the modules
    collects (every function and global not only declared), no for a name none defines."""
    (tmp_path / "kernels_for_test.py").write_text(KERNELS)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), str(ROOT), env.get("PYTHONPATH", "")])
    env.pop("RINGQA_LEAN_NUMBA", None)
    warm = "import numpy as np, kernels_for_test as k; k.loop(np.ones(4))"
    for code in (warm, SYMBOLS_PROBE):  # compile into the cache, then load from it
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              env=env, cwd=tmp_path, timeout=300)  # fmt: skip
        assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["hits"] == 1 and out["modules"] >= 1
    assert out["eager"] > 0 and out["names"] > out["eager"]  # declarations are left out
    assert out["same"] and out["unknown"] is False
