"""``ringqa warmup``: compile the numerical kernels ``ringqa commission`` runs, once, with progress.

    ringqa warmup            # what commission uses (about 15 s on 2 cores, empty cache)
    ringqa warmup --all      # also the engine's other effects (torsion, gravity, wall damping,
                             # the dynamic solver): what `ringqa simulate` scenes may switch on

numba compiles each kernel on its first call and keeps it in its on-disk cache, so only the
first run on a machine (or after an update) pays the compile time. This command pays it up
front: the geometry kernels on a shipped ring's centreline, the simulation kernels for the
commissioning scene of every cable preset commission chooses (a 3 mm push), the flexible-element
engine of commission's cross-check (the same push; one compiled set serves every scene, torsion
included), and the TG-43 kernel. Afterwards ``ringqa commission`` compiles nothing
(benchmarks/bench_coldstart.py checks it). Progress goes to stderr; a warm cache makes it
finish in a few seconds, silently. It also writes the bytecode of ringqa's own modules where
it is missing (:func:`ringqa.cli._precompile.write_bytecode`: under ``PYTHONDONTWRITEBYTECODE``
an editable install would otherwise compile them from source on every run).
"""

from __future__ import annotations

import time

from ringqa.cli._options import plain_help


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "warmup",
        help="compile the numerical kernels once (the first run's compile time, paid up front)",
        description=plain_help(__doc__),
        formatter_class=__import__("argparse").RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--all",
        action="store_true",
        help="also the effects commission does not use (torsion, gravity, wall damping, dynamic)",
    )
    p.set_defaults(func=run)


def warm_commission() -> list[str]:
    """Call every kernel a default ``ringqa commission`` calls, on small inputs.

    Returns the names of the cable presets whose commissioning scene was run.
    """
    import numpy as np

    import tg43
    from ringqa.pipeline.inputs import load_input
    from ringqa.pipeline.simulate import (
        FALLBACK_CABLE,
        SOURCE_CABLE,
        commission_scene,
        cross_check_scene,
        default_engine,
    )

    app = load_input("ring26x60").applicator
    channel = app.channels[0]
    cl = channel.centreline
    s = np.linspace(0.0, cl.length_m, 5)
    pos, _tan, _nor = cl.frame(s)
    cl.closest(pos + 1e-4)
    engine = default_engine()
    cables = sorted(set(SOURCE_CABLE.values()) | {FALLBACK_CABLE})
    for k, cable in enumerate(cables):
        scene = commission_scene(engine, channel, cable, {})
        start_mm = float(scene.motion.advances_m[0]) * 1e3
        engine.simulate(scene, [start_mm, start_mm + 3.0])
        if k == 0:  # the cross-check's engine: its kernels do not depend on the cable
            engine.simulate(cross_check_scene(engine, scene), [start_mm, start_mm + 3.0])
    for name in sorted(set(SOURCE_CABLE)):
        src = tg43.load_source(name)
        tg43.dose_rate_per_sk(src, [[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], [[10.0, 0.0, 5.0]])
    return cables


def run(args) -> int:
    """Warm the kernels; print what was done (stderr carries the compile progress)."""
    from ringqa.cli._precompile import write_bytecode

    t0 = time.perf_counter()
    cables = warm_commission()
    write_bytecode()
    if args.all:
        from ringqa.simulation.engine import warm_up

        warm_up()
    what = "commission's kernels" + (" and every effect's" if args.all else "")
    print(
        f"ringqa warmup: {what} ready ({', '.join(cables)} cables; "
        f"{time.perf_counter() - t0:.1f} s)"
    )
    return 0
