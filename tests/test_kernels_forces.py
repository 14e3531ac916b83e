"""Compiled kernels of elements/forces.py and elements/beam.py (docs/kernels.md).

Every batch of tests/kernel_scene.py (springs and rotational springs with and
without damping, constant and time-dependent torques, global and follower forces
with time functions, consistent/undamped and lumped/damped beams, clamps) is
called through :mod:`femb.system.kernels` with a stand-in batch object, and checked

* against the numbers of the numpy kernels they replaced (stored in
  tests/data/kernels_forces_reference.json by tests/data/make_kernels_forces_reference.py,
  which ran the code of commit 97c7148 on the same batches and states);
* against central finite differences of the kernels' own outputs: f_q, f_q̇, Φ_q,
  ∂(Φ_qᵀλ)/∂q, Φ_t, and γ as the second derivative of Φ along a motion;
* for the beam's output helpers: internal force = −gradient of the strain energy;
* and, once, with ``NUMBA_DISABLE_JIT=1`` (the same checks as plain Python).
"""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import kernel_scene as S
from femb.elements import Clamp, Force, ReissnerBeam, RotationalSpringDamper, SpringDamper, Torque
from femb.system import kernels as K

HERE = Path(__file__).resolve().parent
REF = json.loads((HERE / "data" / "kernels_forces_reference.json").read_text())
_, ELEMENTS = S.build()
GROUPS = S.batches(ELEMENTS)
LABELS = list(GROUPS)
FORCE = [k for k in LABELS if GROUPS[k].traits["has_force"]]
CONSTRAINT = [k for k in LABELS if GROUPS[k].nc]


def _fd(fun, x, eps=1e-6):
    """Central differences of fun: (nel, n) -> (nel, ...) with respect to x, element by element."""
    f0 = fun(x)
    J = np.zeros(f0.shape + (x.shape[1],))
    for j in range(x.shape[1]):
        xp, xm = x.copy(), x.copy()
        xp[:, j] += eps
        xm[:, j] -= eps
        J[..., j] = (fun(xp) - fun(xm)) / (2 * eps)
    return J


def _rot(th, s):
    """R(θ) s for stacked θ (n,), s (n, 2)."""
    c, sn = np.cos(th), np.sin(th)
    return np.column_stack((c * s[:, 0] - sn * s[:, 1], sn * s[:, 0] + c * s[:, 1]))


def _close(a, b, what, rtol=1e-6, atol_rel=1e-7):
    b = np.asarray(b, dtype=float)
    np.testing.assert_allclose(a, b, rtol=rtol, atol=atol_rel * max(1.0, np.abs(b).max()), err_msg=what)


def test_scene_has_every_type_and_packed_parameters_follow_the_contract():
    types = {g.cls for g in GROUPS.values()}
    assert types == {SpringDamper, RotationalSpringDamper, Torque, Force, ReissnerBeam, Clamp}
    assert len(GROUPS) == 10          # damped/undamped springs and beams, constant/variable torques
    for label, g in GROUPS.items():
        P = g.P
        assert P.dtype == np.float64 and P.ndim == 2 and P.shape[0] == g.nel and P.shape[1] >= 1, label
        assert P.flags.c_contiguous, label
        ntf = {len(f) for f in g.time_functions}
        assert len(ntf) <= 1, f"{label}: time-function count differs within the batch"
        roles = set(g.cls.kernels)
        want = ({"mass"} if g.traits["has_mass"] else set()) | ({"force"} if g.traits["has_force"] else set())
        want |= {"constraint", "rates"} if g.nc else set()
        want |= {"energy"} if g.cls.work == "potential" else set()     # the potential of the force
        assert roles == want, label
    # one implementation only: the numpy kernel classmethods are gone
    for cls in types:
        for name in ("mass", "force", "constraint", "constraint_all", "constraint_hessian", "constraint_rates",
                     "_kin", "_G"):
            assert name not in vars(cls), f"{cls.__name__}.{name} still defined"


