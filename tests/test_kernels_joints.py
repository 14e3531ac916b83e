"""Compiled kernels of the joints (elements/joints.py) and bodies (elements/bodies.py).

Each kernel is called through :mod:`femb.system.kernels` on a batch described by a small
stand-in group object, and checked

* against central finite differences of its own outputs (Φ_q, ∂(Φ_qᵀλ)/∂q, Φ_t, γ),
* against the values the numpy kernels they replace gave on the same elements and
  states (``tests/data/joints_reference.json``, recorded by
  ``tests/data/make_joints_reference.py`` from the numpy code of commit d1a00cd),
* and run once as plain Python with ``NUMBA_DISABLE_JIT=1``.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from femb.elements import bodies, joints
from femb.system import kernels as K
from femb.system.element import Element

from joints_scenario import BODY_TYPES, JOINT_TYPES, build, states

HERE = Path(__file__).resolve().parent
SEEDS = (11, 12)        # the seeds of the reference file
FD_SEEDS = (1, 2, 3)


@pytest.fixture(scope="module")
def elements():
    return build(joints, bodies)


def make_group(cls, els):
    """The attributes of a model's batch that :mod:`femb.system.kernels` reads."""
    tfun = getattr(cls, "time_functions", None)
    return SimpleNamespace(cls=cls, P=cls.pack(els)["P"], nel=len(els),
                           ndv=3 * len(els[0].nodes()), nc=cls.n_constraints,
                           time_functions=[list(tfun(e)) if tfun else [] for e in els])


def joint_group(elements, name):
    return make_group(getattr(joints, name), elements[name])


def fd(fun, x, eps=1e-6):
    """Central differences of fun: (nel, n) -> (nel, ...), element by element -> (nel, ..., n)."""
    f0 = fun(x)
    J = np.zeros(f0.shape + (x.shape[1],))
    for j in range(x.shape[1]):
        xp, xm = x.copy(), x.copy()
        xp[:, j] += eps
        xm[:, j] -= eps
        J[..., j] = (fun(xp) - fun(xm)) / (2 * eps)
    return J


def close(actual, desired, what, rtol=1e-6, atol=1e-7):
    """assert_allclose with atol relative to the size of the expected values."""
    scale = max(1.0, float(np.abs(desired).max()))
    np.testing.assert_allclose(actual, desired, rtol=rtol, atol=atol * scale, err_msg=what)


# ---------------------------------------------------------------------------
@pytest.mark.parametrize("name", JOINT_TYPES + BODY_TYPES)
def test_pack_and_metadata_follow_the_contract(elements, name):
    mod = joints if name in JOINT_TYPES else bodies
    cls = getattr(mod, name)
    p = cls.pack(elements[name])
    P = p["P"]
    assert P.dtype == np.float64 and P.ndim == 2 and P.flags.c_contiguous
    assert P.shape[0] == len(elements[name]) and P.shape[1] >= 1
    roles = set(cls.kernels)
    expect = ({"constraint", "rates"} if cls.n_constraints else set()) | ({"mass"} if cls.has_mass else set())
    assert roles == expect
    # no numpy kernel classmethod of the old contract is left on the type itself
    for klass in cls.__mro__[:cls.__mro__.index(Element)]:
        for old in ("mass", "force", "constraint", "constraint_all", "constraint_hessian", "constraint_rates"):
            assert old not in vars(klass), f"{klass.__name__}.{old} is still defined"
    g = make_group(cls, elements[name])
    counts = {len(f) for f in g.time_functions}
    assert counts == {1 if cls.rheonomic else 0}


def test_geometry_reads_the_packed_dict(elements):
    for name in JOINT_TYPES + ("RigidBody", "PointMass"):
        mod = joints if name in JOINT_TYPES else bodies
        cls = getattr(mod, name)
        els = elements[name]
        nd = 3 * len(els[0].nodes())
        t, xe, ve, le = states(len(els), 5, ndx=nd)
        blocks = cls.geometry(cls.pack(els), t, xe, ve, le[:, :max(cls.n_constraints, 1)], [e.name for e in els])
        if name == "DrivenAngle":
            assert blocks == []
        else:
            assert blocks and all(np.all(np.isfinite(b.points)) for b in blocks)


