"""Issue-4 performance report for the rod-in-channel engine (a script, not a timed test).

    /work/venv/bin/python benchmarks/bench_engine.py [--quick] [--json OUT.json]
    .venv/bin/python benchmarks/bench_engine.py --per-process N [--baseline DIR | --python-loop]
    .venv/bin/python benchmarks/bench_engine.py --breakdown [SCENE] [--repeats N]

Scene: data/scenes/ring13-push100.toml -- the Flexitron cable (paper Table 1, Stribeck friction,
quasi-static) pushed 100 mm into a ring of centreline radius 13 mm. Reports:

1. time (engine's solve_time_s: JIT excluded; median of repeats), element count, Newton
   iterations, and the max dwell-position error against the same scene 4x refined (element
   lengths and increment / 4): the issue's target is <= 0.05 s and <= 0.05 mm;
2. scaling: time against element count (element lengths x 2, 1, 1/2, 1/4) with the fitted
   exponent (1 = linear);
3. the cost of each effect: time with it on vs off on the same scene;
4. the same for the dynamic solver (0.5 m/s, inertia, wall damping; dt and elements / 4 refined).
Times are also printed as multiples (xN) of the shipped scene's time (of the un-refined run for a
4x-refined one).

``--breakdown`` (default scene ring26-flexitron): where a quasi-static solve's time goes, per
load step, measured inside the compiled loop: uncached twins of :func:`march` and
:func:`newton` with a cycle counter (LLVM's ``readcyclecounter``) around the predictor, each
kind of assembly (the step's first residual + Jacobian, a line-search trial that also builds
the Jacobian, a residual-only trial, a Jacobian-only build), the banded LU solve and the chain
update. The twins are the shipped source with timer lines added (each insertion is checked, so
a changed kernel stops the benchmark instead of timing something else); the run's answers and
counters are the shipped ones. The counter counts wall cycles, so on a loaded machine the shares
are what to read: each share times the solve's CPU time (``time.process_time`` over the same
runs) is the CPU time given.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ringqa.accuracy import scaled_overrides  # noqa: E402
from ringqa.simulation import simulate  # noqa: E402
from ringqa.simulation.scenefile import load_scene, scene_with_overrides  # noqa: E402

SCENE = ROOT / "data" / "scenes" / "ring13-push100.toml"
#: the issue-4 target: at most this solve time AND this max dwell error vs the 4x-refined run
TARGET_S = 0.05
TARGET_MM = 0.05


def timed(scene, repeats: int):
    times, res = [], None
    for _ in range(repeats):
        res = simulate(scene)
        times.append(res.solve_time_s)
        if res.solve_time_s > 5.0:
            break
    return res, statistics.median(times)


def err_mm(a, b) -> float:
    if a.status != 0 or b.status != 0:
        return float("nan")
    return float(np.max(np.linalg.norm((a.source_pos_m - b.source_pos_m) * 1e3, axis=1)))


def refined(scene, f: float):
    """``scene`` with every element length and the increment (or time step) times ``f``."""
    return scene_with_overrides(scene, scaled_overrides(scene, f, f))


def row(name, res, t, err=None, t_base=None) -> dict:
    """Print and return one case; ``t_base`` (s): also the time as a multiple of it."""
    r = {
        "case": name,
        "status": int(res.status),
        "time_s": round(t, 5),
        "n_elements": int(res.n_elements),
        "newton_iters": int(np.sum(res.newton_iters)),
    }
    if err is not None:
        r["max_err_vs_4x_mm"] = round(err, 5)
    if t_base:
        r["time_ratio"] = round(t / t_base, 3)
    print(
        f"{name:48s} status {r['status']:2d}  {t * 1e3:9.2f} ms"
        + (f" (x{r['time_ratio']:.2f})" if t_base else "")
        + f"  {r['n_elements']:5d} el  {r['newton_iters']:6d} it"
        + (f"  err {err:.4f} mm" if err is not None else "")
    )
    return r


#: one fresh process of --per-process: the solve's CPU time and simulate()'s CPU and wall (median
#: of 7 after one warm run) of ring13-push100 and ring26-flexitron, and what the process looked like
_PROCESS = r"""
import json, os, statistics, sys, time
sys.path.insert(0, sys.argv[1])
t0 = time.perf_counter()
from ringqa.simulation import simulate
from ringqa.simulation.scenefile import load_scene
import numba
t_import = time.perf_counter() - t0
out = {"pid": os.getpid(), "import_s": t_import, "numba_threads": numba.config.NUMBA_NUM_THREADS,
       "cpus": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None}
