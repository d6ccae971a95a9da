"""Load numba's cached kernels without numba's compiler set-up (a warm command's start-up).

numba's cache loader (``numba.core.caching.Cache.load_overload``) begins every load with
``target_context.refresh()``: the first one imports every lowering module numba has
(``numba.cpython.*``, ``numba.np.*``, ``numba.typed.*`` ...; ``numba.np.arraymath`` imports
``scipy.linalg`` whole for its BLAS check) and installs their registries. A *compile* needs that;
loading machine code from the cache does not: the loaded code needs numba's runtime (NRT: its
allocator and reference counting, ``rtsys.initialize``) and the helper C symbols, which numba
installs when its CPU target is made. The refresh is 0.25-0.4 s of CPU in a warm ``ringqa
commission`` (about 0.2 s the lowering modules, 0.15 s ``scipy.linalg``, measured under load;
docs/speed.md), paid once per process on the first kernel loaded, on the command's critical
path.

:func:`lean_cache_loads` replaces the loader with one that initialises the runtime and loads;
where the cache has no entry (a compile follows) it makes numba's full refresh first, so a
compile runs exactly as before (numba's compiler refreshes both contexts itself as well). The
loaded machine code is the same bytes either way; only what is imported beside it differs.

The kernels that call ``np.dot`` (the engine's compiled load-step loop) reach BLAS through
numba's helper library, which imports ``scipy.linalg.cython_blas`` on the first call for the
function pointers; importing that module the usual way runs ``scipy.linalg``'s ``__init__``
(0.15 s: scipy's array-API layer, ``numpy.f2py``, ``numpy.testing``). :func:`lean_cache_loads`
loads the extension module itself under its full name instead (3-4 ms), so the helper finds it
in ``sys.modules``; a later ``import scipy.linalg`` works as usual.

Only the command line installs it (:func:`ringqa.cli._jit_notice`, for the commands that run
kernels), for the process and the processes it forks; ``RINGQA_LEAN_NUMBA=0`` leaves numba as it
is. It is installed only for the numba releases it was checked on (:data:`CHECKED_NUMBA`),
where numba has the loader's parts this relies on, and not where
numba's BLAS/LAPACK integer width would not match scipy's (numba's own check, which its full
set-up makes, then refuses as before).
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import importlib.util
import os
import sys
from pathlib import Path

#: the environment variable that switches the lean loads off (``0``)
ENV = "RINGQA_LEAN_NUMBA"

#: the numba releases (major, minor) whose cache loader this was written against and checked on
#: (tests/cli/test_numba_loads.py; constraints/clinical.txt pins 0.68.1): any other numba is
#: left as it is, whatever attributes it has
CHECKED_NUMBA = ((0, 68),)

#: the BLAS module numba's helper library imports for ``np.dot`` in compiled code
CYTHON_BLAS = "scipy.linalg.cython_blas"


def lean_cache_loads() -> bool:
    """Install the lean cache loader (once per process); whether it is in place."""
    if os.environ.get(ENV, "1") == "0":
        return False
    if not numba_checked():
        return False
    try:
        from numba.core import caching
        from numba.core.runtime import rtsys
    except ImportError:  # pragma: no cover - a numba without these parts: as it is
        return False
    cache = caching.Cache
    if getattr(cache.load_overload, "ringqa_lean", False):
        return True
    parts = ("_guard_against_spurious_io_errors", "_load_overload")
    if not all(hasattr(cache, p) for p in parts) or not hasattr(rtsys, "initialize"):
        return False  # pragma: no cover - another numba: as it is
    if not _blas_width_matches():
        return False  # pragma: no cover - numba's full set-up refuses it

    def load_overload(self, sig, target_context):
        rtsys.initialize(target_context)  # the runtime the loaded code calls (once)
        with self._guard_against_spurious_io_errors():
            data = self._load_overload(sig, target_context)
        if data is None:  # not in the cache: numba compiles next, after its full set-up
            target_context.refresh()
        return data

    load_overload.ringqa_lean = True
    load_overload.__doc__ = cache.load_overload.__doc__
    cache.load_overload = load_overload
    preload_cython_blas()
    lazy_defined_symbols()
    return True


class _Defined:
    """What one LLVM module defines, looked up when asked: a function by name (LLVM's own
    lookup), the global variables (few; LLVM's lookup by name skips private ones, which
    numba's walk counts) listed once when first needed."""

    def __init__(self, module) -> None:
        self.module = module
        self.globals: set[str] | None = None

    def __contains__(self, name: str) -> bool:
        try:
            fn = self.module.get_function(name)
        except NameError:
            pass
        else:
            if not fn.is_declaration:
                return True
        if self.globals is None:
            self.globals = {g.name for g in self.module.global_variables if not g.is_declaration}
        return name in self.globals


def lazy_defined_symbols() -> bool:
    """numba's JIT engine told which symbols a module defines when asked, not by listing them
    all when the module is added (whether it is in place).

    ``JitEngine`` keeps the set of every symbol its modules define, for
    ``is_symbol_defined`` (asked for a kernel's entry point when it is loaded, and at a
    compile); it builds the set by walking every function and global of each module added:
    the shared module a cached kernel carries holds every function inlined into it, and each
    name and declaration flag is a call through llvmlite's lock. For the example's 24 cached
    kernels that walk was 0.035 s of CPU and about half of their loading in the profile
    (docs/speed.md, 2026-11-29). Here the modules are kept, and ``is_symbol_defined(name)``
    looks ``name`` up in them, newest first (the set is only added to, never read otherwise,
    and numba never removes a module), remembering each name found: the same answers."""
    try:
        from numba.core.codegen import JitEngine
    except ImportError:  # pragma: no cover - another numba: as it is
        return False
    if getattr(JitEngine._load_defined_symbols, "ringqa_lean", False):
        return True
    if not hasattr(JitEngine, "is_symbol_defined"):
        return False  # pragma: no cover - another numba: as it is

    def _load_defined_symbols(self, mod):
        self.__dict__.setdefault("_ringqa_modules", []).append(_Defined(mod))

    def is_symbol_defined(self, name):
        if name in self._defined_symbols:
            return True
        for defined in reversed(self.__dict__.get("_ringqa_modules", ())):
            if name in defined:
                self._defined_symbols.add(name)
                return True
        return False

    _load_defined_symbols.ringqa_lean = True
    is_symbol_defined.__doc__ = JitEngine.is_symbol_defined.__doc__
    JitEngine._load_defined_symbols = _load_defined_symbols
    JitEngine.is_symbol_defined = is_symbol_defined
    return True


def numba_checked(version: str | None = None) -> bool:
    """The installed numba (or ``version``) is a release in :data:`CHECKED_NUMBA`."""
    if version is None:
        from numba import __version__ as version  # lean_cache_loads imports numba next anyway
    parts = version.split(".")
    try:
        return (int(parts[0]), int(parts[1])) in CHECKED_NUMBA
    except (IndexError, ValueError):
        return False


def _blas_width_matches() -> bool:
    """numba's BLAS/LAPACK wrappers were built for the integer width scipy provides (what
    ``numba.np.linalg._check_lapack_int_width`` checks where numba has it; True where numba
    does not record its width)."""
    from numba import _helperlib

    built = bool(getattr(_helperlib, "LAPACK_BUILD_ILP64", False))
    try:
        from scipy.__config__ import CONFIG

        found = bool(CONFIG["Build Dependencies"]["blas"]["cython blas ilp64"])
    except (ImportError, KeyError, TypeError):
        found = False
    return built == found


def preload_cython_blas() -> bool:
    """Load ``scipy.linalg.cython_blas`` (an extension module) without ``scipy.linalg``'s
    package ``__init__``; whether it is in ``sys.modules`` now. Left to the usual import where
    ``scipy.linalg`` is imported already or the extension is not found."""
    if CYTHON_BLAS in sys.modules or "scipy.linalg" in sys.modules:
        return CYTHON_BLAS in sys.modules
    spec = importlib.util.find_spec("scipy")
    if spec is None or not spec.submodule_search_locations:
        return False  # pragma: no cover - numba's np.dot needs scipy: numba says so
    folder = Path(next(iter(spec.submodule_search_locations))) / "linalg"
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        path = folder / f"cython_blas{suffix}"
        if path.is_file():
            break
    else:
        return False  # pragma: no cover - another scipy layout: the usual import
    module_spec = importlib.util.spec_from_file_location(CYTHON_BLAS, path)
    if module_spec is None or module_spec.loader is None:
        return False  # pragma: no cover
    module = importlib.util.module_from_spec(module_spec)
    sys.modules[CYTHON_BLAS] = module
    try:
        module_spec.loader.exec_module(module)
    except Exception:  # pragma: no cover - left to the usual import
        del sys.modules[CYTHON_BLAS]
        return False
    return True


#: numba's configuration file, read from the working folder when numba is imported
NUMBA_CONFIG_FILE = ".numba_config.yaml"


class _ConfigHook(importlib.abc.MetaPathFinder):
    """Finds ``numba.core.config`` as the path finder does; while it executes, ``yaml`` is
    missing for it (see :func:`numba_config_without_yaml`)."""

    def find_spec(self, name, path, target=None):
        if name != "numba.core.config":
            return None
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec  # pragma: no cover - another layout: as it is
        real = spec.loader.exec_module

        def exec_module(module):
            blocked = "yaml" not in sys.modules and not os.path.isfile(NUMBA_CONFIG_FILE)
            if blocked:
                sys.modules["yaml"] = None  # "import yaml" raises ImportError: numba goes on
            try:
                real(module)
            finally:
                if blocked and sys.modules.get("yaml", 0) is None:
                    del sys.modules["yaml"]

        spec.loader.exec_module = exec_module
        return spec


def numba_config_without_yaml() -> bool:
    """Import numba without importing a YAML parser for a configuration file that is not there.

    ``numba.core.config`` imports ``yaml`` (PyYAML) when numba is imported, only to read
    :data:`NUMBA_CONFIG_FILE` from the working folder where there is one: 0.015-0.02 s of CPU
    of every command's start-up before it forks (docs/speed.md, 2026-11-29). Installed by the
    ``ringqa`` script before numba is imported; where the file exists, or PyYAML is imported
    already, numba is imported as usual, and ``yaml`` is importable as usual afterwards (only
    numba's configuration module saw it missing). ``RINGQA_LEAN_NUMBA=0`` leaves numba as it is.
    Returns whether the hook is in place."""
    if os.environ.get(ENV, "1") == "0" or "numba.core.config" in sys.modules:
        return False
    if not any(isinstance(f, _ConfigHook) for f in sys.meta_path):
        sys.meta_path.insert(0, _ConfigHook())
    return True