# ---------------------------------------------------------------------------
@pytest.mark.parametrize("seed", FD_SEEDS)
@pytest.mark.parametrize("name", JOINT_TYPES)
def test_constraint_jacobians_against_finite_differences(elements, name, seed):
    g = joint_group(elements, name)
    t, xe, ve, le = states(g.nel, seed)
    le = le[:, :g.nc]
    Phi, B, H = K.constraint(g, t, xe, le, jac=True)
    assert Phi.shape == (g.nel, g.nc) and B.shape == (g.nel, g.nc, 6) and H.shape == (g.nel, 6, 6)
    Phi2, B2, H2 = K.constraint(g, t, xe, le, jac=False)
    np.testing.assert_array_equal(Phi2, Phi)
    np.testing.assert_array_equal(B2, B)
    assert H2 is None
    close(B, fd(lambda x: K.constraint(g, t, x, le, False)[0], xe), f"{name} Phi_q")
    Hfd = fd(lambda x: np.einsum("ecd,ec->ed", K.constraint(g, t, x, le, False)[1], le), xe)
    close(H, Hfd, f"{name} d(Phi_q^T lambda)/dq")
    np.testing.assert_array_equal(H, H.transpose(0, 2, 1))


@pytest.mark.parametrize("seed", FD_SEEDS)
@pytest.mark.parametrize("name", JOINT_TYPES)
def test_rates_against_finite_differences(elements, name, seed):
    g = joint_group(elements, name)
    t, xe, ve, le = states(g.nel, seed)
    Phi_t, gam = K.rates(g, t, xe, ve)
    assert Phi_t.shape == gam.shape == (g.nel, g.nc)

    def phi(s):  # Φ along the motion x + s v at time t + s
        return K.constraint(g, t + s, xe + s * ve, None, False)[0]

    eps = 1e-6
    close(Phi_t, (K.constraint(g, t + eps, xe, None, False)[0]
                  - K.constraint(g, t - eps, xe, None, False)[0]) / (2 * eps), f"{name} Phi_t")
    # γ = d²Φ/ds² along the motion; second differences with one Richardson step
    d2 = [(phi(h) - 2 * phi(0.0) + phi(-h)) / h ** 2 for h in (1e-3, 5e-4)]
    close(gam, (4 * d2[1] - d2[0]) / 3, f"{name} gamma", rtol=1e-6, atol=1e-6)
    if not g.cls.rheonomic:
        assert np.all(Phi_t == 0.0)


def test_rheonomic_terms_follow_the_time_functions(elements):
    """Φ, Φ_t, γ of the drivers move with d(t), d'(t), d''(t) exactly as written."""
    for name in ("DrivenAngle", "DrivenDisplacement"):
        g = joint_group(elements, name)
        t, xe, ve, le = states(g.nel, 4)
        tf = K.time_values(g, t)
        Phi, _, _ = K.constraint(g, t, xe, None, False)
        Phi_t, gam = K.rates(g, t, xe, ve)
        # the same kernels with the time functions' values set to zero
        Phi0 = np.zeros_like(Phi)
        B0 = np.zeros((g.nel, 1, 6))
        H0 = np.zeros((g.nel, 6, 6))
        g.cls.kernels["constraint"](g.P, t, np.zeros_like(tf), xe, np.zeros((g.nel, 1)), False, Phi0, B0, H0)
        Pt0, gam0 = np.zeros_like(Phi), np.zeros_like(Phi)
        g.cls.kernels["rates"](g.P, t, np.zeros_like(tf), xe, ve, Pt0, gam0)
        np.testing.assert_allclose(Phi, Phi0 - tf[:, :, 0], rtol=0, atol=1e-15)
        np.testing.assert_allclose(Phi_t, Pt0 - tf[:, :, 1], rtol=0, atol=1e-15)
        np.testing.assert_allclose(gam, gam0 - tf[:, :, 2], rtol=0, atol=1e-13)


