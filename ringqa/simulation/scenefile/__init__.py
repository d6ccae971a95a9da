"""Scene files: TOML in millimetres/degrees/seconds in, a validated SI :class:`Scene` out.

A scene file has the sections ``[channel]``, ``[instrument]``, ``[discretisation]``,
``[effects]``, ``[contact]``, ``[motion]``, ``[solver]`` and ``[outputs]`` (all optional except
the channel) plus top-level ``name`` and ``description``. Every key is described once, with its
unit, default and range, in :mod:`ringqa.simulation.scene_keys` (``data/scenes/README.md``'s keys
table is generated from it); this package converts with those descriptions, so it is the one
place where scene keys change units. Every error names the file, the dotted key and the fix.

The channel is either an applicator channel::

    [channel]
    applicator = "ring26x60"     # shipped name or path to an applicator file/folder
    channel = "ring"

or an analytic channel for validation scenes (``kind`` = ``"straight"``, ``"arc"``, ``"helix"``,
``"s-curve"``) or an inline centreline (``kind = "points"``, ``centreline_mm = [[x, y, z], ...]``),
with a lumen (``lumen = "circular" | "u" | "stepped"``, ``r_b_mm``, ``r_a_mm``, ``flat_mm``,
``s_breaks_mm``). Lumen keys given with an applicator replace that channel's lumen.

Overrides (``--set KEY=VALUE`` on the command line, ``overrides=`` here) are dotted keys in the
same user units; string values are parsed as TOML values (``0.5``, ``true``, ``[1, 2]``,
``{thin = 2.0, thick = 5.0}``) and fall back to plain strings (``flexitron``).

The modules, one job each (everything public is importable from this package):

- :mod:`.read`: find and read scene files, apply ``--set`` overrides (no validation).
- :mod:`.check`: the checker that reads keys through the registry and names file and key.
- :mod:`.channel`: the channel (analytic, inline points or applicator) and its lumen.
- :mod:`.sections`: instrument, effects, contact, motion (default advances), solver, outputs.
- :mod:`.write`: a :class:`Scene` back to a user-unit dict (:func:`scene_to_dict`).
- :mod:`.load`: the entry points :func:`load_scene`, :func:`scene_with_overrides`,
  :func:`scene_for_channel`.
"""

from ringqa.simulation.scene_keys import CHANNEL_KINDS, KEYS, LUMEN_KINDS
from ringqa.simulation.scenefile.channel import (
    ANALYTIC_TIP_GAP_MM,
    analytic_centreline_mm,
    build_channel,
)
from ringqa.simulation.scenefile.check import SCHEMA, Checker
from ringqa.simulation.scenefile.load import (
    load_scene,
    scene_for_channel,
    scene_from_data,
    scene_with_overrides,
)
from ringqa.simulation.scenefile.read import (
    apply_overrides,
    parse_set_args,
    parse_value,
    read_scene_dict,
    resolve_scene_path,
    shipped_scenes,
)
from ringqa.simulation.scenefile.sections import (
    DEFAULT_GRAVITY_M_S2,
    DEFAULT_SPAN_MM,
    DEFAULT_STEP_MM,
    STANDARD_GRAVITY_M_S2,
    default_advances_mm,
)
from ringqa.simulation.scenefile.write import lumen_spec, scene_to_dict

__all__ = [
    "ANALYTIC_TIP_GAP_MM",
    "CHANNEL_KINDS",
    "DEFAULT_GRAVITY_M_S2",
    "DEFAULT_SPAN_MM",
    "DEFAULT_STEP_MM",
    "KEYS",
    "LUMEN_KINDS",
    "SCHEMA",
    "STANDARD_GRAVITY_M_S2",
    "Checker",
    "analytic_centreline_mm",
    "apply_overrides",
    "build_channel",
    "default_advances_mm",
    "load_scene",
    "lumen_spec",
    "parse_set_args",
    "parse_value",
    "read_scene_dict",
    "resolve_scene_path",
    "scene_for_channel",
    "scene_from_data",
    "scene_to_dict",
    "scene_with_overrides",
    "shipped_scenes",
]
