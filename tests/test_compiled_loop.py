"""The compiled time loop against the numpy engine it replaced, and its linear algebra."""
import json
import math
from pathlib import Path

import numpy as np
import pytest

import femb
from femb.base.jit import kernel
from femb.benchmarks.scenes.planar import andrews

REF = json.loads((Path(__file__).parent / "data" / "andrews_numpy_d1a00cd.json").read_text())
#: the seed reproduction's settings: residual Newton test, the seed's start, no step-size check
LEGACY = dict(newton_test="residual", start="seed", check_every=0)


@pytest.fixture(scope="module")
def andrews_model():
    return andrews.build().compile()


@pytest.mark.parametrize("linear_solver", ["band", "dense"])
def test_andrews_1000_steps_equal_the_numpy_engine(andrews_model, linear_solver):
    """q after 1000 steps to 1e-12 relative, and identical Newton iteration counts."""
    r = femb.simulate(andrews_model, 0.03, 3e-5, rho_inf=0.7, linear_solver=linear_solver, **LEGACY)
    q_ref = np.array(REF["q_1000"])
    assert np.abs(r.q[-1] - q_ref).max() <= 1e-12 * np.abs(q_ref).max()
    np.testing.assert_array_equal(r.newton_iterations, REF["newton_iterations"])
    # λ carries the index-3 amplification of round-off (~1/(βh²) times ε): same to 1e-7
    lam_ref = np.array(REF["lam_1000"])
    assert np.abs(r.lam[-1] - lam_ref).max() <= 1e-7 * np.abs(lam_ref).max()


SPATIAL_REF = json.loads((Path(__file__).parent / "data" / "spatial_engine_reference.json").read_text())


@pytest.mark.parametrize("formulation", ["index3", "index2"])
def test_heavy_top_equals_the_per_kind_engine(formulation):
    """The one engine against the per-kind generated modules it replaced (commit 1e00ae6): the
    heavy top after 300 steps, q to 1e-12, identical Newton iteration counts."""
    from femb.benchmarks.scenes.spatial import heavy_top
    ref = SPATIAL_REF[f"heavy_top_{formulation}"]
    model = heavy_top.build()
    model = model.compile() if hasattr(model, "compile") else model
    r = femb.simulate(model, t_end=ref["n"] * ref["h"], h=ref["h"], rho_inf=0.7, formulation=formulation)
    q_ref = np.array(ref["q"])
    assert np.abs(r.q[-1] - q_ref).max() <= 1e-12 * np.abs(q_ref).max()
    np.testing.assert_array_equal(r.newton_iterations, ref["newton"])
    np.testing.assert_allclose(r.lam[-1], ref["lam"], rtol=1e-8, atol=1e-9 * np.abs(ref["lam"]).max())


def test_band_lu_matches_dense_solve_and_flags_singularity():
    """The compiled band LU with partial pivoting solves random band systems and sees singular ones."""
    from femb.solve.codegen import _envelope, compiled
    model = andrews.build().compile()
    mod = compiled(model).mod
    rng = np.random.default_rng(5)
    for N, kl, ku in [(7, 2, 1), (30, 4, 6), (41, 40, 40), (60, 3, 3)]:
        A = np.zeros((N, N))
        for i in range(N):
            for j in range(max(0, i - kl), min(N, i + ku + 1)):
                A[i, j] = rng.standard_normal()
        A[np.arange(N), np.arange(N)] *= 1e-3      # small diagonal: pivoting must act
        ldab = 2 * kl + ku + 1
        AB = np.zeros((N, ldab))
        for j in range(N):
            for i in range(max(0, j - ku), min(N, j + kl + 1)):
                AB[j, kl + ku + i - j] = A[i, j]
        ABf = AB.reshape(-1).copy()
        piv = np.zeros(N, dtype=np.int64)
        rows, cols = np.nonzero(A)
        env = _envelope(rows, cols, N, kl, ku)          # the work bounds femb computes per model
        assert mod.band_lu(ABf, N, kl, ku, env, piv, 1e-13) == 0
        b = rng.standard_normal(N)
        x = b.copy()
        mod.band_solve(ABf, N, kl, ku, env, piv, x)
        np.testing.assert_allclose(A @ x, b, rtol=1e-9, atol=1e-9 * np.abs(b).max())
        # two equal rows make it singular (row N-2 kept inside row N-1's band)
        A2 = A.copy()
        if N - 2 - kl >= 0:
            A2[N - 2, N - 2 - kl] = 0.0
        A2[N - 1] = A2[N - 2]
        AB2 = np.zeros((N, ldab))
        for j in range(N):
            for i in range(max(0, j - ku), min(N, j + kl + 1)):
                AB2[j, kl + ku + i - j] = A2[i, j]
        ABf2 = AB2.reshape(-1).copy()
        assert mod.band_lu(ABf2, N, kl, ku, env, piv, 1e-13) == 1