@pytest.mark.parametrize("label", LABELS)
def test_kernels_equal_the_old_numpy_kernels(label):
    g = GROUPS[label]
    for case in REF["batches"][label]:
        t = case["t"]
        xe, ve, le = (np.array(case[k], dtype=float).reshape(g.nel, -1) for k in ("xe", "ve", "le"))
        out = {}
        if g.traits["has_mass"]:
            out["Me"] = K.mass(g, xe)
        if g.traits["has_force"]:
            out["fe"], out["fq"], out["fv"] = K.force(g, t, xe, ve, raw=True)
        if g.nc:
            out["Phi"], out["B"], out["H"] = K.constraint(g, t, xe, le)
            out["Phi_t"], out["gam"] = K.rates(g, t, xe, ve)
        assert out
        for k, a in out.items():
            _close(a, case[k], f"{label} {k}", rtol=1e-12, atol_rel=1e-14)


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("label", FORCE)
def test_force_jacobians_against_finite_differences(label, seed):
    g = GROUPS[label]
    t, xe, ve, _ = S.random_state(g, np.random.default_rng(seed))
    f, fq, fv = K.force(g, t, xe, ve, jac=True, raw=True)
    f2, _, _ = K.force(g, t, xe, ve, jac=False)
    np.testing.assert_array_equal(f, f2)
    assert np.all(np.isfinite(f)) and np.abs(f).max() > 0.0
    _close(fq, _fd(lambda x: K.force(g, t, x, ve, False)[0], xe), f"{label} df/dq")
    Jv = _fd(lambda v: K.force(g, t, xe, v, False)[0], ve)
    if g.traits["force_depends_on_qd"]:
        assert np.abs(Jv).max() > 0.0
        _close(fv, Jv, f"{label} df/dv")
    else:
        assert np.abs(Jv).max() == 0.0, f"{label} depends on v but does not say so"
        assert np.abs(fv).max() == 0.0, f"{label} writes fv without depending on v"


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("label", CONSTRAINT)
def test_constraint_jacobians_hessian_and_rates_against_finite_differences(label, seed):
    g = GROUPS[label]
    t, xe, ve, le = S.random_state(g, np.random.default_rng(10 + seed))
    Phi, B, H = K.constraint(g, t, xe, le, jac=True)
    Phi2, B2, H2 = K.constraint(g, t, xe, le, jac=False)
    np.testing.assert_array_equal(Phi, Phi2)
    np.testing.assert_array_equal(B, B2)
    assert H2 is None
    _close(B, _fd(lambda x: K.constraint(g, t, x, le, False)[0], xe), f"{label} Phi_q")
    _close(H, _fd(lambda x: np.einsum("ecd,ec->ed", K.constraint(g, t, x, le, False)[1], le), xe),
           f"{label} d(Phi_q^T lam)/dq")
    Phi_t, gam = K.rates(g, t, xe, ve)
    eps = 1e-6
    Pt = (K.constraint(g, t + eps, xe, le, False)[0] - K.constraint(g, t - eps, xe, le, False)[0]) / (2 * eps)
    _close(Phi_t, Pt, f"{label} Phi_t", atol_rel=1e-8)
    # γ = d²/ds² Φ(x + s v, t + s) at s = 0
    h = 1e-4
    d2 = (K.constraint(g, t + h, xe + h * ve, le, False)[0] - 2.0 * Phi
          + K.constraint(g, t - h, xe - h * ve, le, False)[0]) / h ** 2
    assert np.abs(gam).max() > 0.0
    _close(gam, d2, f"{label} gamma", rtol=1e-5, atol_rel=1e-6)


@pytest.mark.parametrize("label", [k for k in LABELS if GROUPS[k].traits["has_mass"]])
def test_beam_mass_is_constant_symmetric_and_carries_the_element_mass(label):
    g = GROUPS[label]
    rng = np.random.default_rng(3)
    Me = K.mass(g, g.x0)
    np.testing.assert_array_equal(Me, K.mass(g, g.x0 + rng.standard_normal(g.x0.shape)))
    np.testing.assert_array_equal(Me, Me.transpose(0, 2, 1))
    L = g.p["L"]
    for k, rho in ((0, g.p["rhoA"]), (1, g.p["rhoA"]), (2, g.p["rhoI"])):
        blk = Me[:, k::3, k::3]
        np.testing.assert_allclose(blk.sum(axis=(1, 2)), rho * L, rtol=1e-14)
    lumped = np.array([e.mass_type == "lumped" for e in g.els])
    np.testing.assert_array_equal(Me[lumped][:, 0, 3], 0.0)
    np.testing.assert_allclose(Me[~lumped][:, 0, 3], (g.p["rhoA"] * L / 6.0)[~lumped], rtol=1e-14)


def test_time_functions_are_read_at_the_kernel_time():
    g = GROUPS["Force'Force'"]
    xe = g.x0.copy()
    for t in (0.0, 0.7):
        f, _, _ = K.force(g, t, xe, np.zeros_like(xe), jac=False)
        for e, el in enumerate(g.els):
            F = np.array([fn.f(t) for fn in el.fns])
            th = xe[e, 2]
            R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
            if el.frame == "body":
                F = R @ F
            d = R @ el.s
            np.testing.assert_allclose(f[e, :2], F, rtol=1e-14, atol=1e-15)
            np.testing.assert_allclose(f[e, 2], d[0] * F[1] - d[1] * F[0], rtol=1e-13, atol=1e-15)


