"""Scene files: TOML in millimetres/degrees/seconds in, a validated SI :class:`Scene` out.

A scene file has the sections ``[channel]``, ``[instrument]``, ``[discretisation]``,
``[effects]``, ``[contact]``, ``[motion]``, ``[solver]`` and ``[outputs]`` (all optional except
the channel) plus top-level ``name`` and ``description``. Keys carry their unit in the name
(``increment_mm``, ``speed_mm_s``, ``time_step_s``); this package is the ONE place where they are
converted to SI (with :mod:`ringqa.units`). Every error names the file, the dotted key and the fix.
``data/scenes/README.md`` documents every key; :data:`SCHEMA` is the machine-readable version.

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

The modules, one job each (everything is importable from this package):

- :mod:`.read`: find and read scene files, apply ``--set`` overrides (no validation).
- :mod:`.check`: the key schema (:data:`SCHEMA`) and the checker that validates against it.
- :mod:`.channel`: the channel (analytic, inline points or applicator) and its lumen.
- :mod:`.sections`: instrument, effects, contact, motion (default advances) and solver settings.
- :mod:`.write`: a :class:`Scene` back to a user-unit dict (:func:`scene_to_dict`).
- :mod:`.load`: the entry points :func:`load_scene`, :func:`scene_with_overrides`,
  :func:`scene_for_channel`.
"""

# The private helpers are re-exported as well (``_name as _name``): every name the single module
# ringqa/simulation/scenefile.py defined stays importable from ringqa.simulation.scenefile.
from ringqa.simulation.scenefile.channel import (
    _POINT_SPACING_MM as _POINT_SPACING_MM,
)
from ringqa.simulation.scenefile.channel import (
    ANALYTIC_TIP_GAP_MM,
    analytic_centreline_mm,
    build_channel,
)
from ringqa.simulation.scenefile.channel import _applicator_channel as _applicator_channel
from ringqa.simulation.scenefile.channel import _arc as _arc
from ringqa.simulation.scenefile.channel import _count as _count
from ringqa.simulation.scenefile.channel import _line as _line
from ringqa.simulation.scenefile.channel import _lumen as _lumen
from ringqa.simulation.scenefile.channel import _lumen_inner as _lumen_inner
from ringqa.simulation.scenefile.check import _ANY_NUM_OR_TABLE as _ANY_NUM_OR_TABLE
from ringqa.simulation.scenefile.check import _NUM as _NUM
from ringqa.simulation.scenefile.check import (
    CHANNEL_KINDS,
    EXTRA_FIELDS,
    LUMEN_KINDS,
    SCHEMA,
    SECTION_KEYS,
)
from ringqa.simulation.scenefile.check import _Checker as _Checker
from ringqa.simulation.scenefile.check import _type_words as _type_words
from ringqa.simulation.scenefile.load import _scene_from_data as _scene_from_data
from ringqa.simulation.scenefile.load import load_scene, scene_for_channel, scene_with_overrides
from ringqa.simulation.scenefile.read import _resolve_scene_path as _resolve_scene_path
from ringqa.simulation.scenefile.read import (
    apply_overrides,
    parse_set_args,
    parse_value,
    read_scene_dict,
    shipped_scenes,
)
from ringqa.simulation.scenefile.sections import (
    DEFAULT_SPAN_MM,
    DEFAULT_STEP_MM,
    STANDARD_GRAVITY_M_S2,
    default_advances_mm,
)
from ringqa.simulation.scenefile.sections import _contact as _contact
from ringqa.simulation.scenefile.sections import _custom_instrument as _custom_instrument
from ringqa.simulation.scenefile.sections import _effects as _effects
from ringqa.simulation.scenefile.sections import _extra_in as _extra_in
from ringqa.simulation.scenefile.sections import _instrument as _instrument
from ringqa.simulation.scenefile.sections import _motion as _motion
from ringqa.simulation.scenefile.sections import _solver as _solver
from ringqa.simulation.scenefile.write import _channel_spec as _channel_spec
from ringqa.simulation.scenefile.write import _extra_out as _extra_out
from ringqa.simulation.scenefile.write import _lumen_spec as _lumen_spec
from ringqa.simulation.scenefile.write import _plain as _plain
from ringqa.simulation.scenefile.write import scene_to_dict

__all__ = [
    "ANALYTIC_TIP_GAP_MM",
    "CHANNEL_KINDS",
    "DEFAULT_SPAN_MM",
    "DEFAULT_STEP_MM",
    "EXTRA_FIELDS",
    "LUMEN_KINDS",
    "SCHEMA",
    "SECTION_KEYS",
    "STANDARD_GRAVITY_M_S2",
    "analytic_centreline_mm",
    "apply_overrides",
    "build_channel",
    "default_advances_mm",
    "load_scene",
    "parse_set_args",
    "parse_value",
    "read_scene_dict",
    "scene_for_channel",
    "scene_to_dict",
    "scene_with_overrides",
    "shipped_scenes",
]