import types
import ringqa.simulation.solvers.driver as driver
if len(sys.argv) > 2 and sys.argv[2] == "python-loop":
    driver.USE_MARCH = False
# solve_time_s in CPU seconds: the driver's clock is this process's CPU time (other users' load
# on a shared machine inflates wall figures several times)
driver.time = types.SimpleNamespace(perf_counter=time.process_time)
for name in ("ring13-push100", "ring26-flexitron"):
    scene = load_scene(os.path.join(sys.argv[1], "data", "scenes", name + ".toml"))
    t1 = time.perf_counter(); simulate(scene); first = time.perf_counter() - t1
    solve, wall, cpu, iters = [], [], [], 0
    for _ in range(7):
        t1 = time.perf_counter(); c1 = time.process_time(); r = simulate(scene)
        cpu.append(time.process_time() - c1); wall.append(time.perf_counter() - t1)
        solve.append(r.solve_time_s); iters = int(r.stats.n_newton_iters)
    out[name] = {"first_s": first, "solve_cpu_ms": 1e3 * statistics.median(solve),
                 "wall_ms": 1e3 * statistics.median(wall), "outside_cpu_ms": 1e3 * (
                 statistics.median(cpu) - statistics.median(solve)), "iters": iters,
                 "steps": int(r.stats.n_steps), "cpu_ms": 1e3 * statistics.median(cpu),
                 "solve_cpu_min_ms": 1e3 * min(solve), "residuals": int(r.stats.n_residuals)}
print(json.dumps(out))
"""


def per_process(n: int, baseline: Path | None = None, python_loop: bool = False) -> int:
    """``n`` fresh processes one after the other: is the solve time bimodal per process?

    With ``baseline`` (another checkout) or ``python_loop`` (this checkout with the compiled
    load-step loop off: ``driver.USE_MARCH = False``) the processes alternate between "before"
    (that) and "after" (this checkout), ``n`` each, and the medians and their ratio are
    printed: CPU time of the solve (the driver's clock switched to ``time.process_time`` in
    the benchmark's processes) and of ``simulate()``, less sensitive to other users' load than
    wall figures, Newton iterations, residual assemblies and load steps.
    """
    import subprocess

    variants = [("after", ROOT, "")]
    if baseline is not None:
        variants.insert(0, ("before", Path(baseline).resolve(), ""))
    elif python_loop:
        variants.insert(0, ("before", ROOT, "python-loop"))
    print(
        "| process | checkout | import s | ring13 simulate CPU ms | solve CPU ms | outside CPU ms "
        "| iters | ring26-flexitron simulate CPU ms | solve CPU ms | outside CPU ms | iters | "
        "residuals | steps |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    got: dict[str, list] = {v[0]: [] for v in variants}
    for k in range(n):
        for label, root, flag in variants:
            cmd = [sys.executable, "-c", _PROCESS, str(root)] + ([flag] if flag else [])
            done = subprocess.run(cmd, capture_output=True, text=True, check=True)
            d = json.loads(done.stdout.strip().splitlines()[-1])
            got[label].append(d)
            a, b = d["ring13-push100"], d["ring26-flexitron"]
            print(
                f"| {k} | {label} | {d['import_s']:.2f} | {a['cpu_ms']:.1f} | "
                f"{a['solve_cpu_ms']:.1f} | {a['outside_cpu_ms']:.1f} | {a['iters']} | "
                f"{b['cpu_ms']:.1f} | {b['solve_cpu_ms']:.1f} | {b['outside_cpu_ms']:.1f} | "
                f"{b['iters']} | {b['residuals']} | {b['steps']} |",
                flush=True,
            )
    if len(variants) == 2:
        print("\nmedians over the processes (before -> after, ratio):")
        for scene in ("ring13-push100", "ring26-flexitron"):
            for key in ("solve_cpu_ms", "solve_cpu_min_ms", "cpu_ms", "outside_cpu_ms", "iters",
                        "residuals", "steps"):  # fmt: skip
                vals = [[p[scene].get(key) for p in got[lab]] for lab in ("before", "after")]
                if any(v is None for vs in vals for v in vs):
                    continue
                m0, m1 = (statistics.median(v) for v in vals)
                print(f"  {scene:18s} {key:16s} {m0:9.2f} -> {m1:9.2f}  x{m1 / m0:.3f}")
    return 0


def _instrumented_march():
    """(march, hz): the compiled load-step loop and Newton with cycle counters (``--breakdown``)
    and the counter's rate (1/s). ``march`` takes one more argument, ``T`` (64,) int64: at slot
    ``k`` (:data:`_BREAKDOWN`; 1 Newton, 9 the loop) the cycles of the timed calls, at ``16 + k``
    their number, at ``32 + k`` and ``48 + k`` the same for calls longer than 200 us (the process
    was descheduled: a loaded machine's time, not the kernel's)."""
    import inspect

    from llvmlite import ir
    from numba import njit
    from numba.core import cgutils
    from numba.core import types as nt
    from numba.extending import intrinsic

    import ringqa.simulation.solvers.march as mm
    import ringqa.simulation.solvers.newton as nm

    @intrinsic
    def rdtsc(typingctx):
        def codegen(context, builder, signature, args):
            fnty = ir.FunctionType(ir.IntType(64), [])
            fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.readcyclecounter")
            return builder.call(fn, [])

        return nt.int64(), codegen

    def patch(src, old, new):
        if old not in src:
            raise SystemExit(f"--breakdown: the kernel source changed, update the probe: {old!r}")
        return src.replace(old, new)

    def timed(src, stmt, slot):
        """``stmt`` (its first line, stripped; the statement ends at its line's end or at
        ``  # fmt: skip``) wrapped in the counter for ``slot``."""
        lines = src.split("\n")
        hits = [i for i, ln in enumerate(lines) if ln.strip().startswith(stmt)]
        if len(hits) != 1:
            raise SystemExit(f"--breakdown: the kernel source changed, update the probe: {stmt!r}")
        i = hits[0]
        j = i
        while lines[j].count("(") + sum(ln.count("(") for ln in lines[i:j]) > sum(
            ln.count(")") for ln in lines[i : j + 1]
        ):
            j += 1
        pad = lines[i][: len(lines[i]) - len(lines[i].lstrip())]
        lines[i:j + 1] = [pad + "t_ = rdtsc()", *lines[i : j + 1],
                          f"{pad}_acc(T, {slot}, rdtsc() - t_)"]  # fmt: skip
        return "\n".join(lines)

    @njit
    def cycles():
        return rdtsc()

    c0, t0 = cycles(), time.perf_counter()
    time.sleep(0.2)
    hz = (cycles() - c0) / (time.perf_counter() - t0)
    limit = int(200e-6 * hz)  # a timed call longer than 200 us was descheduled: kept apart

    @njit
    def _acc(T, k, d):
        if d < limit:
            T[k] += d
            T[16 + k] += 1
        else:
            T[32 + k] += d
            T[48 + k] += 1

    deco = '@njit(cache=True, error_model="numpy")\n'
    src = inspect.getsource(nm.newton.py_func).replace(deco, "")
    src = patch(src, "energies, counters):", "energies, counters, T):")
    src = timed(src, "assemble(effects, q, st, sw, r, B, yes, yes, energies)", 2)
    src = timed(src, "assemble(effects, q, st, sw, r_scratch, B, yes, no, e_scratch)", 5)
    src = patch(src, "if not band_solve(B, kl, rhs, n_free):", "if not ok_:")
    src = patch(
        src,
        "        if not ok_:",
        "        ok_ = band_solve(B, kl, rhs, n_free)\n        if not ok_:",
    )
    src = timed(src, "ok_ = band_solve(B, kl, rhs, n_free)", 6)
    src = timed(src, "update_chain(q0, rhs, lam, nd, n_nodes, n_free, q)", 7)
    src = timed(src, "assemble(effects, q, st, sw, r_try, B, trial_jac, yes, energies)", 34)
    src = patch(src, "_acc(T, 34,", "_acc(T, 3 if trial_jac else 4,")
    g = dict(nm.__dict__, rdtsc=rdtsc, _acc=_acc)
    exec(compile(src, nm.__file__, "exec"), g)  # the shipped source, timers added
    newton_t = njit(error_model="numpy")(g["newton"])
    msrc = inspect.getsource(mm.march.py_func).replace(deco, "")
    msrc = patch(msrc, "rec_contact, rec_u,\n):", "rec_contact, rec_u, T,\n):")
    msrc = timed(msrc, "predict(q, True, du, u_new,", 0)
    msrc = timed(msrc, "status, it, res = newton(", 1)
    msrc = patch(msrc, "energies, counters)  # fmt: skip", "energies, counters, T)  # fmt: skip")
    msrc = patch(msrc, "    n_all = q.shape[0]\n", "    t_m = rdtsc()\n    n_all = q.shape[0]\n")
    msrc = patch(msrc, "    return code", "    T[9] += rdtsc() - t_m\n    return code")
    gm = dict(mm.__dict__, rdtsc=rdtsc, newton=newton_t, _acc=_acc)
    exec(compile(msrc, mm.__file__, "exec"), gm)
    march_t = njit(error_model="numpy")(gm["march"])
    return march_t, hz


#: ``--breakdown``'s slots: (index in T, label)
_BREAKDOWN = (
    (0, "predictor (slide + extrapolation)"),
    (2, "assembly: step's first residual + Jacobian"),
    (3, "assembly: line-search trial + Jacobian"),
    (4, "assembly: residual-only trial"),
    (5, "assembly: Jacobian only"),
    (6, "banded LU solve"),
    (7, "chain update"),
)


def breakdown(name: str, repeats: int) -> int:
    """Print where ``name``'s quasi-static solve spends its time (module docstring)."""
    import types

    import ringqa.simulation.solvers.driver as driver
    import ringqa.simulation.solvers.march as mm

    march_t, hz = _instrumented_march()
    T = np.zeros(64, dtype=np.int64)
    shim = types.SimpleNamespace(**{k: getattr(mm, k) for k in dir(mm) if not k.startswith("__")})
    shim.march = lambda *a: march_t(*a, T)
    driver.march_kernel = shim
    driver.time = types.SimpleNamespace(perf_counter=time.process_time)  # solve_time_s: CPU
    scene = load_scene(ROOT / "data" / "scenes" / f"{name}.toml")
    simulate(scene)  # compiles the twins
    T[:] = 0
    solve = []
    for _ in range(repeats):
        r = simulate(scene)
        solve.append(r.solve_time_s)
    st = r.stats
    cpu = statistics.median(solve)
    print(f"{name}: {st.n_steps} load steps, {st.n_newton_iters} Newton iterations "
          f"({st.n_newton_iters / st.n_steps:.2f} a step), {st.n_residuals} residual assemblies "
          f"({st.n_jacobians} with the Jacobian), {st.n_solves} LU solves, {st.n_halvings} "
          f"line-search halvings; solve {cpu * 1e3:.2f} ms CPU (median of {repeats} runs, "
          f"the whole solve: initial equilibrium and Python's share included)")  # fmt: skip
    print("| part | calls a step | us a call | us a load step | share |")
    print("|---|---|---|---|---|")
    us = 1e6 / hz

    def mean_us(k):
        return T[k] / max(T[16 + k], 1) * us

    # the loop without descheduled time: every call at its undisturbed mean
    parts = [(label, T[16 + k] / repeats, mean_us(k)) for k, label in _BREAKDOWN]

    def every(k):  # cycles of all calls, descheduled ones included
        return T[k] + T[32 + k]

    # what the timed parts leave of Newton and of the loop (rarely descheduled: small shares)
    inner = sum(every(k) for k, _ in _BREAKDOWN if k != 0)
    newton_own = max(every(1) - inner, 0) * us / repeats
    loop_own = max(every(9) - every(0) - every(1), 0) * us / repeats
    total = sum(n * u for _, n, u in parts) + newton_own + loop_own
    for label, n, u in parts:
        print(
            f"| {label} | {n / st.n_steps:.2f} | {u:.2f} | {n * u / st.n_steps:.2f} | "
            f"{100 * n * u / total:.1f} % |"
        )
    for label, v in (("Newton's own work (tests, copies)", newton_own),
                     ("the loop's own work (monitor, records)", loop_own)):  # fmt: skip
        print(f"| {label} | | | {v / st.n_steps:.2f} | {100 * v / total:.1f} % |")
    left = int(sum(T[48 + k] for k, _ in _BREAKDOWN))
    print(f"| load steps (sum) | | | {total / st.n_steps:.2f} | {total / 1e3:.2f} ms a run |")
    print(f"({left} timed calls longer than 200 us, i.e. descheduled, left out of the means)")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="1 repeat, fewer cases")
    ap.add_argument("--json", type=Path, help="write the results as JSON here")
    ap.add_argument(
        "--per-process", type=int, default=0, metavar="N",
        help="only: N fresh processes, each timing ring13 and ring26-flexitron (bimodal?)",
    )  # fmt: skip
    ap.add_argument(
        "--baseline", type=Path, metavar="DIR",
        help="with --per-process: alternate with this checkout (before) and print the ratios",
    )  # fmt: skip
    ap.add_argument(
        "--python-loop", action="store_true",
        help="with --per-process: 'before' = this checkout with the compiled loop off",
    )  # fmt: skip
    ap.add_argument(
        "--breakdown", nargs="?", const="ring26-flexitron", metavar="SCENE",
        help="only: where the quasi-static solve's time goes, per load step (a shipped scene)",
    )  # fmt: skip
    ap.add_argument("--repeats", type=int, default=20, help="runs of --breakdown (default 20)")
    args = ap.parse_args()
    if args.breakdown:
        return breakdown(args.breakdown, args.repeats)
    if args.per_process:
        return per_process(args.per_process, args.baseline, args.python_loop)
    reps = 1 if args.quick else 5
    base = load_scene(SCENE)
    t0 = time.perf_counter()
    simulate(base)  # compile (JIT) once; solve_time_s excludes it anyway
    print(f"first call (incl. JIT/cache load): {time.perf_counter() - t0:.2f} s")
    out: dict = {"scene": str(SCENE.relative_to(ROOT)), "repeats": reps}

    thin, thick = (sec.element_length_m * 1e3 for sec in base.instrument.sections[1:3])
    inc = base.solver.increment_m * 1e3
    print(f"\n1. quasi-static as shipped (links {thin:g}/{thick:g} mm, increment {inc:g} mm)")
    res, t = timed(base, reps)
    ref, t_ref = timed(refined(base, 0.25), 1)
    err = err_mm(res, ref)
    out["quasistatic"] = [
        row(f"shipped ({thin:g}/{thick:g} mm, inc {inc:g} mm)", res, t, err),
        row(
            f"4x refined ({thin / 4:g}/{thick / 4:g} mm, inc {inc / 4:g} mm)", ref, t_ref, t_base=t
        ),
    ]
    med = float(np.median(np.linalg.norm((res.source_pos_m - ref.source_pos_m) * 1e3, axis=1)))
    ok_t, ok_e = t <= TARGET_S, err <= TARGET_MM
    print(
        f"   issue target: time {t * 1e3:.1f} ms <= {TARGET_S * 1e3:g} ms "
        f"{'MET' if ok_t else 'NOT MET'}; max error vs 4x refined {err:.4f} mm <= "
        f"{TARGET_MM:g} mm {'MET' if ok_e else 'NOT MET'} "
        f"(median {med:.4f} mm)"
    )
    out["target"] = {"time_s": t, "max_err_mm": err, "median_err_mm": med,
                     "time_met": ok_t, "error_met": ok_e}  # fmt: skip
    r8, t8 = timed(refined(base, 0.125), 1)
    ref_spread = err_mm(ref, r8)
    print(f"   the reference itself: 4x vs 8x refined {ref_spread:.4f} mm ({t8:.2f} s)")
    out["target"]["ref_4x_vs_8x_mm"] = ref_spread
    others = {
        "paper's links 3/10 mm": {"discretisation.element_length_mm": {"thin": 3.0, "thick": 10.0}},
        "finer links 1.5/5 mm": {"discretisation.element_length_mm": {"thin": 1.5, "thick": 5.0}},
        "engine's default 20 mm approach": {"solver.approach_mm": 20.0},
    }
    for name, ov in others.items():
        other = scene_with_overrides(base, ov)
        ro, to = timed(other, reps)
        ror, tor = timed(refined(other, 0.25), 1)
        out["quasistatic"] += [
            row(f"{name} (inc {inc:g} mm)", ro, to, err_mm(ro, ror), t),
            row("  its 4x refined", ror, tor, t_base=to),
        ]

    print("\n2. scaling with element count (increment fixed)")
    pts = []
    for f in (2.0, 1.0, 0.5, 0.25):
        s = scene_with_overrides(
            base, {"discretisation.element_length_mm": {"thin": thin * f, "thick": thick * f}}
        )
        r, tt = timed(s, reps)
        pts.append((r.n_elements, tt, r.status))
        row(f"elements x{1 / f:g}", r, tt, t_base=t)
    good = [(n, tt) for n, tt, st in pts if st == 0 and tt > 0]
    if len(good) >= 2:
        k = np.polyfit(np.log([n for n, _ in good]), np.log([tt for _, tt in good]), 1)[0]
        print(f"   fitted exponent time ~ n_elements^{k:.2f} (1 = linear)")
        out["scaling"] = {"points": pts, "exponent": float(k)}

    print("\n3. cost of each effect (on vs off, same scene)")
    cases = {
        "friction none": {"effects.friction": "none"},
        "friction coulomb": {"effects.friction": "coulomb"},
        "friction stribeck (default)": {},
        "torsion on": {"effects.torsion": True},
        "wall damping on": {"effects.wall_damping": True},
        "gravity on": {"effects.gravity": True},
        "contact off (free rod, no wall)": {"effects.contact": False},
        "stabilisation 1e-3": {"solver.stabilisation": 1e-3},
    }
    if args.quick:
        cases = dict(list(cases.items())[:3])
    out["effects"] = []
    for name, ov in cases.items():
        s = scene_with_overrides(base, ov) if ov else base
        r, tt = timed(s, reps)
        out["effects"].append(row(name, r, tt, err_mm(r, res), t))

    print("\n4. dynamic solver (0.5 m/s, inertia, wall damping) vs 4x refined (dt, elements)")
    dyn = scene_with_overrides(base,
        {"solver.kind": "dynamic", "effects.inertia": True, "effects.wall_damping": True,
         "motion.speed_mm_s": 500.0, "solver.time_step_s": 1e-3}
    )  # fmt: skip
    simulate(dyn)
    rd, td = timed(dyn, reps)
    rdr, tdr = timed(refined(dyn, 0.25), 1)
    out["dynamic"] = [row(f"dynamic dt 1 ms ({thin:g}/{thick:g} mm)", rd, td, err_mm(rd, rdr), t),
                      row("dynamic 4x refined (dt 0.25 ms)", rdr, tdr, t_base=td),
                      {"dynamic_vs_quasistatic_mm": err_mm(rd, res)}]  # fmt: skip
    print(f"   dynamic vs quasi-static dwell difference: {err_mm(rd, res):.4f} mm")
    if args.json:
        args.json.write_text(json.dumps(out, indent=2, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
