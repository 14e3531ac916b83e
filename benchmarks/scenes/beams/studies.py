"""Convergence studies shared by the flexible scenes: in h against a fine run, and in the mesh.

Each takes the scene's ``build(n_elements, **kw)``, its per-mesh Newton
options and (for the mesh study) a scalar output at the final time.
"""
from __future__ import annotations

import numpy as np


def time_convergence(build, newton_options, n_elements, t_end, hs, h_ref, rho_inf=0.7, **kw):
    """Global errors at t_end against a run with ``h_ref`` (femb's own, h_ref ≪ min(hs)).

    Returns
    -------
    dict
        ``h``, ``err_q`` (max abs error of q), ``err_lam`` (of λ) and the fitted
        orders ``order_q``, ``order_lam`` (slope of the log–log fit).
    """
    import femb

    model = build(n_elements, **kw).compile()
    opts = newton_options(n_elements)
    ref = femb.simulate(model, t_end, h_ref, rho_inf=rho_inf, store=False, **opts)
    eq, el = [], []
    for h in hs:
        r = femb.simulate(model, t_end, h, rho_inf=rho_inf, store=False, **opts)
        eq.append(np.abs(r.q[-1] - ref.q[-1]).max())
        el.append(np.abs(r.lam[-1] - ref.lam[-1]).max())
    hs = np.asarray(hs)
    return {"h": hs, "err_q": np.array(eq), "err_lam": np.array(el),
            "order_q": float(np.polyfit(np.log(hs), np.log(eq), 1)[0]),
            "order_lam": float(np.polyfit(np.log(hs), np.log(el), 1)[0])}


def mesh_convergence(build, newton_options, final_value, ns, t_end, h, rho_inf=0.7, **kw):
    """A scalar output at t_end for each mesh and the observed orders.

    Parameters
    ----------
    final_value : callable(Result) -> float
        The output at the final time.

    Returns
    -------
    dict
        ``n``, ``value``, ``diff`` (``|w_{k+1} − w_k|``) and ``orders``
        log(diff_k / diff_{k+1}) / log(n_{k+1} / n_k).
    """
    import femb

    w = []
    for n in ns:
        r = femb.simulate(build(n, **kw).compile(), t_end, h, rho_inf=rho_inf, store=False,
                          **newton_options(n))
        w.append(final_value(r))
    w = np.array(w)
    d = np.abs(np.diff(w))
    return {"n": np.asarray(ns), "value": w, "diff": d,
            "orders": np.log(d[:-1] / d[1:]) / np.log(np.asarray(ns[1:-1]) / np.asarray(ns[:-2]))}