def test_spring_of_zero_length_gives_nan_not_an_exception():
    g = GROUPS["SpringDamper('SpringDamper', True)"]
    xe = g.x0.copy()
    ve = np.ones_like(xe)
    e = g.els[0]
    # put point b of element 0 exactly onto point a (rotations zero, so the offsets are s_a, s_b)
    xe[0, 2] = xe[0, 5] = 0.0
    xe[0, 3:5] = xe[0, 0:2] + e.sa - e.sb
    f, fq, _ = K.force(g, 0.0, xe, ve)
    assert np.all(np.isnan(f[0])) and np.all(np.isnan(fq[0]))
    assert np.all(np.isfinite(f[1:])) and np.all(np.isfinite(fq[1:]))


@pytest.mark.parametrize("label", [k for k in LABELS if GROUPS[k].cls is ReissnerBeam])
def test_beam_internal_force_is_minus_the_energy_gradient_and_helpers_agree(label):
    g = GROUPS[label]
    t, xe, ve, _ = S.random_state(g, np.random.default_rng(7))
    zero = np.zeros_like(ve)
    f, _, _ = K.force(g, t, xe, zero, jac=False)
    dW = _fd(lambda x: g.cls.strain_energy(g.p, x)[:, None], xe)[:, 0, :]
    _close(f, -dW, f"{label} f = -dW/dq")
    # reference configuration is stress free
    np.testing.assert_allclose(g.cls.strains(g.p, g.x0), 0.0, atol=1e-14)
    # resultants (with rates for damped sections) reproduce the kernel's force: f[θ_B] − f[θ_A] = −2M
    f, _, _ = K.force(g, t, xe, ve, jac=False)
    sig = g.cls.resultants(g.p, xe, ve)
    np.testing.assert_allclose(f[:, 5] - f[:, 2], -2.0 * sig[:, 2], rtol=1e-12)
    # strain rates are the time derivative of the strains along x + s v
    h = 1e-6
    rate = (g.cls.strains(g.p, xe + h * ve) - g.cls.strains(g.p, xe - h * ve)) / (2 * h)
    _close(g.cls.strain_rates(g.p, xe, ve), rate, f"{label} strain rates")


def test_spring_geometry_reports_the_kernel_tension():
    g = GROUPS["SpringDamper('SpringDamper', False)"]
    t, xe, ve, le = S.random_state(g, np.random.default_rng(5))
    (blk,) = g.cls.geometry(g.p, t, xe, ve, le, [e.name for e in g.els])
    n_seg = blk.cells[0][1].shape[0] // g.nel
    N = blk.cell_data["force"][0][::n_seg]
    l = np.hypot(*(xe[:, 3:5] + _rot(xe[:, 5], g.p["sb"]) - xe[:, 0:2] - _rot(xe[:, 2], g.p["sa"])).T)
    np.testing.assert_allclose(N, g.p["k"] * (l - g.p["l0"]), rtol=1e-12)


@pytest.mark.skipif(os.environ.get("NUMBA_DISABLE_JIT") == "1", reason="already running as plain Python")
def test_the_same_checks_pass_as_plain_python():
    """NUMBA_DISABLE_JIT=1 runs the kernels as plain Python: every other test of this file must pass."""
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    # one process: xdist workers (pyproject addopts) would each import femb again for this short file
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-n", "0", "-p", "no:cacheprovider",
                        str(Path(__file__)), "-k", "not plain_python"],
                       env=env, capture_output=True, text=True, cwd=HERE.parent)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert " passed" in r.stdout and "failed" not in r.stdout


@pytest.mark.parametrize("label", LABELS)
def test_output_geometry_reads_the_packed_dict(label):
    g = GROUPS[label]
    t, xe, ve, le = S.random_state(g, np.random.default_rng(11))
    blocks = g.cls.geometry(g.p, t, xe, ve, le, [e.name for e in g.els])
    assert bool(blocks) == (g.cls is not RotationalSpringDamper)     # it has never drawn anything
    for b in blocks:
        assert np.all(np.isfinite(b.points)) and b.points.shape[1] == 3
        for arrs in b.cell_data.values():
            assert all(np.all(np.isfinite(a)) for a in arrs)
        for a in b.point_data.values():
            assert np.all(np.isfinite(a))
    if g.cls is Clamp:
        np.testing.assert_allclose(blocks[0].points[:, :2], xe[:, 0:2] + _rot(xe[:, 2], g.p["sa"]), rtol=1e-14)
        np.testing.assert_array_equal(blocks[0].point_data["reaction_torque"], le[:, 2])
