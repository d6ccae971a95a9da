"""The folders show the architecture: data flows one way, tg43 stands alone.

Every ``import`` in the package sources is read with ``ast`` (no code is run) and checked
against the layer order written in DEVELOPERS.md:

    foundations (units, errors, paths, provenance, outdir, jsonio, datasets, parallel)
      -> geometry -> io -> simulation -> plan -> accuracy -> pipeline -> report -> needle
      -> config -> cli

A module may import its own layer and layers to its left, never to its right; ``tg43`` never
imports ``ringqa``. ``needle`` (the needle-insertion study) sits beside the pipeline: it uses
only the foundations, geometry, simulation and report, and only the cli imports it. The test
fails with the offending file and import.

Private names (the rule of :func:`test_no_private_imports`): a leading underscore means "this
module only" for a name and "this package only" for a module.

- A module never imports another module's private name (``from ringqa.x import _helper``):
  whatever a second module needs is public, with a docstring (the pipeline's and the accuracy
  study's steps hand each other public functions and dataclasses).
- A private module (``_kernels.py``, ``cli/_options.py``) is imported only from inside its own
  top-level package (``ringqa.simulation.solvers`` may use ``ringqa.simulation._kernels``; the
  pipeline may not).
- Dunder names (``__version__``) are public.

Known exceptions are listed in :data:`PRIVATE_IMPORT_EXCEPTIONS` with their reason; the test also
fails when an exception is no longer needed, so the list only shrinks.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ["foundations", "geometry", "io", "simulation", "plan", "accuracy", "pipeline", "report",
          "sweep", "calibration", "needle", "config", "cli"]  # fmt: skip
#: what ringqa.needle may import (besides itself): it sits beside the pipeline
NEEDLE_USES = {"foundations", "geometry", "simulation", "report", "needle"}
#: (source file or folder, imported name) -> why it is still allowed. Delete entries as they go.
PRIVATE_IMPORT_EXCEPTIONS: dict[tuple[str, str], str] = {}

FOUNDATIONS = {"units", "errors", "paths", "provenance", "outdir", "jsonio", "textio", "datasets",
               "progress", "parallel", "__init__", "__main__"}  # fmt: skip


def _layer(module: str) -> int | None:
    parts = module.split(".")
    if parts[0] != "ringqa" or len(parts) == 1:
        return 0 if parts == ["ringqa"] else None
    head = parts[1]
    if head in FOUNDATIONS:
        return 0
    return LAYERS.index(head) if head in LAYERS else None


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    return ".".join(rel.parts)


def _imports(path: Path):
    tree = ast.parse(path.read_text(), filename=str(path))
    package = _module_name(path).rsplit(".", 1)[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                yield node.lineno, ".".join([*base, node.module or ""]).rstrip(".")
            elif node.module:
                yield node.lineno, node.module


def _sources(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


def test_tg43_never_imports_ringqa():
    bad = [
        f"{p.relative_to(ROOT)}:{line} imports {mod}"
        for p in _sources("tg43")
        for line, mod in _imports(p)
        if mod == "ringqa" or mod.startswith("ringqa.")
    ]
    assert not bad, "tg43 must stand alone:\n" + "\n".join(bad)


def test_ringqa_imports_only_leftwards():
    bad = []
    for path in _sources("ringqa"):
        if path.name == "__main__.py" or "_data" in path.parts:
            continue
        own = _layer(_module_name(path))
        if own is None:
            continue
        for line, mod in _imports(path):
            other = _layer(mod)
            if other is not None and other > own:
                where = f"{path.relative_to(ROOT)}:{line}"
                bad.append(f"{where} ({LAYERS[own]}) imports {mod} ({LAYERS[other]})")
    assert not bad, "imports against the data flow:\n" + "\n".join(bad)


def test_needle_sits_beside_the_pipeline():
    """ringqa.needle imports only foundations, geometry, simulation and report (not io, plan,
    accuracy or pipeline), and nothing but the cli imports it."""
    bad = []
    for path in _sources("ringqa"):
        own = _module_name(path)
        for line, mod in _imports(path):
            layer = _layer(mod)
            if layer is None:
                continue
            where = f"{path.relative_to(ROOT)}:{line}"
            if own.startswith("ringqa.needle") and LAYERS[layer] not in NEEDLE_USES:
                bad.append(f"{where} imports {mod} ({LAYERS[layer]})")
            if LAYERS[layer] == "needle" and not own.startswith(("ringqa.needle", "ringqa.cli")):
                bad.append(f"{where} imports {mod}: only the cli may use ringqa.needle")
    assert not bad, "ringqa.needle out of place:\n" + "\n".join(bad)


def _is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _private_imports(path: Path):
    """(line, module, name) of every import of a private name or a private module of ringqa."""
    tree = ast.parse(path.read_text(), filename=str(path))
    me = _module_name(path)
    package = me if path.name == "__init__.py" else me.rsplit(".", 1)[0]
    package = package.removesuffix(".__init__")
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                module = ".".join([*base, node.module or ""]).rstrip(".")
            else:
                module = node.module or ""
            if module.split(".")[0] != "ringqa":
                continue
            for alias in node.names:
                yield node.lineno, module, alias.name
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "ringqa":
                    yield node.lineno, alias.name, ""


def _top_package(module: str) -> str:
    parts = module.split(".")
    return ".".join(parts[:2])


def test_no_private_imports():
    """No module imports another module's private name; a private module is used only inside its
    own top-level package (the rule in the module docstring)."""
    bad, used = [], set()
    for path in _sources("ringqa"):
        rel = str(path.relative_to(ROOT))
        me = _module_name(path)
        for line, module, name in _private_imports(path):
            parts = [*module.split("."), *([name] if name else [])]
            private_module = any(_is_private(p) for p in module.split(".")[1:])
            private_name = bool(name) and _is_private(name)
            # "from pkg import _mod" imports a private MODULE when pkg/_mod.py exists
            target = ROOT.joinpath(*parts)
            if private_name and (target.with_suffix(".py").is_file() or target.is_dir()):
                private_name, private_module = False, True
            problem = None
            if private_name:
                problem = f"imports the private name {name} from {module}"
            elif private_module and _top_package(module) != _top_package(me):
                problem = f"imports from the private module {'.'.join(parts)} of another package"
            if problem is None:
                continue
            key = next(
                (k for k in PRIVATE_IMPORT_EXCEPTIONS
                 if rel.startswith(k[0]) and k[1] in ("*", name)),
                None,
            )  # fmt: skip
            if key is not None:
                used.add(key)
                continue
            bad.append(f"{rel}:{line} {problem}")
    assert not bad, "private imports (make the name public, or keep it in its module):\n" + (
        "\n".join(bad)
    )
    stale = set(PRIVATE_IMPORT_EXCEPTIONS) - used
    assert not stale, f"exceptions no longer needed, delete them: {sorted(stale)}"


def test_private_import_check_catches_a_violation(tmp_path, monkeypatch):
    """The checker sees through relative imports: a module importing ``_helper`` from its
    sibling, and one importing a sibling's private module by a relative path."""
    pkg = tmp_path / "ringqa" / "pipeline"
    pkg.mkdir(parents=True)
    (pkg / "steps.py").write_text("from .dwells import _helper\nfrom ..geometry import _kernels\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    found = list(_private_imports(pkg / "steps.py"))
    assert found == [(1, "ringqa.pipeline.dwells", "_helper"), (2, "ringqa.geometry", "_kernels")]


@pytest.mark.parametrize("package", ["ringqa", "tg43"])
def test_packages_import_without_side_effects(package, capsys):
    """Importing prints nothing and compiles nothing (numba kernels compile on first use)."""
    import importlib
    import sys

    before = set(sys.modules)
    importlib.import_module(package)
    assert capsys.readouterr().out == ""
    assert "matplotlib.pyplot" not in set(sys.modules) - before


def _import_graph() -> dict[str, set[str]]:
    """module -> the ringqa modules it imports (every import, also inside functions).

    ``from pkg import name`` counts as an import of ``pkg.name`` when that is a module, else of
    ``pkg``; importing ``a.b.c`` is an edge to ``a.b.c`` only (not to its parent packages).
    """
    graph: dict[str, set[str]] = {}
    for path in _sources("ringqa"):
        if "_data" in path.parts:
            continue
        me = _module_name(path).removesuffix(".__init__")
        tree = ast.parse(path.read_text(), filename=str(path))
        package = me if path.name == "__init__.py" else me.rsplit(".", 1)[0]
        edges = graph.setdefault(me, set())
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[: len(package.split(".")) - node.level + 1]
                    module = ".".join([*base, node.module or ""]).rstrip(".")
                else:
                    module = node.module or ""
                mods = []
                for alias in node.names:
                    sub = ROOT.joinpath(*module.split("."), alias.name)
                    is_module = sub.with_suffix(".py").is_file() or sub.is_dir()
                    mods.append(f"{module}.{alias.name}" if is_module else module)
            else:
                continue
            edges.update(m for m in mods if m.split(".")[0] == "ringqa" and m != me)
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10000))
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_circle():
    """No two modules of ringqa import each other, directly or round a loop, not even from inside
    a function (the scene model used to import its file format back: scene.py <-> scenefile)."""
    cycles = _cycles(_import_graph())
    assert not cycles, "import circles:\n" + "\n".join(" -> ".join(c) for c in cycles)


def test_import_circle_check_catches_a_circle():
    """The checker finds a two-module loop and a three-module loop."""
    assert _cycles({"a": {"b"}, "b": {"a"}}) == [["a", "b"]]
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []
