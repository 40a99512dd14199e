"""One run comparing ldpipe's engine with the alternatives on the same grid, against a reference.

    .venv/bin/python benchmarks/compare.py                 # default: 100x100 grid, ~3-5 min on 2 cores
    .venv/bin/python benchmarks/compare.py --n 40 --n-per-traj 8 --n-ref 30   # quick look

Problem: Barbanis 2 DoF, section U_xpx (y = 0, p_y > 0 from the energy), E = E_c + dE,
M_{1/2} (and the arc-length LD for heyoka), tau = 50 forward.  Writes
benchmarks/results/compare_<time>.{md,json} and latest.{md,json}.

Throughput = trajectory time units integrated / second.  "per core" divides by the process CPU
time (all threads of this process), "total" by the wall time.  Scipy and heyoka here run in one
thread; the engine may use several (its CPU/wall ratio is in the table).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import threading
import time
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
import scipy  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import alternatives as alt  # noqa: E402

from ldpipe.testing import reference_ld as ref  # noqa: E402  (independent of the engine: numpy and scipy only)


# ------------------------------------------------------------------------------------------
def machine_info() -> dict:
    model = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    flags = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("flags"):
                f = line.split(":", 1)[1].split()
                flags = " ".join(x for x in ("avx2", "fma", "avx512f") if x in f)
                break
    except OSError:
        pass
    info = {
        "cpu_model": model,
        "simd_flags": flags,
        "logical_cpus": os.cpu_count(),
        "cpus_available": len(os.sched_getaffinity(0)),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
    }
    try:
        import heyoka as hy

        info["heyoka"] = hy.__version__
        info["heyoka_simd_size"] = hy.recommended_simd_size()
    except ImportError:
        info["heyoka"] = None
    try:
        import numba

        info["numba"] = numba.__version__
        info["numba_threads"] = numba.config.NUMBA_NUM_THREADS
    except ImportError:
        pass
    return info


def section_grid(n, x_range, px_range, energy):
    x = np.linspace(*x_range, n)
    px = np.linspace(*px_range, n)
    X, PX = np.meshgrid(x, px, indexing="ij")
    states, allowed = ref.section_state(X.ravel(), PX.ravel(), energy)
    return states[allowed], allowed


def timed(fn, *args, **kwargs):
    """(result, wall s, process CPU s, peak thread count seen)."""
    peak = [threading.active_count(), _os_threads()]
    w0, c0 = time.perf_counter(), time.process_time()
    out = fn(*args, **kwargs)
    w1, c1 = time.perf_counter(), time.process_time()
    peak.append(_os_threads())
    return out, w1 - w0, c1 - c0, max(peak)


def _os_threads() -> int:
    try:
        return len(os.listdir("/proc/self/task"))
    except OSError:
        return threading.active_count()


def rel_errors(values, reference_values):
    e = np.abs(values - reference_values) / np.abs(reference_values)
    finite = np.isfinite(e)
    if not finite.any():
        return {"err_median": None, "err_worst": None, "n_err": 0, "n_nonfinite": int((~finite).sum())}
    return {"err_median": float(np.median(e[finite])), "err_worst": float(np.max(e[finite])),
            "n_err": int(finite.sum()), "n_nonfinite": int((~finite).sum())}


# ------------------------------------------------------------------------------------------
class Runner:
    def __init__(self, states, ref_idx, ref_ld, ref_arc, tau, only=None):
        self.states, self.ref_idx, self.ref_ld, self.ref_arc, self.tau = states, ref_idx, ref_ld, ref_arc, tau
        self.only = only  # parts of method keys (see ``wanted``); None: every method
        self.rows: list[dict] = []

    def wanted(self, key: str) -> bool:
        """Whether the method with this key runs: every one, or those whose key contains a part of --only."""
        return self.only is None or any(part in key for part in self.only)

    def run(self, group, name, settings, quantity, fn, states_idx=None, **extra):
        """fn(states) -> (ld (N,), time_units, info); states_idx: which grid points (default all)."""
        idx = np.arange(len(self.states)) if states_idx is None else np.asarray(states_idx)
        print(f"  {group:<28} {name:<40} {settings:<28} N={len(idx)} ...", end=" ", flush=True)
        try:
            (ld, time_units, info), wall, cpu, threads = timed(fn, self.states[idx])
        except Exception as exc:  # noqa: BLE001 -- a failing method is a result, not a crash
            print(f"FAILED: {type(exc).__name__}: {exc}")
            self.rows.append({"group": group, "method": name, "settings": settings, "quantity": quantity,
                              "n": int(len(idx)), "error": f"{type(exc).__name__}: {exc}"})
            return None
        ld = np.asarray(ld, float)
        # reference points covered by this run
        pos = {g: k for k, g in enumerate(idx)}
        have = [j for j, g in enumerate(self.ref_idx) if g in pos]
        refv = (self.ref_arc if quantity == "arclength" else self.ref_ld)[have]
        got = ld[[pos[self.ref_idx[j]] for j in have]]
        row = {"group": group, "method": name, "settings": settings, "quantity": quantity,
               "n": int(len(idx)), "wall_s": wall, "cpu_s": cpu, "cpu_per_wall": cpu / wall if wall > 0 else None,
               "threads_seen": threads, "time_units": float(time_units),
               "throughput_total": time_units / wall, "throughput_per_core": time_units / cpu if cpu > 0 else None,
               "n_nonfinite_all": int((~np.isfinite(ld)).sum()), **rel_errors(got, refv),
               "per_core_rounds": [time_units / cpu if cpu > 0 else None], "info": _jsonable(info), **extra}
        key = (group, name, settings, quantity, row["n"])
        previous = next((r for r in self.rows if "error" not in r and
                         (r["group"], r["method"], r["settings"], r["quantity"], r["n"]) == key), None)
        if previous is None:
            row["runs"] = 1
            self.rows.append(row)
        else:  # a repeated round: keep the fastest wall and CPU time seen (errors are reproducible)
            previous["runs"] += 1
            previous["per_core_rounds"].append(time_units / cpu if cpu > 0 else None)
            previous["wall_s"] = min(previous["wall_s"], wall)
            previous["cpu_s"] = min(previous["cpu_s"], cpu)
            previous["cpu_per_wall"] = previous["cpu_s"] / previous["wall_s"]
            previous["throughput_total"] = previous["time_units"] / previous["wall_s"]
            previous["throughput_per_core"] = previous["time_units"] / previous["cpu_s"] if previous["cpu_s"] > 0 else None
            row = previous
        print(f"{wall:7.2f} s wall, {fmt(row['throughput_per_core'], '.3g')} tu/s/core, "
              f"err med {fmt(row['err_median'], '.1e')} worst {fmt(row['err_worst'], '.1e')}")
        return row


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return obj


# ------------------------------------------------------------------------------------------
def run_engine(runner: Runner, tau: float, args) -> list[str]:
    """>>> HOOK: ldpipe's own engine. <<<

    Rows: rk4 dt 0.1, 0.05, 0.01; dop853 rtol 1e-4, 1e-5, 1e-6, 1e-8, 1e-10 (atol = rtol); and
    dop853 1e-6, 1e-8, 1e-10, 1e-12 with the arc-length LD (to put next to heyoka); taylor at
    1e-8, 1e-10, 1e-12 (default order) with M_1/2 and 1e-8 ... 1e-12 by decades with the arc length.  Skipped, with a note, when ldpipe.engine does not
    import.
    """
    notes = []
    try:
        from ldpipe.engine import LDSettings, compute_ld
        from ldpipe.systems import make_system
    except Exception as exc:  # noqa: BLE001
        note = f"ldpipe.engine not importable ({type(exc).__name__}: {exc}); engine rows skipped"
        print("NOTE:", note)
        return [note]
    system = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})

    configs = [
        ("rk4", dict(scheme="rk4", dt=0.1), 0.5, "dt 0.1"),
        ("rk4", dict(scheme="rk4", dt=0.05), 0.5, "dt 0.05"),
        ("rk4", dict(scheme="rk4", dt=0.01), 0.5, "dt 0.01"),
        ("dop853", dict(scheme="dop853", rtol=1e-4, atol=1e-4), 0.5, "rtol 1e-4"),
        ("dop853", dict(scheme="dop853", rtol=1e-5, atol=1e-5), 0.5, "rtol 1e-5"),
        ("dop853", dict(scheme="dop853", rtol=1e-6, atol=1e-6), 0.5, "rtol 1e-6"),
        ("dop853", dict(scheme="dop853", rtol=1e-8, atol=1e-8), 0.5, "rtol 1e-8"),
        ("dop853", dict(scheme="dop853", rtol=1e-10, atol=1e-10), 0.5, "rtol 1e-10"),
        # the smooth arc length at loose tolerances: what M_1/2 would cost with a free cusp quadrature
        ("dop853", dict(scheme="dop853", rtol=1e-4, atol=1e-4), "arclength", "rtol 1e-4"),
        ("dop853", dict(scheme="dop853", rtol=1e-5, atol=1e-5), "arclength", "rtol 1e-5"),
        ("dop853", dict(scheme="dop853", rtol=1e-6, atol=1e-6), "arclength", "rtol 1e-6"),
        ("dop853", dict(scheme="dop853", rtol=1e-8, atol=1e-8), "arclength", "rtol 1e-8"),
        ("dop853", dict(scheme="dop853", rtol=1e-10, atol=1e-10), "arclength", "rtol 1e-10"),
        ("dop853", dict(scheme="dop853", rtol=1e-12, atol=1e-12), "arclength", "rtol 1e-12"),
        ("taylor", dict(scheme="taylor", rtol=1e-8, atol=1e-8), 0.5, "rtol 1e-8"),
        ("taylor", dict(scheme="taylor", rtol=1e-10, atol=1e-10), 0.5, "rtol 1e-10"),
        ("taylor", dict(scheme="taylor", rtol=1e-12, atol=1e-12), 0.5, "rtol 1e-12"),
    ] + [  # a ladder of one decade steps: the work–precision curve of the matched-error table
        ("taylor", dict(scheme="taylor", rtol=rtol, atol=rtol), "arclength", f"rtol {rtol:g}")
        for rtol in args.taylor_arclength_rtols
    ]
    for scheme, kw, p, label in configs:
        if not runner.wanted(f"{scheme} {'arclength' if p == 'arclength' else 'M_1/2'}"):
            continue
        settings = LDSettings(p=p, tau=tau, **kw)

        def fn(states, settings=settings):
            res = compute_ld(system, np.ascontiguousarray(states), direction=+1, settings=settings)
            return np.asarray(res.ld), tau * len(states), {k: v for k, v in res._asdict().items()
                                                            if k != "ld" and np.ndim(v) == 0}

        # warm-up (JIT compilation) on a few points, timed separately
        try:
            _, warm, _, _ = timed(fn, runner.states[:8])
        except Exception as exc:  # noqa: BLE001
            warm = None
            notes.append(f"engine {scheme} {label}: warm-up failed: {exc}")
        quantity = "arclength" if p == "arclength" else "M_1/2"
        runner.run("ldpipe engine", f"engine {scheme}", label, quantity, fn, warmup_s=warm)
    return notes


def run_alternatives(runner: Runner, tau, args, per_traj_idx) -> dict:
    extra = {}
    # a. per-trajectory scipy DOP853
    if runner.wanted("scipy-per-trajectory"):
            runner.run("scipy per trajectory", "solve_ivp DOP853, LD as state", "rtol 1e-8 atol 1e-10", "M_1/2",
                   lambda s: alt.scipy_per_trajectory(s, tau, 0.5, rtol=1e-8, atol=1e-10), states_idx=per_traj_idx)
    # b. flattened grid, RK45 (ldds)
    for rtol in args.flat_rtols if runner.wanted("scipy-flattened") else ():
        runner.run("scipy flattened (ldds)", "solve_ivp RK45, whole grid one system", f"rtol=atol {rtol:g}",
                   "M_1/2", lambda s, rtol=rtol: alt.scipy_flattened(s, tau, 0.5, rtol=rtol))
    # c. heyoka
    try:
        import heyoka as hy
    except ImportError:
        extra["heyoka"] = "not installed"
        print("NOTE: heyoka not installed; heyoka rows skipped")
        return extra
    hy.set_nthreads(1)  # heyoka's own TBB parallelism off; the ensemble row uses a Python thread pool
    for tol in args.heyoka_tols if runner.wanted("heyoka-batch") else ():
        ta, compile_s = alt.heyoka_build(tol, "arclength")
        runner.run("heyoka batch", f"taylor_adaptive_batch (SIMD {ta.batch_size}), arc length",
                   f"tol {tol:g}", "arclength", lambda s, ta=ta, tol=tol: alt.heyoka_batch(s, tau, tol, ta=ta),
                   compile_s=compile_s)
    workers = len(os.sched_getaffinity(0))
    if args.heyoka_tols and runner.wanted("heyoka-ensemble"):  # at the first tolerance given
        ta, compile_s = alt.heyoka_build(args.heyoka_tols[0], "arclength")
        runner.run("heyoka ensemble (threads)", f"ensemble_propagate_until_batch, {workers} threads, arc length",
                   f"tol {args.heyoka_tols[0]:g}", "arclength",
                   lambda s: alt.heyoka_ensemble(s, tau, args.heyoka_tols[0], ta=ta, max_workers=workers),
                   compile_s=compile_s)
    for tol in args.heyoka_tols if runner.wanted("heyoka-p-half") else ():
        ta_plain, c1 = alt.heyoka_build(tol, "arclength")
        ta_half, c2 = alt.heyoka_build(tol, "sqrt_abs")
        runner.run("heyoka batch", f"taylor_adaptive_batch (SIMD {ta_half.batch_size}), p=1/2 from t=1e-6",
                   f"tol {tol:g}", "M_1/2",
                   lambda s, a=ta_plain, b=ta_half, tol=tol: alt.heyoka_p_half_offset(s, tau, tol, ta_plain=a, ta_half=b),
                   compile_s=c1 + c2)
    if runner.wanted("heyoka-p-half"):
        extra["heyoka_p_half_attempt"] = alt.heyoka_p_half_attempt(runner.states[runner.ref_idx[0]], tau)
    extra["heyoka_threads_setting"] = hy.get_nthreads()
    return extra


# ------------------------------------------------------------------------------------------
def matched_accuracy(rows):
    """For every alternative row: the cheapest engine row (per core) at least as accurate (median)."""
    engine = [r for r in rows if r["group"] == "ldpipe engine" and r.get("err_median") is not None]
    out = []
    for r in rows:
        if r["group"] == "ldpipe engine" or r.get("err_median") is None:
            continue
        cands = [e for e in engine if e["quantity"] == r["quantity"] and e["err_median"] <= r["err_median"]]
        if not cands:
            out.append({"alternative": f"{r['method']} {r['settings']}", "alt_err_median": r["err_median"],
                        "engine": None})
            continue
        best = max(cands, key=lambda e: e["throughput_per_core"])
        out.append({"alternative": f"{r['method']} {r['settings']}", "alt_err_median": r["err_median"],
                    "engine": f"{best['method']} {best['settings']}", "engine_err_median": best["err_median"],
                    "ratio_per_core": best["throughput_per_core"] / r["throughput_per_core"],
                    "ratio_total": best["throughput_total"] / r["throughput_total"],
                    "ratio_per_core_rounds": _round_ratios(best, r)})
    return out


def _round_ratios(engine_row, alternative_row):
    """Per-core throughput ratios round by round (the rounds are interleaved, so round i of each ran close in time)."""
    return [e / a for e, a in zip(engine_row["per_core_rounds"], alternative_row["per_core_rounds"]) if e and a]


def loglog_at(points, error):
    """Throughput at ``error`` on a work–precision curve, linear in (log error, log throughput) between
    the two neighbouring (error, throughput) points that bracket it; None outside the curve."""
    points = sorted(points)
    for (e0, t0), (e1, t1) in zip(points, points[1:]):
        if e0 <= error <= e1:
            w = 0.0 if e1 == e0 else (np.log(error) - np.log(e0)) / (np.log(e1) - np.log(e0))
            return float(np.exp((1.0 - w) * np.log(t0) + w * np.log(t1)))
    return None


def work_precision(rows):
    """For every alternative row and every engine scheme with >= 2 rows of its quantity: the engine's
    per-core throughput interpolated log-log at the alternative's median error (the work–precision
    curve through the engine's tolerance ladder), and the ratio engine / alternative, overall (fastest
    times) and round by round."""
    engine = [r for r in rows if r["group"] == "ldpipe engine" and r.get("err_median")]
    out = []
    for r in rows:
        if r["group"] == "ldpipe engine" or not r.get("err_median"):
            continue
        for method in sorted({e["method"] for e in engine if e["quantity"] == r["quantity"]}):
            curve = [e for e in engine if e["method"] == method and e["quantity"] == r["quantity"]]
            if len(curve) < 2:
                continue
            best = loglog_at([(e["err_median"], e["throughput_per_core"]) for e in curve], r["err_median"])
            rounds = []
            for i, alt_round in enumerate(r["per_core_rounds"]):
                points = [(e["err_median"], e["per_core_rounds"][i]) for e in curve if len(e["per_core_rounds"]) > i]
                value = loglog_at(points, r["err_median"]) if len(points) == len(curve) else None
                if value and alt_round:
                    rounds.append(value / alt_round)
            out.append({"alternative": f"{r['method']} {r['settings']}", "alt_err_median": r["err_median"],
                        "engine": method, "engine_errors": [min(e["err_median"] for e in curve), max(e["err_median"] for e in curve)],
                        "engine_per_core": best, "ratio_per_core": None if best is None else best / r["throughput_per_core"],
                        "ratio_per_core_rounds": rounds})
    return out


def _spread(values) -> str:
    return f"{min(values):.3g}–{max(values):.3g}" if values else "—"


def fmt(v, spec=".2g"):
    if v is None:
        return "—"
    return format(v, spec)


def markdown(report) -> str:
    m, a = report["machine"], report["args"]
    L = [f"# LD benchmark: ldpipe engine vs alternatives ({report['timestamp']})", "",
         f"Machine: {m['cpu_model']} ({m['simd_flags']}), {m['cpus_available']} CPUs available "
         f"({m['logical_cpus']} logical); Python {m['python']}, numpy {m['numpy']}, scipy {m['scipy']}, "
         f"heyoka {m.get('heyoka')}, numba {m.get('numba')}.", "",
         f"Problem: Barbanis 2 DoF, U_xpx (y = 0, p_y > 0), E = {report['energy']:g} (ΔE = {a['dE']:g}), "
         f"tau = {a['tau']:g} forward; grid {a['n']}×{a['n']} over x ∈ [{a['x_range'][0]:g}, {a['x_range'][1]:g}], "
         f"p_x ∈ [{a['px_range'][0]:g}, {a['px_range'][1]:g}] → {report['n_allowed']} allowed points.", "",
         f"Reference: {report['reference']['n']} random grid points, DOP853 rtol=atol {report['reference']['rtol']:g} "
         f"+ crossings + Gauss–Jacobi/QAWS quadrature, {report['reference']['wall_s']:.1f} s. "
         f"Its own accuracy (rtol 1e-11 vs 1e-13 on {report['reference_accuracy']['n']} points): M_1/2 "
         f"{report['reference_accuracy']['ld_reldiff_median']:.1e} median / "
         f"{report['reference_accuracy']['ld_reldiff_max']:.1e} worst; arc length "
         f"{report['reference_accuracy']['arclength_reldiff_median']:.1e} / "
         f"{report['reference_accuracy']['arclength_reldiff_max']:.1e}.", "",
         "Throughput in trajectory time units per second; *per core* = per CPU-second of this process "
         "(all its threads), *total* = per wall second. Error = |LD − ref| / ref on the reference points "
         "the method covered (n err). Compile/JIT time is excluded and listed separately.", "",
         "| method | settings | LD | N | wall s | CPU/wall | tu/s per core | tu/s total | err median | err worst | n err | non-finite | compile s |",
         "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in report["rows"]:
        if "error" in r:
            L.append(f"| {r['method']} | {r['settings']} | {r['quantity']} | {r['n']} | failed: {r['error']} |"
                     + " |" * 8)
            continue
        comp = r.get("compile_s", r.get("warmup_s"))
        L.append(f"| {r['method']} | {r['settings']} | {r['quantity']} | {r['n']} | {r['wall_s']:.2f} | "
                 f"{fmt(r['cpu_per_wall'], '.2f')} | {fmt(r['throughput_per_core'], '.3g')} | "
                 f"{fmt(r['throughput_total'], '.3g')} | {fmt(r['err_median'], '.1e')} | {fmt(r['err_worst'], '.1e')} | "
                 f"{r['n_err']} | {r['n_nonfinite_all']} | {fmt(comp, '.2f')} |")
    L += ["", "## Engine vs alternative at matched accuracy", ""]
    if not any(r["group"] == "ldpipe engine" for r in report["rows"]):
        L.append("No engine rows (see notes).")
    else:
        L += ["For each alternative: the fastest engine row (per core) whose median error is no larger, and "
              "the throughput ratio engine / alternative.", "",
              "| alternative | its err median | engine row | engine err median | ratio per core | per core, rounds min–max | ratio total |",
              "| --- | ---: | --- | ---: | ---: | ---: | ---: |"]
        for x in report["matched"]:
            L.append(f"| {x['alternative']} | {x['alt_err_median']:.1e} | {x['engine'] or '—'} | "
                     f"{fmt(x.get('engine_err_median'), '.1e')} | {fmt(x.get('ratio_per_core'), '.3g')} | "
                     f"{_spread(x.get('ratio_per_core_rounds'))} | {fmt(x.get('ratio_total'), '.3g')} |")
        L += ["", "## Engine vs alternative on the work–precision curve", "",
              "For each alternative and engine scheme with a tolerance ladder: the engine's per-core throughput "
              "interpolated log-log (log throughput linear in log median error) between the two ladder rows that "
              "bracket the alternative's median error; — where the ladder does not reach it. Not a rule that "
              "picks a row: a row whose median error is a hair above the alternative's counts by how close it is.", "",
              "| alternative | its err median | engine | engine err medians (ladder) | engine tu/s per core there | ratio per core | per core, rounds min–max |",
              "| --- | ---: | --- | --- | ---: | ---: | ---: |"]
        for x in report.get("work_precision", []):
            L.append(f"| {x['alternative']} | {x['alt_err_median']:.1e} | {x['engine']} | "
                     f"{x['engine_errors'][0]:.1e} – {x['engine_errors'][1]:.1e} | {fmt(x['engine_per_core'], '.3g')} | "
                     f"{fmt(x['ratio_per_core'], '.3g')} | {_spread(x['ratio_per_core_rounds'])} |")
    ev = report.get("alternatives_extra", {}).get("heyoka_p_half_attempt")
    if ev:
        L += ["", "## heyoka with the p = 1/2 integrand (scalar integrator, tol 1e-10)", "",
              "| start | integrand | outcome | steps | min h | t reached | LD |", "| --- | --- | --- | ---: | ---: | ---: | ---: |"]
        for e in ev:
            if "error" in e:
                L.append(f"| {e['start']} | {e['integrand']} | {e['error']} | | | | |")
            else:
                L.append(f"| {e['start']} | {e['integrand']} | {e['outcome']} | {e['n_steps']} | {e['min_h']:.2g} | "
                         f"{e['t_reached']:.4g} | {e['ld']:.10g} |")
        L += ["", f"Section start point velocity at t = 0: {ev[0]['velocity0']} (dp_y/dt = 0 exactly since y = 0)."]
    if report["notes"]:
        L += ["", "## Notes", ""] + [f"- {n}" for n in report["notes"]]
    return "\n".join(L) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=100, help="grid points per side for the fast methods (default 100)")
    ap.add_argument("--n-per-traj", type=int, default=20, help="points for per-trajectory solve_ivp (default 20)")
    ap.add_argument("--n-ref", type=int, default=60, help="reference points, a random subset of the grid (default 60)")
    ap.add_argument("--n-ref-accuracy", type=int, default=8, help="reference points re-run at rtol 1e-11 (default 8)")
    ap.add_argument("--tau", type=float, default=50.0)
    ap.add_argument("--dE", type=float, default=-0.125, help="excess energy E - E_c (default -0.125)")
    ap.add_argument("--x-range", type=float, nargs=2, default=[-5.6, 5.6])
    ap.add_argument("--px-range", type=float, nargs=2, default=[-5.6, 5.6])
    ap.add_argument("--flat-rtols", type=float, nargs="*", default=[1e-4, 1e-6, 1e-8])
    ap.add_argument("--heyoka-tols", type=float, nargs="*", default=[1e-10, 1e-8, 1e-6])
    ap.add_argument("--taylor-arclength-rtols", type=float, nargs="*", default=[1e-8, 1e-9, 1e-10, 1e-11, 1e-12],
                    help="rtols of ldpipe's Taylor rows with the arc length; each picks its order, one engine "
                         "module per order (default: the decades 1e-8 to 1e-12)")
    ap.add_argument("--repeat", type=int, default=1,
                    help="rounds over all methods (interleaved); each row keeps its fastest wall and CPU time")
    ap.add_argument("--no-engine", action="store_true", help="skip the ldpipe engine rows")
    ap.add_argument("--only", nargs="+", metavar="PART", default=None,
                    help="the methods whose key contains a part (keys in benchmarks/README.md), e.g. "
                         "--only 'taylor arclength' heyoka-batch (default: all)")
    ap.add_argument("--seed", type=int, default=12345)
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)

    energy = ref.E_SADDLE + args.dE
    states, _ = section_grid(args.n, args.x_range, args.px_range, energy)
    rng = np.random.default_rng(args.seed)
    ref_idx = rng.choice(len(states), size=min(args.n_ref, len(states)), replace=False)
    print(f"grid {args.n}x{args.n}: {len(states)} allowed points; reference on {len(ref_idx)}")

    t0 = time.perf_counter()
    ref_ld, ref_arc = ref.reference_ld_many(states[ref_idx], args.tau, 0.5)
    ref_wall = time.perf_counter() - t0
    print(f"reference: {ref_wall:.1f} s")
    acc = ref.estimate_accuracy(states[ref_idx[:args.n_ref_accuracy]], args.tau, 0.5)
    print("reference accuracy:", acc)

    runner = Runner(states, ref_idx, ref_ld, ref_arc, args.tau, args.only)
    notes = []
    load_before = os.getloadavg()
    for round_ in range(args.repeat):
        print(f"round {round_ + 1} of {args.repeat}, load average {os.getloadavg()[0]:.2f}")
        round_notes = []
        if args.no_engine:
            round_notes.append("engine rows skipped (--no-engine)")
        else:
            round_notes += run_engine(runner, args.tau, args)
        extra = run_alternatives(runner, args.tau, args, ref_idx[:args.n_per_traj])
    notes += round_notes
    if args.only:
        notes.append(f"methods run: --only {' '.join(args.only)}")
    if args.repeat > 1:
        notes.append(f"{args.repeat} interleaved rounds over all methods; every row shows its fastest wall and CPU time.")
    notes.append(f"load average (1, 5, 15 min) at the start {tuple(round(v, 2) for v in load_before)}, "
                 f"at the end {tuple(round(v, 2) for v in os.getloadavg())} (2 CPUs).")
    notes.append("scipy and heyoka batch rows run in this single process on one thread (heyoka.set_nthreads(1)); "
                 "per-core and total throughput coincide up to interpreter overhead. The 'heyoka ensemble' row "
                 "uses heyoka's thread pool over all available CPUs: compare its total column.")
    notes.append("heyoka rows integrate the arc-length LD (errors against the arc-length reference) or, "
                 "for 'p=1/2 from t=1e-6', M_1/2 after a shift of the start off the section (see alternatives.py).")

    report = {
        "timestamp": time.strftime("%Y-%m-%dT%H:%M:%S"),
        "machine": machine_info(),
        "args": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
        "energy": energy,
        "n_allowed": int(len(states)),
        "reference": {"n": int(len(ref_idx)), "rtol": 1e-13, "wall_s": ref_wall,
                      "states": states[ref_idx].tolist(), "ld": ref_ld.tolist(), "arclength": ref_arc.tolist()},
        "reference_accuracy": acc,
        "rows": runner.rows,
        "matched": matched_accuracy(runner.rows),
        "work_precision": work_precision(runner.rows),
        "alternatives_extra": _jsonable(extra),
        "notes": notes,
    }
    args.out.mkdir(parents=True, exist_ok=True)
    stamp = time.strftime("%Y%m%d-%H%M%S")
    md = markdown(report)
    for stem in (f"compare_{stamp}", "latest"):
        (args.out / f"{stem}.json").write_text(json.dumps(_jsonable(report), indent=1, allow_nan=True))
        (args.out / f"{stem}.md").write_text(md)
    print()
    print(md)
    print(f"written: {args.out / f'compare_{stamp}.md'} and .json")


if __name__ == "__main__":
    main()
