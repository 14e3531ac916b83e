"""Validation tables (and figures) of the planar Reissner beam: statics, modes, dynamics.

Prints the numbers quoted in docs/beams.md; with ``--figures DIR`` also
writes PNG figures there. Each table names its reference:

1. cantilever, small tip load, against Timoshenko beam theory;
2. cantilever, tip moment 2π EI/L (exact: a full circle);
3. cantilever, large tip load PL²/EI ∈ {1, 3, 10}, against the elastica
   solved independently with scipy's ``solve_bvp``;
4. quarter-ring cantilever (R/h = 1000), against Castigliano's theorem
   (membrane locking check);
5. cantilever frequencies (length/thickness = 100) against Euler–Bernoulli;
6. (``--dynamics``) h- and mesh-convergence of the spin-up and the flexible
   slider-crank scenes.

Usage::

    python -m femb.benchmarks.accuracy.beam_validation [--dynamics] [--figures docs/figures]
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

BETA = np.array([1.875104068711961, 4.694091132974175, 7.854757438237613])


def _cantilever(n, *, EI=1.0, EA=1e7, GA=1e7, L=1.0, P=0.0, M=0.0):
    from femb import Mechanism
    from femb.elements import Force, Section, Torque, add_beam

    m = Mechanism("cantilever")
    b = add_beam(m, "b", Section(EA, GA, EI, 1.0, 1e-3), m.ground, (L, 0.0), n)
    if P:
        m.add(Force("P", b.nodes[-1], (0.0, -P)))
    if M:
        m.add(Torque("M", b.nodes[-1], M))
    return m.compile(), b


def tip_load_table(ns=(2, 4, 8, 16, 32), EI=1.0, GA=10.0, P=1e-5):
    """Relative tip-deflection errors against δ = PL³/3EI + PL/GA."""
    from femb.analysis.static import solve_static

    exact = P / (3 * EI) + P / GA
    errs = []
    for n in ns:
        model, b = _cantilever(n, EI=EI, GA=GA, P=P)
        errs.append(-solve_static(model, load_steps=1).body(b.node_names[-1])[-1, 1] / exact - 1.0)
    return np.asarray(ns), np.array(errs)


def tip_moment_table(ns=(1, 2, 5, 10, 50)):
    """Tip distance from the root (/L) and tip rotation error under M = 2π EI/L."""
    from femb.analysis.static import solve_static

    rows = []
    for n in ns:
        model, b = _cantilever(n, M=2 * math.pi)
        res = solve_static(model, load_steps=4)
        x, y, th = res.body(b.node_names[-1])[-1]
        rows.append((n, math.hypot(x, y), th - 2 * math.pi, int(res.newton_iterations.sum())))
    return rows


def elastica(alphas):
    """Tip (x, y, θ) of the inextensible elastica, L = EI = 1, tip dead load P = α downwards.

    EI θ'' = P cos θ, θ(0) = 0, θ'(L) = 0, x' = cos θ, y' = sin θ; scipy's
    solve_bvp (tol 1e-10) with continuation in α. Returns {α: (tip, s, θ, x, y)}.
    """
    from scipy.integrate import solve_bvp

    s = np.linspace(0.0, 1.0, 101)
    y = np.zeros((4, s.size))
    y[2] = s
    out, a0 = {}, 0.0
    for target in alphas:
        for a in np.linspace(a0, target, 4)[1:]:
            sol = solve_bvp(lambda s, y, a=a: np.vstack((y[1], a * np.cos(y[0]), np.cos(y[0]), np.sin(y[0]))),
                            lambda ya, yb: np.array([ya[0], yb[1], ya[2], ya[3]]), s, y, tol=1e-10,
                            max_nodes=100000)
            if not sol.success:
                raise RuntimeError(f"elastica at P L²/EI = {a}: {sol.message}")
            s, y = sol.x, sol.y
        a0 = target
        out[target] = (np.array([y[2, -1], y[3, -1], y[0, -1]]), s.copy(), y[0].copy(), y[2].copy(), y[3].copy())
    return out


def elastica_table(alphas=(1.0, 3.0, 10.0), ns=(8, 16, 32, 64)):
    """Max tip error ``|(x, y, θ) − elastica|`` for each load and mesh; also the FE shapes."""
    from femb.analysis.static import solve_static

    ref = elastica(alphas)
    errs, shapes = {}, {}
    for a in alphas:
        e = []
        for n in ns:
            model, b = _cantilever(n, P=a)
            res = solve_static(model, load_steps=int(a))
            e.append(np.abs(res.body(b.node_names[-1])[-1] - ref[a][0]).max())
            shapes[(a, n)] = b.coordinates(model, res.q[-1])
        errs[a] = np.array(e)
    return ref, np.asarray(ns), errs, shapes


def ring_table(ns=(2, 4, 8, 16, 32), R=1.0, h=1e-3):
    """Quarter ring clamped at one end, tip load F: error against (π/4) F (R³/EI + R/EA + R/GA)."""
    from femb import Mechanism
    from femb.analysis.static import solve_static
    from femb.elements import Force, Section, add_beam

    sec = Section.rectangle(1.0, 0.4, 1.0, h, 1.0)
    F = 1e-6 * sec.EI / R ** 2
    exact = math.pi / 4 * F * (R ** 3 / sec.EI + R / sec.EA + R / sec.GA)
    errs = []
    for n in ns:
        m = Mechanism("ring")
        b = add_beam(m, "b", sec, (R, 0.0), (0.0, R), n, sweep=math.pi / 2, start_joint="clamp")
        m.add(Force("F", b.nodes[-1], (0.0, -F)))
        res = solve_static(m.compile(), load_steps=1)
        errs.append(-(res.body(b.node_names[-1])[-1, 1] - R) / exact - 1.0)
    return np.asarray(ns), np.array(errs)


def modal_table(ns=(10, 20, 40, 80), n_fine=640):
    """First three cantilever frequencies against Euler–Bernoulli and against a fine mesh.

    Returns ns, {mass: errors against Euler–Bernoulli (len(ns), 3)},
    {mass: errors against the ``n_fine``-element consistent-mass solution (the
    model's converged Timoshenko value)}, the Euler–Bernoulli ω and the fine ω.
    """
    from femb import Mechanism
    from femb.analysis.modal import modal_analysis
    from femb.elements import Section, add_beam

    sec = Section.rectangle(2.1e11, 2.1e11 / 2.6, 0.01, 0.01, 7800.0)     # L/h = 100
    w_eb = BETA ** 2 * math.sqrt(sec.EI / sec.rhoA)

    def omega(n, mass):
        m = Mechanism("cantilever")
        add_beam(m, "b", sec, m.ground, (1.0, 0.0), n, mass=mass)
        return modal_analysis(m.compile(), n_modes=3).omega

    w_fine = omega(n_fine, "consistent")
    out, disc = {}, {}
    for mass in ("consistent", "lumped"):
        rows = np.array([omega(n, mass) for n in ns])
        out[mass] = rows / w_eb - 1.0
        disc[mass] = rows / w_fine - 1.0
    return np.asarray(ns), out, disc, w_eb, w_fine


def _order(ns, errs):
    return float(-np.polyfit(np.log(ns), np.log(np.abs(errs)), 1)[0])


def _figure(w=8.0, h=3.2, ncols=2):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(w, h))
    FigureCanvasAgg(fig)
    return fig, [fig.add_subplot(1, ncols, k + 1) for k in range(ncols)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dynamics", action="store_true", help="also the h- and mesh-convergence of the scenes")
    ap.add_argument("--figures", metavar="DIR", help="write PNG figures to DIR")
    a = ap.parse_args(argv)
    out = Path(a.figures) if a.figures else None
    if out:
        out.mkdir(parents=True, exist_ok=True)

    ns, e = tip_load_table()
    print("1. cantilever, tip load P = 1e-5 (EI = 1, GA = 10, L = 1) vs Timoshenko PL³/3EI + PL/GA")
    for n, x in zip(ns, e):
        print(f"   n = {n:3d}   relative error {x: .3e}   (PL³/(12 EI n²)/δ = {-1e-5 / (12 * n * n) / (1e-5 / 3 + 1e-6):.3e})")
    print(f"   observed order {_order(ns, e):.3f}")

    print("2. cantilever, tip moment 2π EI/L, 4 load steps: |tip − root|/L and tip rotation − 2π")
    for n, d, dth, it in tip_moment_table():
        print(f"   n = {n:3d}   {d:.2e}   {dth: .2e}   ({it} Newton iterations)")

    ref, ns_e, errs, shapes = elastica_table()
    print("3. cantilever, tip load PL²/EI = 1, 3, 10 vs the elastica (solve_bvp): max tip error / L")
    for al in errs:
        x, y, th = ref[al][0]
        print(f"   PL²/EI = {al:4.0f}: elastica tip x = {x:.6f}, y = {y:.6f}, θ = {th:.6f}")
        print("      " + "  ".join(f"n={n}: {v:.2e}" for n, v in zip(ns_e, errs[al]))
              + f"   order {_order(ns_e, errs[al]):.2f}")

    ns_r, er = ring_table()
    print("4. quarter ring R/h = 1000, tip load vs Castigliano: relative error")
    print("   " + "  ".join(f"n={n}: {v: .2e}" for n, v in zip(ns_r, er)) + f"   order {_order(ns_r[1:], er[1:]):.2f}")

    ns_m, em, dm, w_eb, w_fine = modal_table()
    print("5. cantilever frequencies, L/h = 100, vs Euler–Bernoulli (1.8751, 4.6941, 7.8548)² √(EI/ρAL⁴)")
    print(f"   ω_EB = {w_eb.round(3).tolist()} rad/s; 640 elements: {w_fine.round(3).tolist()} rad/s "
          f"({(100 * (w_fine / w_eb - 1)).round(3).tolist()} %: shear and rotary inertia)")
    print("   relative errors in % against Euler–Bernoulli | against 640 elements")
    for mass in em:
        for n, r, d in zip(ns_m, em[mass], dm[mass]):
            print(f"   {mass:10s} n = {n:3d}: " + "  ".join(f"{100 * v: .3f}" for v in r) + "  | "
                  + "  ".join(f"{100 * v: .4f}" for v in d))
        print(f"   {mass:10s} orders against 640 elements: "
              + ", ".join(f"{_order(ns_m, dm[mass][:, k]):.2f}" for k in range(3)))

    if out:
        fig, (ax1, ax2) = _figure()
        for al, c in zip(errs, ("C0", "C1", "C2")):
            _, s, th, x, y = ref[al]
            ax1.plot(x, y, "-", color=c, lw=1.0, label=f"elastica PL²/EI = {al:g}")
            X = shapes[(al, 8)]
            ax1.plot(X[:, 0], X[:, 1], "o", color=c, ms=3.5, mfc="none", label="8 elements" if al == 1.0 else None)
            ax2.loglog(ns_e, errs[al], "o-", color=c, label=f"PL²/EI = {al:g}")
        ax2.loglog(ns_e, 2 * errs[10.0][0] * (ns_e[0] / ns_e) ** 2, "k--", lw=0.8, label="slope −2")
        ax1.set_aspect("equal")
        ax1.set_xlabel("x / L")
        ax1.set_ylabel("y / L")
        ax1.legend(fontsize=7, loc="lower left")
        ax2.set_xticks(ns_e, [str(n) for n in ns_e])
        ax2.minorticks_off()
        ax2.set_xlabel("elements")
        ax2.set_ylabel("max tip error / L")
        ax2.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "beam_elastica.png", dpi=120)
        fig, (ax1, ax2) = _figure()
        for k in range(3):
            ax1.loglog(ns_m, np.abs(dm["consistent"][:, k]) * 100, "o-", color=f"C{k}",
                       label=f"mode {k + 1}, consistent")
            ax1.loglog(ns_m, np.abs(dm["lumped"][:, k]) * 100, "s:", color=f"C{k}", label=f"mode {k + 1}, lumped")
        ax1.axhline(1.0, color="k", lw=0.6)
        ax1.set_xticks(ns_m, [str(n) for n in ns_m])
        ax1.minorticks_off()
        ax1.set_xlabel("elements")
        ax1.set_ylabel("|ω / ω(640 el.) − 1| (%)")
        ax1.legend(fontsize=6)
        ax2.loglog(ns, np.abs(e), "o-", label="tip load vs Timoshenko")
        ax2.loglog(ns_r, np.abs(er), "s-", label="quarter ring vs Castigliano")
        ax2.loglog(ns, np.abs(e[0]) * (ns[0] / ns) ** 2, "k--", lw=0.8, label="slope −2")
        ax2.set_xticks(ns_r, [str(n) for n in ns_r])
        ax2.minorticks_off()
        ax2.set_xlabel("elements")
        ax2.set_ylabel("relative error")
        ax2.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "beam_modes_static.png", dpi=120)

    if a.dynamics:
        import femb
        from femb.benchmarks.scenes.beams import flexible_slider_crank as fsc
        from femb.benchmarks.scenes.beams import spin_up

        results = {}
        for name, mod, kw in (("spin_up", spin_up, {}), ("flexible_slider_crank", fsc, {})):
            c = mod.time_convergence(**kw)
            results[name] = c
            print(f"6. {name}: h-convergence (errors at t = {mod.CONVERGENCE['t_end']} s against h_ref)")
            for row in zip(c["h"], c["err_q"], c["err_lam"]):
                print("   h = %.3g   max|q error| = %.3e   max|λ error| = %.3e" % row)
            print(f"   orders: q {c['order_q']:.2f}, λ {c['order_lam']:.2f}")
        ms = spin_up.mesh_convergence(t_end=5.0)
        mf = fsc.mesh_convergence(ns=(4, 8, 16, 32), t_end=0.01, h=4e-5)
        for name, m, key, t in (("spin_up", ms, "tip_deflection", 5.0),
                                ("flexible_slider_crank", mf, "midspan_deflection", 0.01)):
            print(f"7. {name}: {key} at t = {t:g} s against the mesh")
            print("   " + "  ".join(f"n={n}: {v:.6g}" for n, v in zip(m["n"], m[key]))
                  + "   orders " + ", ".join(f"{o:.2f}" for o in m["orders"]))
        if out:
            fig, (ax1, ax2) = _figure()
            for name, c, mk in (("spin-up (n = 4)", results["spin_up"], "o"),
                                ("slider-crank (n = 4)", results["flexible_slider_crank"], "s")):
                h = c["h"] / c["h"][0]
                ax1.loglog(h, c["err_q"] / c["err_q"][0], mk + "-", label=f"q, {name}")
                ax1.loglog(h, c["err_lam"] / c["err_lam"][0], mk + ":", label=f"λ, {name}")
            ax1.loglog([1, 1 / 8], [1, 1 / 64], "k--", lw=0.8, label="slope 2")
            ax1.set_xticks([1, 0.5, 0.25, 0.125], ["1", "1/2", "1/4", "1/8"])
            ax1.minorticks_off()
            ax1.set_xlabel("h / h_max")
            ax1.set_ylabel("error / error(h_max)")
            ax1.legend(fontsize=6)
            r = femb.simulate(spin_up.build(10).compile(), 20.0, spin_up.H, rho_inf=0.7, stride=10,
                              **spin_up.newton_options(10))
            ax2.plot(r.t, spin_up.outputs(r)["tip_deflection"], lw=1.0)
            ax2.set_xlabel("t (s)")
            ax2.set_ylabel("spin-up tip deflection (m), n = 10")
            fig.tight_layout()
            fig.savefig(out / "beam_dynamics.png", dpi=120)
    if out:
        print(f"figures written to {out}")


if __name__ == "__main__":
    main()