def test_band_lu_without_interchanges_compacts_its_factors():
    """No row interchange: the factors move into N (kl + ku + 1) entries (``ipiv[N]`` = 1) and the
    compact solve gives the same solution; one interchange keeps the full storage."""
    from femb.solve.codegen import _envelope, compiled
    mod = compiled(andrews.build().compile()).mod
    rng = np.random.default_rng(11)
    for N, kl, ku in [(9, 2, 3), (60, 11, 11), (50, 5, 2)]:
        A = np.zeros((N, N))
        for i in range(N):
            for j in range(max(0, i - kl), min(N, i + ku + 1)):
                A[i, j] = rng.standard_normal()
        A[np.arange(N), np.arange(N)] = 3.0 * (kl + ku + 1)     # dominant diagonal: no interchange
        ldab = 2 * kl + ku + 1
        rows, cols = np.nonzero(A)
        env = _envelope(rows, cols, N, kl, ku)
        b = rng.standard_normal(N)
        for swap in (False, True):
            A1 = A.copy()
            if swap:
                A1[1, 0] = 10.0 * A1[0, 0]                     # row 1 is the first pivot
            AB = np.zeros((N, ldab))
            for j in range(N):
                for i in range(max(0, j - ku), min(N, j + kl + 1)):
                    AB[j, kl + ku + i - j] = A1[i, j]
            ABf = AB.reshape(-1).copy()
            piv = np.full(2 * N, -7, dtype=np.int64)
            assert mod.band_lu(ABf, N, kl, ku, env, piv, 1e-13) == 0
            assert piv[N] == (0 if swap else 1)
            if not swap:
                assert np.all(piv[:N] == np.arange(N))
            x = b.copy()
            mod.band_solve(ABf, N, kl, ku, env, piv, x)
            np.testing.assert_allclose(A1 @ x, b, rtol=1e-10, atol=1e-10 * np.abs(b).max())


def test_dense_lu_on_the_nonzero_pattern_solves_sparse_systems_and_flags_singularity():
    """The dense LU records the factors' pattern as it pivots; its solve visits those entries only."""
    from femb.solve.codegen import compiled
    mod = compiled(andrews.build().compile()).mod
    rng = np.random.default_rng(7)
    for N, density in [(5, 0.6), (41, 0.1), (90, 0.05)]:
        A = np.where(rng.random((N, N)) < density, rng.standard_normal((N, N)), 0.0)
        A[np.arange(N), rng.permutation(N)] += 1.0          # regular, with nonzeros off the diagonal
        A[np.arange(N), np.arange(N)] *= 1e-3               # small diagonal: pivoting must act
        b = rng.standard_normal(N)
        x = b.copy()
        piv = np.zeros(3 * N + 2 * N * N, dtype=np.int64)
        assert mod.dense_lu_solve(A.reshape(-1).copy(), N, piv, 1e-13, x) == 0
        np.testing.assert_allclose(A @ x, b, rtol=1e-9, atol=1e-9 * np.abs(b).max())
        # the pattern holds the factors' nonzeros only: fewer than N² where the matrix is sparse
        if density < 0.2:
            assert piv[N:2 * N].sum() + piv[2 * N:3 * N].sum() < 0.6 * N * N
        A2 = A.copy()
        A2[N - 1] = A2[0]
        assert mod.dense_lu_solve(A2.reshape(-1).copy(), N, piv, 1e-13, b.copy()) == 1


