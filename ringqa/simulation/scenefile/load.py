"""The entry points: a validated SI :class:`Scene` from a file, a dict, a scene or a channel.

:func:`load_scene` reads the file and applies overrides (:mod:`.read`); :func:`scene_from_data`
checks every key (:mod:`.check`), builds the channel (:mod:`.channel`) and the other sections
(:mod:`.sections`) and ties the ``[channel]`` table to the channel it built
(``scene.channel_spec``, so :func:`~.write.scene_to_dict` can write it back as given).
:func:`scene_with_overrides` and :func:`scene_for_channel` go the same way.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ringqa.errors import SceneError
from ringqa.simulation.instruments import CABLE_PRESETS
from ringqa.simulation.scene import ChannelSpec, Scene
from ringqa.simulation.scene_keys import SECTIONS, section_keys
from ringqa.simulation.scenefile.channel import build_channel
from ringqa.simulation.scenefile.check import Checker
from ringqa.simulation.scenefile.read import (
    apply_overrides,
    plain_copy,
    read_scene_dict,
    resolve_scene_path,
)
from ringqa.simulation.scenefile.sections import (
    read_contact,
    read_effects,
    read_instrument,
    read_model,
    read_motion,
    read_outputs,
    read_solver,
)
from ringqa.simulation.scenefile.write import scene_to_dict


def load_scene(
    path_or_dict: str | Path | Mapping[str, Any],
    overrides: Mapping[str, Any] | None = None,
    name: str | None = None,
) -> Scene:
    """Load and validate a scene (TOML file or dict in user units) into an SI :class:`Scene`.

    Parameters
    ----------
    path_or_dict : str, Path or mapping
        A scene TOML file, a shipped scene name (``"ring26-flexitron"`` from ``data/scenes``), or
        the same content as a dict.
    overrides : mapping of dotted key -> value, optional
        ``{"solver.increment_mm": 0.5}``; string values are parsed as TOML values.
    name : str, optional
        Scene name; default the file's ``name`` key, the file stem, or ``"scene"``.

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        Naming the file and dotted key and how to fix it.
    """
    if isinstance(path_or_dict, Mapping):
        data, origin, stem = dict(path_or_dict), "", None
    else:
        path = resolve_scene_path(path_or_dict)
        data, origin, stem = read_scene_dict(path), f"{path}: ", path.stem
    data = apply_overrides(data, overrides, origin)
    return scene_from_data(data, origin, name or None, stem)


def scene_from_data(
    data: dict, origin: str = "", name: str | None = None, stem: str | None = None, channel=None
) -> Scene:
    """A :class:`Scene` from a user-unit dict (``origin`` prefixes errors; ``channel``: use this
    channel object instead of building one from ``data["channel"]``)."""
    ck = Checker(data, origin)
    known_top = [k.name for k in section_keys("")]
    unknown = sorted(set(data) - set(known_top) - {s for s in SECTIONS if s})
    if unknown:
        raise ck.fail(
            unknown[0],
            "unknown top-level key or table",
            f"allowed: {', '.join([*known_top, *[s for s in SECTIONS if s]])}",
        )
    for section in SECTIONS:  # every key's name, type and range before any work
        sec = ck.section(section) if section else data
        for k in section_keys(section):
            if k.name in sec:
                ck.value(section, k.name, sec=sec if section else None)
    scene_name = name or ck.value("", "name") or stem or "scene"
    preset = ck.value("instrument", "preset")
    if channel is None:
        channel = build_channel(ck)
    spec = plain_copy(data.get("channel", {}))
    app = spec.get("applicator")
    if app is not None and origin and ("/" in str(app) or str(app).endswith(".json")):
        cand = Path(origin.rstrip(": ")).parent / str(app)
        if cand.exists():  # keep the scene usable from another folder
            spec["applicator"] = str(cand.resolve())
    try:
        return Scene(
            name=str(scene_name),
            channel=channel,
            instrument=read_instrument(ck, preset),
            effects=read_effects(ck),
            contact=read_contact(ck, preset),
            motion=read_motion(ck, channel, preset),
            solver=read_solver(ck),
            outputs=read_outputs(ck),
            description=ck.value("", "description"),
            channel_spec=ChannelSpec(spec, channel) if spec else None,
            model=read_model(ck),
        )
    except SceneError as exc:  # a dataclass's own check: name the file too
        if origin and not str(exc).startswith(origin):
            raise SceneError(f"{origin}{exc}") from None
        raise


def scene_with_overrides(scene: Scene, overrides: Mapping[str, Any]) -> Scene:
    """A new scene with dotted-key overrides (user units) applied to ``scene``'s settings.

    ``discretisation.element_length_mm`` re-discretises the instrument's sections; the channel
    object is kept unless a ``channel.*`` key is overridden; ``motion.step_mm``/``span_mm``
    replace the scene's advances.
    """
    over = dict(overrides)
    data = scene_to_dict(scene)
    if any(k in over for k in ("motion.step_mm", "motion.span_mm")):
        data["motion"].pop("advances_mm", None)
    if "instrument.preset" in over or "instrument.real_mass" in over:
        data["instrument"].pop("sections", None)
        data["instrument"].pop("centre_from_tip_mm", None)
        if "instrument.preset" in over:
            data.pop("contact", None)
    data = apply_overrides(data, over)
    keep = None if any(k.startswith("channel.") or k == "channel" for k in over) else scene.channel
    return scene_from_data(data, "", scene.name, None, channel=keep)


def scene_for_channel(channel, cable: str = "flexitron", **overrides) -> Scene:
    """A scene for a channel object (the pipeline's entry), defaults from the cable preset.

    Parameters
    ----------
    channel : ringqa.geometry.Channel
        Used as is (its centreline is not re-fitted); default dwell advances follow its measured
        path (or every 1 mm over 60 mm back from ``s_ref``).
    cable : str
        Instrument preset name (``"flexitron"``).
    **overrides
        Section tables in user units, ``solver={"increment_mm": 0.5}``, or single keys with the
        dot written as a double underscore, ``solver__increment_mm=0.5``.

    Returns
    -------
    Scene
    """
    if cable not in CABLE_PRESETS:
        raise SceneError(
            f"cable = {cable!r}: unknown preset (choose one of {', '.join(sorted(CABLE_PRESETS))})"
        )
    data: dict[str, Any] = {"instrument": {"preset": cable}}
    flat: dict[str, Any] = {}
    for key, val in overrides.items():
        if isinstance(val, Mapping):
            data.setdefault(key, {}).update(val)
        else:
            flat[key.replace("__", ".")] = val
    data = apply_overrides(data, flat)
    return scene_from_data(data, "", f"{channel.name}-{cable}", None, channel=channel)