# ---------------------------------------------------------------------------
def _reference():
    return json.loads((HERE / "data" / "joints_reference.json").read_text())


@pytest.mark.parametrize("name", JOINT_TYPES)
def test_constraints_equal_the_numpy_kernels(elements, name):
    g = joint_group(elements, name)
    cases = [c for c in _reference()["cases"] if c["type"] == name]
    assert [c["seed"] for c in cases] == list(SEEDS)
    for c in cases:
        t, xe, ve, le = states(g.nel, c["seed"])
        Phi, B, H = K.constraint(g, t, xe, le[:, :g.nc], jac=True)
        Phi_t, gam = K.rates(g, t, xe, ve)
        for what, val in (("Phi", Phi), ("B", B), ("H", H), ("Phi_t", Phi_t), ("gam", gam)):
            ref = np.array(c[what])
            np.testing.assert_allclose(val, ref, rtol=1e-13, atol=1e-14 * max(1.0, np.abs(ref).max()),
                                       err_msg=f"{name} {what} (seed {c['seed']})")


@pytest.mark.parametrize("name", BODY_TYPES)
def test_mass_equals_the_numpy_kernels(elements, name):
    cls = getattr(bodies, name)
    g = make_group(cls, elements[name])
    (c,) = [c for c in _reference()["cases"] if c["type"] == name]
    t, xe, ve, le = states(g.nel, c["seed"], ndx=3)
    Me = K.mass(g, xe)
    np.testing.assert_array_equal(Me, np.array(c["M"]))
    # constant mass: the same at any configuration
    np.testing.assert_array_equal(K.mass(g, states(g.nel, 99, ndx=3)[1]), Me)
    m = np.array([e.m for e in elements[name]])
    np.testing.assert_array_equal(Me[:, 0, 0], m)
    np.testing.assert_array_equal(Me[:, 1, 1], m)


# ---------------------------------------------------------------------------
_PLAIN = r"""
import json, sys
import numpy as np
sys.path.insert(0, sys.argv[1])
import femb.base.jit
from femb.system import kernels as K
from femb.elements import bodies, joints
from joints_scenario import BODY_TYPES, JOINT_TYPES, build, states
from test_kernels_joints import make_group
els = build(joints, bodies)
out = {"disabled": femb.base.jit.jit_disabled(),
       "plain": all(type(f).__name__ == "function"
                    for c in (joints.Slider, joints.PointOnLine, joints.DrivenAngle,
                              joints.DrivenDisplacement, joints.Hinge, bodies.RigidBody, bodies.PointMass)
                    for f in c.kernels.values())}
for name in JOINT_TYPES:
    g = make_group(getattr(joints, name), els[name])
    t, xe, ve, le = states(g.nel, 11)
    Phi, B, H = K.constraint(g, t, xe, le[:, :g.nc], jac=True)
    out[name] = [a.tolist() for a in (Phi, B, H) + K.rates(g, t, xe, ve)]
for name in BODY_TYPES:
    g = make_group(getattr(bodies, name), els[name])
    out[name] = [K.mass(g, states(g.nel, 11, ndx=3)[1]).tolist()]
print(json.dumps(out))
"""


def test_kernels_run_as_plain_python(elements):
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    r = subprocess.run([sys.executable, "-c", _PLAIN, str(HERE)], env=env, capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["disabled"] and out["plain"]
    for name in JOINT_TYPES:
        g = joint_group(elements, name)
        t, xe, ve, le = states(g.nel, 11)
        Phi, B, H = K.constraint(g, t, xe, le[:, :g.nc], jac=True)
        for a, b in zip((Phi, B, H) + K.rates(g, t, xe, ve), out[name]):
            np.testing.assert_allclose(np.array(b), a, rtol=1e-14, atol=1e-14, err_msg=name)
    for name in BODY_TYPES:
        g = make_group(getattr(bodies, name), elements[name])
        np.testing.assert_array_equal(np.array(out[name][0]), K.mass(g, states(g.nel, 11, ndx=3)[1]))
