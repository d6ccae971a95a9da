"""``ringqa.pipeline``'s public names are imported on first use (PEP 562), and are what they
were when the package imported them eagerly: every name is its module's object, and
``ringqa.pipeline.commission`` is the function even after the step module of that name is
imported."""

from __future__ import annotations

import importlib
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def test_every_public_name_is_its_modules_object():
    """Each name of ``EXPORTS`` (and so of ``__all__``) resolves to the very object its module
    defines, and is listed by ``dir()``."""
    import ringqa.pipeline as pipeline

    assert sorted(pipeline.__all__) == sorted(pipeline.EXPORTS)
    for name, module in pipeline.EXPORTS.items():
        assert getattr(pipeline, name) is getattr(importlib.import_module(module), name), name
        assert name in dir(pipeline)


def test_commission_is_the_function_after_its_module_is_imported():
    """In a fresh interpreter: the step module imported first, then the package's name ->
    still the function (as with the eager import), and the module stays in sys.modules."""
    code = (
        "import sys, types\n"
        "import ringqa.pipeline.commission\n"
        "from ringqa.pipeline import commission\n"
        "import ringqa.pipeline as p\n"
        "assert callable(commission) and not isinstance(commission, types.ModuleType)\n"
        "assert p.commission is commission\n"
        "m = sys.modules['ringqa.pipeline.commission']\n"
        "assert isinstance(m, types.ModuleType) and m.commission is commission\n"
        "print('ok')\n"
    )
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       check=False)  # fmt: skip
    assert p.returncode == 0 and p.stdout.strip() == "ok", p.stderr


def test_importing_one_step_does_not_import_the_batch():
    """``import ringqa.pipeline.numbers`` (the number formats, stdlib only) no longer imports
    every step with the package: no batch module, no pandas."""
    code = (
        "import sys\nimport ringqa.pipeline.numbers\n"
        "print(sorted(m for m in ('ringqa.pipeline.batch', 'pandas', 'numba') "
        "if m in sys.modules))\n"
    )
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       check=True)  # fmt: skip
    assert p.stdout.strip() == "[]"


def test_an_unknown_name_is_an_attribute_error():
    import ringqa.pipeline as pipeline

    with pytest.raises(AttributeError, match="no_such_name"):
        pipeline.no_such_name  # noqa: B018
    with pytest.raises(ImportError):
        from ringqa.pipeline import no_such_name  # noqa: F401
