"""The folders show the architecture: data flows one way, tg43 stands alone.

Every ``import`` in the package sources is read with ``ast`` (no code is run) and checked
against the layer order written in DEVELOPERS.md:

    foundations (units, errors, paths, provenance, outdir)
      -> geometry -> io -> simulation -> plan -> accuracy -> pipeline -> report -> needle -> cli

A module may import its own layer and layers to its left, never to its right; ``tg43`` never
imports ``ringqa``. ``needle`` (the needle-insertion study) sits beside the pipeline: it uses
only the foundations, geometry, simulation and report, and only the cli imports it. The test
fails with the offending file and import.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ["foundations", "geometry", "io", "simulation", "plan", "accuracy", "pipeline", "report",
          "needle", "cli"]  # fmt: skip
#: what ringqa.needle may import (besides itself): it sits beside the pipeline
NEEDLE_USES = {"foundations", "geometry", "simulation", "report", "needle"}
FOUNDATIONS = {"units", "errors", "paths", "provenance", "outdir", "__init__", "__main__"}


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


@pytest.mark.parametrize("package", ["ringqa", "tg43"])
def test_packages_import_without_side_effects(package, capsys):
    """Importing prints nothing and compiles nothing (numba kernels compile on first use)."""
    import importlib
    import sys

    before = set(sys.modules)
    importlib.import_module(package)
    assert capsys.readouterr().out == ""
    assert "matplotlib.pyplot" not in set(sys.modules) - before