def test_packs_give_compiled_code_the_arrays_by_number_and_share_them_with_python():
    """femb.base.jit.pack: every rank and dtype comes back unchanged; writes go both ways; bad input is refused."""
    import numba
    from femb.base.jit import OPTIONS, fview1, fview2, fview3, iview1, iview2, iview3, pack
    rng = np.random.default_rng(3)
    arrays = [rng.standard_normal(5), np.arange(6, dtype=np.int64).reshape(2, 3), rng.standard_normal((3, 0)),
              rng.standard_normal((2, 3, 4)), np.array([1, 0, 1], dtype=np.int8), rng.integers(-9, 9, (2, 2, 2)),
              rng.standard_normal((4, 1))]
    P, views = pack(arrays)
    for a, v in zip(arrays, views):
        assert v.shape == a.shape and np.array_equal(v, a)

    @numba.njit(**OPTIONS)
    def checksum(P):
        a = fview1(P, 0)
        b = iview2(P, 1)
        c = fview2(P, 2)
        d = fview3(P, 3)
        e = iview1(P, 4)
        f = iview3(P, 5)
        g = fview2(P, 6)
        s = 0.0
        for i in range(a.shape[0]):
            s += a[i]
        for i in range(b.shape[0]):
            for j in range(b.shape[1]):
                s += b[i, j] * (i + 1)
        s += c.shape[0] + 10.0 * c.shape[1]
        for i in range(d.shape[0]):
            for j in range(d.shape[1]):
                for k in range(d.shape[2]):
                    s += d[i, j, k] * (1 + i + 2 * j + 3 * k)
        for i in range(e.shape[0]):
            s += 100.0 * e[i]
        for i in range(f.shape[0]):
            for j in range(f.shape[1]):
                for k in range(f.shape[2]):
                    s += f[i, j, k] * (k + 1)
        g[3, 0] = -7.0                     # written by compiled code, seen by Python
        return s

    views[1][1, 2] = 50                    # written by Python, seen by compiled code
    arrays[1][1, 2] = 50
    a, b, c, d, e, f, g = arrays
    ii, jj, kk = np.meshgrid(range(2), range(3), range(4), indexing="ij")
    expect = (a.sum() + (b * np.arange(1, 3)[:, None]).sum() + 3.0 + (d * (1 + ii + 2 * jj + 3 * kk)).sum()
              + 100.0 * e.sum() + (f * np.arange(1, 3)).sum())
    assert checksum(P) == pytest.approx(expect, rel=1e-13)
    assert views[6][3, 0] == -7.0
    with pytest.raises(ValueError, match="array 0 has 4 dimensions"):
        pack([np.zeros((1, 1, 1, 1))])
    with pytest.raises(ValueError, match="array 1 has dtype"):
        pack([np.zeros(2), np.array(["x"])])


def test_spin_up_runs_with_the_variable_band_and_matches_the_full_band():
    """The per-column work bounds of the band LU change the cost, not the numbers."""
    from femb.benchmarks.scenes.beams import spin_up
    model = spin_up.build(60).compile()          # 195 unknowns: above the dense-storage size
    a = femb.simulate(model, 0.2, 5e-3)
    b = femb.simulate(model, 0.2, 5e-3, linear_solver="dense")
    assert a.settings["storage"] == "band"
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-11)
    np.testing.assert_allclose(a.lam, b.lam, rtol=1e-7, atol=1e-7 * np.abs(b.lam).max())


