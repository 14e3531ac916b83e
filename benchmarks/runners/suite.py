"""The femb benchmark suite: run time against error, and numerical-stability stress tests.

One command runs everything and writes a report folder::

    femb bench [--quick] [--out DIR]                    # the command line
    python -m femb.benchmarks.runners.suite [--quick] [--out DIR] [--only PART,...]

The folder (default ``bench-report/``) holds ``report.md`` (tables, verdicts,
figures embedded), ``results.json`` (every number) and the PNG figures. Every
figure in it is produced by that one command. ``--quick`` (about a minute on
2 cores) runs a small set at reduced size (:data:`QUICK_SCENES`, :data:`QUICK_PARTS`:
the work–precision study of one scene per family (planar and spatial rigid bodies,
beams), the spatial per-step timing and the four cheapest stress
tests) with fewer step sizes, one timing repeat and shorter long runs; it prints what
it leaves out when it starts, and the report says it again; ``--quick --only
PART,...`` runs any parts at the reduced size. The full suite takes well under
30 minutes.

Parts
-----
``work_precision``
    For every scene of the registry (read at run time): wall time against
    the error at t_end and the maximum error over the run, for positions,
    velocities and multipliers, femb at ρ∞ ∈ {0, 0.5, 0.7, 0.9} with scaling on
    and off, femb's adaptive steps over a ladder of rtol beside them, and the
    peers (:mod:`femb.benchmarks.peers`) measured in the same run
    (:mod:`femb.benchmarks.runners.work_precision`, :mod:`femb.benchmarks.runners.adaptive_suite`).
``headline``
    Wall time to bring Andrews' seven angles to 1e-6 rad at t = 0.03 s, femb
    against each peer, as ratios; and femb's adaptive steps against its best
    fixed step to the same target (steps and wall time).
``spatial_per_step``
    ms per step of femb and of Exudyn on the 400-brick chain of Exudyn's
    perf3DRigidBodies (:mod:`femb.benchmarks.scenes.spatial.rigid_chain_3d`: the same model,
    h = 1e-3 s, ρ∞ = 0.8, 1 s, in quick mode 0.05 s; median of 3 interleaved
    warm runs) and their ratio, the spatial counterpart of the headline.
stress tests
    :data:`femb.benchmarks.runners.stress.TESTS` (the adaptive-step tests of
    :mod:`femb.benchmarks.runners.adaptive_suite` included), each with its pass/fail
    criteria and a verdict (PASS / FAIL / FINDING) next to the measured figures.

The exit status is 0 when the report was written (the verdicts are in it), 2
for bad arguments.
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import sys
import time
from pathlib import Path

from femb.benchmarks import peers
from femb.benchmarks.runners import adaptive_suite, stress, work_precision
from femb.benchmarks.runners.work_precision import clean, first_line

#: Parts of the suite, in run order (stress tests follow).
PARTS = ("work_precision", "headline", "spatial_per_step") + tuple(stress.TESTS)

#: what ``--quick`` runs without ``--only``: the work–precision study of one scene of each family (planar
#: rigid bodies: the pendulum, whose reference is exact; spatial rigid bodies: the heavy top; beams: the
#: flexible slider–crank; 4–6 s of CPU time each, figures included), the spatial per-step timing of
#: the 400-brick chain and the four cheapest stress tests (1–4 s of CPU time each)
QUICK_SCENES = ("pendulum", "heavy_top", "flexible_slider_crank")
QUICK_PARTS = ("work_precision", "spatial_per_step", "dead_centre", "long_runs", "units",
               "tolerance_proportionality")

#: spatial per-step part: (bricks, t_end in s) per mode, h = 1e-3 s, ρ∞ = 0.8, 3 timed runs
SPATIAL_PER_STEP = {"full": (400, 1.0), "quick": (400, 0.05)}
SPATIAL_RUNS = 3


def _log_fn(enabled):
    def log(msg):
        if enabled:
            print(msg, file=sys.stderr, flush=True)
    return log


def _progress_factory(enabled):
    """femb.io.progress, tolerant of an unknown total (None)."""
    from femb.io.progress import PlainProgress, progress

    def make(total, desc):
        if total is None:
            return PlainProgress(None, total=None, desc=desc, enabled=enabled)
        return progress(int(total), desc, enabled=enabled)
    return make


def _machine():
    import numpy
    import scipy

    try:
        import femb
        fv = femb.__version__
    except Exception:   # pragma: no cover
        fv = "unknown"
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {"python": platform.python_version(), "platform": platform.platform(), "cpu": cpu,
            "cores": os.cpu_count(), "numpy": numpy.__version__, "scipy": scipy.__version__, "femb": fv}


def plan(quick=False, only=None):
    """The parts and the work–precision scenes a run covers.

    Parameters
    ----------
    quick : bool
        Without ``only``: :data:`QUICK_PARTS` and :data:`QUICK_SCENES`.
    only : iterable of str, optional
        Parts to run (every registry scene for ``work_precision``; ``headline`` alone
        studies Andrews).

    Returns
    -------
    parts : list of str
        In :data:`PARTS` order.
    scenes : list of str
    """
    from femb.study.registry import names

    wanted = set(only) if only else set(QUICK_PARTS if quick else PARTS)
    parts = [p for p in PARTS if p in wanted]
    if "work_precision" in parts:
        scenes = list(QUICK_SCENES) if quick and not only else names()
    else:
        scenes = ["andrews"] if "headline" in parts else []
    return parts, scenes


def run_suite(quick=False, out="bench-report", progress=True, only=None):
    """Run the benchmark suite and write the report folder.

    Parameters
    ----------
    quick : bool
        Short mode (about a minute on 2 cores): without ``only``, the parts and
        scenes of :func:`plan`; every part with fewer step sizes and tolerances,
        one repeat, 2·10⁴ instead of 10⁶ steps in the long runs; the report says
        what was shortened and what was left out.
    out : str or Path
        Report folder; created if needed (files in it are overwritten).
    progress : bool
        Print progress on stderr while running.
    only : iterable of str, optional
        Run only these parts (names of :data:`PARTS`; ``headline`` needs
        ``work_precision`` of Andrews and runs it if needed).

    Returns
    -------
    dict
        The content of ``results.json``: ``suite`` (command, mode, machine,
        peers, wall time), ``work_precision`` (scene -> study),
        ``headline``, ``spatial_per_step`` (:func:`femb.benchmarks.scenes.spatial.rigid_chain_3d.measure`),
        ``stress`` (test id -> result with ``criteria``),
        ``verdicts`` (counts), ``report`` (path of report.md).
    """
    from femb.study.registry import names

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    unknown = sorted(set(only or ()) - set(PARTS))
    if unknown:
        raise ValueError(f"unknown part(s) {', '.join(unknown)}; known: {', '.join(PARTS)}")
    parts, scenes = plan(quick, only)
    log = _log_fn(progress)
    make_progress = _progress_factory(progress)
    mode = "quick" if quick else "full"
    cmd = "femb bench" + (" --quick" if quick else "") + (f" --out {out}" if str(out) != "bench-report" else "")
    if only:
        cmd = (f"python -m femb.benchmarks.runners.suite{' --quick' if quick else ''} --out {out} "
               f"--only {','.join(parts)}")
    t_start = time.perf_counter()
    results = {"suite": {"command": cmd, "mode": mode, "parts": parts,
                         "started": datetime.datetime.now().isoformat(timespec="seconds"),
                         "machine": _machine(), "peers": peers.status()},
               "work_precision": {}, "headline": None, "spatial_per_step": None, "stress": {}}
    results["suite"]["left_out"] = {"parts": [p for p in PARTS if p not in parts],
                                    "scenes": [s for s in names() if s not in scenes]}
    if quick and not only:
        left = results["suite"]["left_out"]
        log(f"femb bench --quick: work-precision of {', '.join(scenes)}; parts {', '.join(parts)}. Left out: "
            f"parts {', '.join(left['parts'])}; the work-precision studies of {', '.join(left['scenes'])} "
            "(`femb bench` runs everything, `python -m femb.benchmarks.runners.suite --quick --only PART,...` "
            "any part at this size)")
    tasks = [("wp", s) for s in scenes] + ([("headline", None)] if "headline" in parts else []) + \
            ([("spatial", None)] if "spatial_per_step" in parts else []) + \
            [("stress", p) for p in parts if p in stress.TESTS]
    ctx = stress.Context(quick=quick, out=out, log=log, progress=make_progress)
    with make_progress(len(tasks), "femb bench") as bar:
        for i, (kind, arg) in enumerate(tasks, 1):
            t0, c0 = time.perf_counter(), time.process_time()
            label = {"wp": f"work-precision: {arg}", "headline": "headline: time to 1e-6 rad on Andrews",
                     "spatial": "spatial per step: Exudyn's 400-brick chain",
                     "stress": f"stress test: {arg}"}[kind]
            log(f"femb bench [{i}/{len(tasks)}] {label} ...")
            if kind == "wp":
                try:
                    wp = work_precision.study(arg, quick=quick, log=log)
                    wp["figure"] = work_precision.figure(wp, out / f"wp_{arg}.png").name
                    if (wp.get("adaptive") or {}).get("points"):
                        wp["figure_adaptive"] = work_precision.adaptive_figure(
                            wp, out / f"wp_adaptive_{arg}.png").name
                except Exception as exc:    # one broken scene must not stop the suite
                    import traceback

                    wp = {"scene": arg, "error": f"{type(exc).__name__}: {first_line(exc)}",
                          "traceback": traceback.format_exc()}
                    log(f"  {arg}: FAILED: {wp['error']}")
                wp["wall_s"] = time.perf_counter() - t0
                results["work_precision"][arg] = clean(wp)
            elif kind == "headline":
                wpa = results["work_precision"].get("andrews")
                if not wpa or "error" in wpa:
                    wpa = work_precision.study("andrews", quick=True, log=log)
                try:
                    hl = work_precision.headline(wpa, quick=quick, log=log)
                    hl["figure"] = work_precision.headline_figure(hl, out / "headline.png").name
                except Exception as exc:
                    hl = {"error": f"{type(exc).__name__}: {first_line(exc)}", "codes": [], "ratios": {}}
                try:        # Andrews to the same target with adaptive steps, against femb's fixed run
                    fixed = next((c for c in hl.get("codes", []) if c["code"] == "femb"), None)
                    hl["adaptive"] = adaptive_suite.andrews_to_target(quick=quick, fixed=fixed, log=log)
                except Exception as exc:
                    hl["adaptive"] = {"error": f"{type(exc).__name__}: {first_line(exc)}"}
                hl["wall_s"] = time.perf_counter() - t0
                results["headline"] = clean(hl)
            elif kind == "spatial":
                from femb.benchmarks.scenes.spatial import rigid_chain_3d

                n_b, t_sp = SPATIAL_PER_STEP[mode]
                try:
                    sp = rigid_chain_3d.measure(n=n_b, t_end=t_sp, h=1e-3, rho_inf=0.8, runs=SPATIAL_RUNS,
                                                log=lambda m: log("  " + m))
                except Exception as exc:
                    sp = {"error": f"{type(exc).__name__}: {first_line(exc)}"}
                sp["wall_s"] = time.perf_counter() - t0
                results["spatial_per_step"] = clean(sp)
            else:
                results["stress"][arg] = stress.run(arg, ctx)
                v = [c["verdict"] for c in results["stress"][arg]["criteria"]]
                log(f"  {arg}: " + ", ".join(f"{k} {v.count(k)}" for k in (stress.PASS, stress.FINDING, stress.FAIL)
                                             if v.count(k)))
            log(f"  ({time.perf_counter() - t0:.1f} s, CPU {time.process_time() - c0:.1f} s)")
            bar.update(1)
    counts = {stress.PASS: 0, stress.FAIL: 0, stress.FINDING: 0}
    for r in results["stress"].values():
        for c in r["criteria"]:
            counts[c["verdict"]] += 1
    results["verdicts"] = counts
    results["suite"]["wall_s"] = time.perf_counter() - t_start
    results["report"] = str(out / "report.md")
    results = clean(results)
    (out / "results.json").write_text(json.dumps(results, indent=1) + "\n")
    (out / "report.md").write_text(render_report(results))
    log(f"femb bench: wrote {out / 'report.md'} and {out / 'results.json'} "
        f"({results['suite']['wall_s']:.0f} s; verdicts: PASS {counts['PASS']}, FINDING {counts['FINDING']}, "
        f"FAIL {counts['FAIL']})")
    return results


# --------------------------------------------------------------------------
# report
# --------------------------------------------------------------------------
def _f(x, spec=".3g"):
    if x is None:
        return "–"
    try:
        return format(float(x), spec)
    except (TypeError, ValueError):
        return str(x)


def _md(text):
    return str(text).replace("|", "\\|").replace("\n", " ")


def _verdict(v):
    return f"**{v}**"


def _wp_rows(series_label, p, key):
    e = p["errors"]
    count = p.get("steps") or p.get("nfev")
    cells = [series_label, _f(p.get(key), ".3g"), str(int(count)) if count else "–", _f(p.get("wall_s"), ".3g")]
    if p.get("failed"):
        return "| " + " | ".join(cells + [f"failed: {_md(p['failed'])[:90]}"] + [""] * 5) + " |"
    for g in work_precision.GROUPS:
        cells += [_f(e[g]["final_rel"], ".2e"), _f(e[g]["max_rel"], ".2e")]
    return "| " + " | ".join(cells) + " |"


def _order(points, group):
    from femb.benchmarks.accuracy.convergence import fit_order

    pts = [p for p in points if p.get("failed") is None and p["errors"][group]["final_rel"]]
    return fit_order([p["h"] for p in pts], [p["errors"][group]["final_rel"] for p in pts])


def _adaptive_table(wp):
    """Fixed (ρ∞ = 0.7, scaled) against adaptive steps of one scene: steps, wall time, max errors."""
    ad = wp["adaptive"]
    L = [f"Fixed against adaptive steps (ρ∞ = 0.7; adaptive: rtol = atol, h_max = "
         f"{_f(ad.get('h_max')) if ad.get('h_max') else 'none'}, errors at the same sample times, interpolated "
         "between accepted steps; steps include the rejected ones):", "",
         "| run | h [s] / rtol | steps (rejected) | wall [s] | pos. max | vel. max | mult. max |",
         "|---|---|---|---|---|---|---|"]
    fixed = next((s for s in wp["femb"] if s["rho_inf"] == 0.7 and s["scaling"]), None)
    rows = [("fixed", p, "h") for p in (fixed or {}).get("points", [])] + [("adaptive", p, "rtol")
                                                                           for p in ad["points"]]
    for kind, p, key in rows:
        if p.get("failed"):
            L.append(f"| {kind} | {_f(p.get(key))} | failed: {_md(p['failed'])[:90]} | | | | |")
            continue
        e = p["errors"]
        rej = f" ({p['rejected']})" if kind == "adaptive" else ""
        L.append(f"| {kind} | {_f(p.get(key))} | {p.get('steps')}{rej} | {_f(p.get('wall_s'))} | "
                 f"{_f(e['positions']['max_rel'], '.2e')} | {_f(e['velocities']['max_rel'], '.2e')} | "
                 f"{_f(e['multipliers']['max_rel'], '.2e')} |")
    return "\n".join(L)


def _spatial_sentence(sp):
    """One line: femb and Exudyn ms/step on the chain and the ratio."""
    head = (f"Spatial per step ({sp['n']} twisted bricks on revolute joints, Exudyn's perf3DRigidBodies, "
            f"{sp['steps']} steps of {sp['h']:g} s): femb {_f(sp['femb_ms'])} ms/step")
    if sp.get("ratio") is None:
        return head + f"; Exudyn: {sp.get('message') or 'not measured'}."
    tail = f"; Exudyn {_f(sp['exudyn_ms'])} ms/step; femb time / Exudyn time: **{_f(sp['ratio'])}**"
    dflt = (sp.get("exudyn") or {}).get("default")
    if dflt:
        tail += f" ({_f(dflt['ratio'])} against Exudyn with its default Newton tolerances)"
    return head + tail + "."


def _spatial_section(sp):
    """Markdown section of the spatial per-step part (:func:`femb.benchmarks.scenes.spatial.rigid_chain_3d.measure`)."""
    if sp.get("error"):
        return f"The spatial per-step measurement failed: {_md(sp['error'])}"
    L = [f"The chain of `femb.benchmarks.scenes.spatial.rigid_chain_3d` ({sp['n']} bricks, {6 * sp['n']} velocities, "
         f"{5 * sp['n']} constraint rows; Exudyn's TestModels/perf3DRigidBodies.py) from rest, generalized-α "
         f"ρ∞ = {sp['rho_inf']:g}, h = {sp['h']:g} s, {sp['steps']} steps (t_end = {sp['t_end']:g} s), both codes "
         f"in this process, timed in turn, median of {sp['runs']} warm runs (`time.perf_counter` around femb's "
         "`simulate`, consistent initial values included, and around Exudyn's `SolveDynamic`; model construction "
         f"excluded). Exudyn {sp.get('exudyn_version')}: Euler-parameter nodes, index 3, sparse LU, modified Newton, "
         f"{sp.get('exudyn_threads', 1)} thread. `python -m femb.benchmarks.scenes.spatial.rigid_chain_3d --runs 5` prints the same.",
         "", "| code | Newton setting | Newton it./step | ms/step | runs [ms/step] | femb time / this time |",
         "|---|---|---|---|---|---|",
         f"| femb | default (correction test) | {_f(sp['femb_newton'], '.2f')} | {_f(sp['femb_ms'])} | "
         f"{', '.join(_f(x) for x in sp['femb_runs'])} | 1 |"]
    for key, e in (sp.get("exudyn") or {}).items():
        L.append(f"| Exudyn | {key}: {_md(e['newton_tolerances'])} | {_f(e.get('newton'), '.2f')} | {_f(e['ms'])} | "
                 f"{', '.join(_f(x) for x in e['runs'])} | {_f(e['ratio'])} |")
    if not sp.get("exudyn"):
        L.append(f"| Exudyn | {_md(sp.get('message') or 'not measured')} | | | | |")
    L.append("")
    L.append(f"femb's time loop alone: {_f(sp.get('femb_loop_ms'))} ms/step; its consistent initial values: "
             f"{_f(sp.get('femb_init_ms'))} ms per run (included above).")
    return "\n".join(L)


def render_report(res):
    """Markdown report from the results dict (see :func:`run_suite`)."""
    s = res["suite"]
    m = s["machine"]
    L = []
    L.append("# femb benchmark report")
    L.append("")
    L.append(f"Produced by **`{s['command']}`** ({s['mode']} mode) on {s['started']}, in "
             f"{s.get('wall_s', 0):.0f} s. Every figure and number below comes from this one run; "
             "`results.json` beside this file holds every number.")
    L.append("")
    L.append(f"Machine: {m['cpu']}, {m['cores']} cores; Python {m['python']}, numpy {m['numpy']}, scipy {m['scipy']}, "
             f"femb {m['femb']}. Peers: scipy {s['peers']['scipy']['version']}; Exudyn "
             f"{s['peers']['exudyn']['version']}.")
    if s["mode"] == "quick":
        L.append("")
        L.append("**Quick mode**: fewer step sizes and tolerances, ρ∞ ∈ {0, 0.5, 0.7, 0.9} with scaling on and "
                 "ρ∞ = 0.7 with scaling off, one timing repeat, stiff-spring and mass-ratio runs over 0.25 s instead "
                 "of 1 s, long runs of 20,000 steps instead of 1,000,000, the spatial per-step timing over 50 steps "
                 "instead of 1000. Run `femb bench` for the full suite.")
        left = s.get("left_out") or {}
        if left.get("parts") or left.get("scenes"):
            L.append("")
            L.append("Left out of this run: " + "; ".join(
                x for x in (("parts " + ", ".join(f"`{p}`" for p in left.get("parts", []))) if left.get("parts") else "",
                            ("the work–precision studies of " + ", ".join(left.get("scenes", [])))
                            if left.get("scenes") else "") if x)
                     + ". `python -m femb.benchmarks.runners.suite --quick --only PART,...` runs any of them at this size.")
    L.append("")
    L.append("Timing: `time.perf_counter` around the integration call of each code (femb `simulate` including its "
             "consistent initial values; scipy `solve`; Exudyn `SolveDynamic`), model construction excluded, median "
             "of repeats. Verdicts: **PASS** criterion met; **FAIL** not met; **FINDING** not met, with the cause "
             "measured and described (a femb defect or a limitation of the method).")
    # ---- summary
    L.append("")
    L.append("## Summary")
    L.append("")
    hl = res.get("headline")
    if hl and hl.get("codes"):
        fe = hl["codes"][0]
        parts = []
        for c in hl["codes"][1:]:
            r = hl["ratios"].get(c["code"])
            parts.append(f"{c['code']} {_f(r, '.3g')}×" if r else f"{c['code']}: "
                         + ("not installed" if "not installed" in str(c.get("setting")) else "not reached"))
        L.append(f"* Headline: femb reaches {hl['target']:g} rad on Andrews' angles in {_f(fe.get('wall_s'))} s; "
                 f"femb time / peer time: {'; '.join(parts)}.")
    ha = (hl or {}).get("adaptive") or {}
    if ha.get("goals"):
        L.append(f"* Andrews to {ha['target']:g} rad with adaptive steps: {ha['adaptive']['steps']} steps "
                 f"(rtol {ha['adaptive']['rtol']:.3g}), {_f(ha['adaptive']['wall_s'])} s, against {ha['fixed']['steps']} "
                 f"fixed steps, {_f(ha['fixed']['wall_s'])} s (steps ratio {ha['steps_ratio']:.2f}, wall-time ratio "
                 f"{ha['wall_ratio']:.2f}).")
    sp = res.get("spatial_per_step")
    if sp and not sp.get("error"):
        L.append(f"* {_spatial_sentence(sp)}")
    v = res.get("verdicts", {})
    L.append(f"* Stress-test criteria: {v.get('PASS', 0)} PASS, {v.get('FINDING', 0)} FINDING, {v.get('FAIL', 0)} FAIL.")
    if res["stress"]:
        L.append("")
        L.append("| stress test | PASS | FINDING | FAIL | time [s] |")
        L.append("|---|---|---|---|---|")
        for tid, r in res["stress"].items():
            vv = [c["verdict"] for c in r["criteria"]]
            L.append(f"| [{_md(r['title'])}](#stress-{tid.replace('_', '-')}) | {vv.count('PASS')} | "
                     f"{vv.count('FINDING')} | {vv.count('FAIL')} | {_f(r.get('wall_s'), '.1f')} |")
    # ---- headline
    if hl:
        L.append("")
        L.append("## Headline: time to 1e-6 rad on Andrews' angles")
        L.append("")
        if hl.get("error"):
            L.append(f"The headline measurement failed: {_md(hl['error'])}")
        else:
            L.append(f"Error metric: {hl['metric']}. Timing: {hl['timing']} ({hl['repeats']} repeat(s)). "
                     "Fixed-step codes: the step count predicted from the h² law of the sweep, raised by 10 % until "
                     "the target is met; scipy: the largest tolerance meeting it, refined in quarter decades.")
            L.append("")
            L.append("| code | setting | steps / tol | error [rad] | wall time [s] | femb time / this time |")
            L.append("|---|---|---|---|---|---|")
            for c in hl["codes"]:
                st = (f"{c['steps']} steps (h = {c['h']:.3g} s)" if c.get("steps") else
                      (f"tol {c['tol']:.3g}" if c.get("tol") else "–"))
                ratio = "1" if c["code"] == "femb" else _f(hl["ratios"].get(c["code"]), ".3g")
                wall = _f(c.get("wall_s")) if c.get("reached") else ("not installed" if "not installed" in
                                                                     str(c.get("setting")) else "not reached")
                L.append(f"| {c['code']} | {_md(c.get('setting', ''))} | {st} | {_f(c.get('error'), '.2e')} | "
                         f"{wall} | {ratio} |")
            if hl.get("figure"):
                L.append("")
                L.append(f"![headline]({hl['figure']})")
        ha = hl.get("adaptive")
        if ha:
            L.append("")
            L.append("### Adaptive against fixed steps (femb)")
            L.append("")
            if ha.get("error"):
                L.append(f"The adaptive measurement failed: {_md(ha['error'])}")
            else:
                L.append("The largest rtol (= atol) reaching the target (quarter decades from 1e-9, tighter until met or "
                         "looser while met, then three bisections in log rtol) against the best fixed step (the "
                         "run above lowered in 2 % decrements while the target is met). Also printed by "
                         "`python -m femb.benchmarks.runners.adaptive_suite`.")
                L.append("")
                L.append(adaptive_suite.format_andrews(ha))
    # ---- spatial per step
    if sp:
        L.append("")
        L.append("## Spatial per step: Exudyn's 400-brick chain")
        L.append("")
        L.append(_spatial_section(sp))
    # ---- work precision
    if res["work_precision"]:
        L.append("")
        L.append("## Work–precision diagrams")
        L.append("")
        L.append("Errors are relative, in the max norm over each group of outputs: *final* = at t_end, *max* = the "
                 "largest over the sample times of the run (definitions in `femb.benchmarks.runners.work_precision`). "
                 "Solid lines: femb scaled; dashed: unscaled; dotted ×: Exudyn; dash-dot: scipy. Errors below the accuracy "
                 "of the reference measure the reference, not the code: Andrews' published values are good to about "
                 "3e-10 relative in the angles and 5e-8 in the rates at t = 0.03 s, the scipy references elsewhere "
                 "to about 1e-10.")
        for name, wp in res["work_precision"].items():
            L.append("")
            L.append(f"### {name}")
            L.append("")
            if wp.get("error"):
                L.append(f"The study of this scene failed: {_md(wp['error'])}")
                continue
            L.append(f"{_md(wp.get('description', '')).rstrip('.')}. t_end = {wp['t_end']:g} s, {wp['n_samples'] + 1} sample "
                     f"times, {wp['repeats']} timing repeat(s). Reference: {_md(wp['reference'])}.")
            if wp.get("note"):
                L.append(f"Note: {_md(wp['note'])}.")
            g = wp["groups"]
            L.append(f"Groups: positions = {', '.join(g['positions']) or '–'}; velocities = "
                     f"{', '.join(g['velocities']) or '–'}; multipliers = {', '.join(g['multipliers']) or '–'}.")
            L.append(f"Peers: scipy: {_md(wp['scipy']['status'])}; Exudyn: {_md(wp['exudyn']['status'])}.")
            if wp.get("figure"):
                L.append("")
                L.append(f"![work-precision {name}]({wp['figure']})")
            ad = wp.get("adaptive") or {}
            if ad.get("error"):
                L.append("")
                L.append(f"The adaptive series failed: {_md(ad['error'])}")
            elif ad.get("points"):
                L.append("")
                L.append(_adaptive_table(wp))
                if wp.get("figure_adaptive"):
                    L.append("")
                    L.append(f"![fixed vs adaptive {name}]({wp['figure_adaptive']})")
            L.append("")
            L.append("Fitted orders (slope of the final relative error over h) and the finest point of every femb "
                     "series:")
            L.append("")
            L.append("| ρ∞ | scaling | order pos. | order mult. | finest h [s] | wall [s] | pos. final | vel. final | "
                     "mult. final | mult. max |")
            L.append("|---|---|---|---|---|---|---|---|---|---|")
            for sr in wp["femb"]:
                ok = [p for p in sr["points"] if p.get("failed") is None]
                fin = min(ok, key=lambda p: p["h"]) if ok else None
                e = fin["errors"] if fin else None
                L.append(f"| {sr['rho_inf']:g} | {'on' if sr['scaling'] else 'off'} | "
                         f"{_f(_order(sr['points'], 'positions'), '.2f')} | "
                         f"{_f(_order(sr['points'], 'multipliers'), '.2f')} | {_f(fin and fin['h'])} | "
                         f"{_f(fin and fin['wall_s'])} | {_f(e and e['positions']['final_rel'], '.2e')} | "
                         f"{_f(e and e['velocities']['final_rel'], '.2e')} | "
                         f"{_f(e and e['multipliers']['final_rel'], '.2e')} | "
                         f"{_f(e and e['multipliers']['max_rel'], '.2e')} |")
            L.append("")
            L.append("All points at ρ∞ = 0.7 and the peers (every series is in `results.json`):")
            L.append("")
            L.append("| code | h [s] / tol | steps / f-evals | wall [s] | pos. final | pos. max | vel. final | vel. max | "
                     "mult. final | mult. max |")
            L.append("|---|---|---|---|---|---|---|---|---|---|")
            for sr in wp["femb"]:
                if sr["rho_inf"] != 0.7:
                    continue
                for p in sr["points"]:
                    L.append(_wp_rows(f"femb ρ∞=0.7 {'scaled' if sr['scaling'] else 'unscaled'}", p, "h"))
            for p in (wp.get("adaptive") or {}).get("points", []):
                L.append(_wp_rows(f"femb adaptive ρ∞=0.7 (rtol)", p, "rtol"))
            for sr in wp["exudyn"].get("series", []):
                if sr["rho_inf"] != 0.7:
                    continue
                for p in sr["points"]:
                    L.append(_wp_rows("Exudyn ρ∞=0.7", p, "h"))
            if not wp["exudyn"].get("series"):
                L.append(f"| Exudyn | {_md(wp['exudyn']['status'])} | | | | | | | | |")
            for sr in wp["scipy"].get("series", []):
                for p in sr["points"]:
                    L.append(_wp_rows(f"scipy {sr['method']}", p, "tol"))
            if not wp["scipy"].get("series"):
                L.append(f"| scipy | {_md(wp['scipy']['status'])} | | | | | | | | |")
    # ---- stress
    if res["stress"]:
        L.append("")
        L.append("## Stress tests")
        findings = []
        for tid, r in res["stress"].items():
            L.append("")
            L.append(f'<a id="stress-{tid.replace("_", "-")}"></a>')
            L.append("")
            L.append(f"### {r['title']}")
            L.append("")
            st = {k: v for k, v in (r.get("settings") or {}).items() if v not in ("", None)}
            if st:
                L.append("Settings: " + "; ".join(f"{k} = {_md(v)}" for k, v in st.items()) + ".")
                L.append("")
            L.append("| criterion | measured | verdict |")
            L.append("|---|---|---|")
            for c in r["criteria"]:
                L.append(f"| {_md(c['criterion'])} | {_md(c['measured'])} | {_verdict(c['verdict'])} |")
                if c.get("finding"):
                    findings.append((r["title"], c))
            seen = []
            for c in r["criteria"]:
                text = c.get("finding") or c.get("note")
                if text and text not in seen:
                    seen.append(text)
                    L.append("")
                    L.append(f"*{c['verdict']}*: {text}")
            for fig in r.get("figures", []):
                L.append("")
                L.append(f"![{tid}]({fig})")
        if findings:
            L.append("")
            L.append("## Findings")
            L.append("")
            L.append("Each distinct finding once, with the criteria that revealed it:")
            grouped = {}
            for title, c in findings:
                grouped.setdefault(c["finding"], []).append(f"{title}: {c['criterion']}")
            for text, where in grouped.items():
                L.append("")
                L.append(f"* {text}")
                L.append(f"  (criteria: {'; '.join(_md(w) for w in where)})")
    L.append("")
    L.append(f"Re-run: `{s['command']}` (all of it) or `python -m femb.benchmarks.runners.suite --only PART[,PART...]` with "
             f"parts {', '.join(PARTS)}.")
    L.append("")
    return "\n".join(L)


# --------------------------------------------------------------------------
def build_parser(prog="femb bench"):
    """Arguments of ``femb bench`` / ``python -m femb.benchmarks.runners.suite``."""
    p = argparse.ArgumentParser(prog=prog, description="Run femb's benchmark suite (work-precision diagrams "
                                "against peers and numerical-stability stress tests) and write a report folder.")
    p.add_argument("--quick", action="store_true", help="reduced size; without --only, the small set of plan() (about a minute on 2 cores)")
    p.add_argument("--out", default="bench-report", metavar="DIR", help="report folder (default: bench-report)")
    p.add_argument("--only", metavar="PART[,PART...]", help=f"run only these parts: {', '.join(PARTS)}")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    return p


def main(argv=None):
    """Entry point of ``femb bench``; returns the exit status (0: report written, 2: bad arguments)."""
    p = build_parser()
    try:
        args = p.parse_args(argv)
    except SystemExit as exc:       # argparse exits on --help (0) and on errors (2)
        return int(exc.code or 0)
    only = [x.strip() for x in args.only.split(",") if x.strip()] if args.only else None
    try:
        run_suite(quick=args.quick, out=args.out, progress=not args.quiet, only=only)
    except ValueError as exc:
        print(f"femb bench: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"femb bench: error: cannot write the report: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