def test_python_time_functions_give_the_same_run_as_compiled_ones():
    """A driver given as Python callables goes through Python once per step; same numbers as Harmonic."""
    import math
    from femb.base.functions import Harmonic
    from femb.elements import DrivenAngle, Gravity, Hinge, RigidBody

    def build(fn):
        m = femb.Mechanism("driven")
        bar = m.add(RigidBody("bar", 1.0, 1 / 12, position=(0.5, 0.0), points={"O": (-0.5, 0.0)}))
        m.add(Hinge("pivot", "ground", bar, point_b="O"))
        m.add(DrivenAngle("motor", "ground", bar, fn))
        m.add(Gravity((0.0, -9.81)))
        return m.compile()

    py = (lambda t: 0.3 * math.sin(4.0 * t), lambda t: 1.2 * math.cos(4.0 * t), lambda t: -4.8 * math.sin(4.0 * t))
    a = femb.simulate(build(py), 0.5, 1e-3)
    b = femb.simulate(build(Harmonic(0.3, 4.0)), 0.5, 1e-3)
    assert a.t.size == b.t.size == 501
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-13)
    np.testing.assert_allclose(a.lam, b.lam, rtol=1e-10, atol=1e-10)
    c = femb.simulate(build(py), 0.5, rtol=1e-6)          # adaptive steps with Python functions
    assert c.success and c.t[-1] == 0.5 and c.h_steps.size == c.t.size - 1


def test_solver_steps_one_at_a_time_and_stops_at_its_end():
    from femb.benchmarks.scenes.planar import pendulum
    from femb.solve.solver import GeneralizedAlphaSolver
    model = pendulum.build().compile()
    s = GeneralizedAlphaSolver(model, 1e-3)                 # no end: steps as asked
    its = [s.step() for _ in range(5)]
    assert s.step_index == 5 and s.state.t == pytest.approx(5e-3) and min(its) >= 1
    r = femb.simulate(model, 5e-3, 1e-3)
    np.testing.assert_allclose(s.state.q, r.q[-1], rtol=0, atol=1e-14)
    s2 = GeneralizedAlphaSolver(model, 1e-3, n_steps=2)
    s2.step()
    s2.step()
    with pytest.raises(femb.ParameterError, match="reached its end"):
        s2.step()


@kernel(allocates=True)
def attractor_allocating(P, t, tf, xe, ve, jac, fe, fq, fv):
    for e in range(xe.shape[0]):
        D = np.empty(2)                       # an allocation per element and call
        D[0] = xe[e, 0] - P[e, 0]
        D[1] = xe[e, 1] - P[e, 1]
        d2 = D[0] * D[0] + D[1] * D[1]
        a = P[e, 2] / (d2 * math.sqrt(d2))
        fe[e, 0] = -a * D[0]
        fe[e, 1] = -a * D[1]
        if jac:
            b = 3.0 / d2
            fq[e, 0, 0] = -a * (1.0 - b * D[0] * D[0])
            fq[e, 0, 1] = a * b * D[0] * D[1]
            fq[e, 1, 0] = a * b * D[0] * D[1]
            fq[e, 1, 1] = -a * (1.0 - b * D[1] * D[1])


def test_an_allocating_user_kernel_still_runs():
    """A user's kernel that creates arrays (``@kernel(allocates=True)``) runs: its model kind's loop
    is compiled with reference counting; the numbers equal the allocation-free kernel's."""
    from femb.benchmarks.scenes.planar import bead_attractor as ba

    class AllocatingAttractor(ba.PointAttractor):
        kernels = {"force": attractor_allocating}

    ref = femb.simulate(ba.build().compile(), 0.05, 1e-3)
    mech = ba.build()
    for e in mech.elements:
        if isinstance(e, ba.PointAttractor):
            e.__class__ = AllocatingAttractor       # the same element with the user's kernel
    r = femb.simulate(mech.compile(), 0.05, 1e-3)
    assert np.array_equal(r.q, ref.q) and np.array_equal(r.lam, ref.lam)
