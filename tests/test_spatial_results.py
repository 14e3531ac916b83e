"""Spatial results read like planar ones: energies, named outputs, tables, plots, reactions.

Every name :meth:`Result.outputs` lists for a spatial model is read through
``series()``, ``to_pandas()`` and ``plot()``, with its unit; the energy balance
of conservative spatial models (gravity, point springs, bushings, rotational
springs, loads) closes; ``reaction_at`` is evaluated for all stored steps at
once and agrees with the joints' own per-step output (``joint_reactions``).
"""
import warnings

import numpy as np
import pytest

import femb
from femb.base.functions import Harmonic
from femb.errors import ModelError
from femb.elements import (Bushing, PointSpringDamper, RevoluteJoint, SpatialForce, SpatialGravity,
                           SpatialRigidBody, SpatialRotationalSpringDamper, SpatialTorque)
from femb.elements.spatial_joints import joint_reactions

from femb.benchmarks.scenes.spatial import heavy_top, spatial_slider_crank


@pytest.fixture(scope="module")
def top_run():
    return femb.simulate(heavy_top.build().compile(), 1.0, 2.0 ** -11, rho_inf=0.9)


def spring_pendulum():
    """A rigid body hanging from the ground on a point spring, released in motion (conservative)."""
    mech = femb.Mechanism("spatial_spring_pendulum")
    b = mech.add(SpatialRigidBody("bob", 2.0, (0.02, 0.03, 0.04), position=(0.8, 0.1, -0.5),
                                  velocity=(0.0, 1.0, 0.5), omega=(1.0, -2.0, 3.0), points={"A": (0.1, 0.0, 0.0)}))
    mech.add(PointSpringDamper("spring", "ground", b, stiffness=200.0, length=0.6, point_b="A"),
             SpatialGravity((0.0, 0.0, -9.81)))
    return mech


def mounted_wheel(load=20.0):
    """A plate on a six-component bushing, a wheel on a revolute joint with a torsion spring,
    a harmonic force on the plate and a follower torque on the wheel (no damping); the plate
    starts at rest, the wheel spinning about its axle (consistent initial velocities)."""
    mech = femb.Mechanism("mounted_wheel")
    plate = mech.add(SpatialRigidBody("plate", 3.0, (0.05, 0.06, 0.08), position=(0.0, 0.0, -0.3)))
    mech.add(Bushing("mount", "ground", plate, stiffness=(4e3, 5e3, 6e3),
                     rotational_stiffness=(300.0, 400.0, 500.0), at=(0.0, 0.0, 0.0)),
             SpatialGravity((0.0, 0.0, -9.81)))
    wheel = mech.add(SpatialRigidBody("wheel", 1.0, (0.01, 0.01, 0.02), position=(0.5, 0.0, -0.3),
                                      omega=(0.0, 0.0, 2.0)))
    mech.add(RevoluteJoint("axle", plate, wheel, at=(0.5, 0.0, -0.3), axis=(0.0, 0.0, 1.0)))
    mech.add(SpatialRotationalSpringDamper("torsion", plate, wheel, stiffness=5.0, at=(0.5, 0.0, -0.3),
                                           axis=(0.0, 0.0, 1.0)))
    mech.add(SpatialForce("push", plate, (load, 2.0 * load, 0.0), point=(0.1, 0.1, 0.0),
                          function=Harmonic(1.0, 20.0)))
    mech.add(SpatialTorque("twist", wheel, (0.0, 0.0, 0.1 * load), follower=True, function=Harmonic(1.0, 3.0)))
    return mech


@pytest.fixture(scope="module")
def wheel_run():
    with warnings.catch_warnings():
        warnings.simplefilter("error", femb.InitialMoveWarning)       # consistent as given
        return femb.simulate(mounted_wheel().compile(), 1.0, 1e-3, rho_inf=0.9)


@pytest.fixture(scope="module")
def crank_run():
    return femb.simulate(spatial_slider_crank.build().compile(), 0.2, 1e-3, rho_inf=0.9)


# ---------------------------------------------------------------- energies
def test_heavy_top_energy_balance(top_run):
    e = top_run.energy()
    # V_g = −m gᵀ r_G: the centre of mass falls and rises by ~1 m on this run
    z = top_run.series("top.z")[0]
    np.testing.assert_allclose(e["gravitational"], 15.0 * 9.81 * z, rtol=1e-12, atol=1e-9)
    assert np.ptp(e["gravitational"]) > 100.0
    assert top_run.energy_balance() <= 1e-3


def test_spatial_spring_pendulum_energy_balance():
    r = femb.simulate(spring_pendulum().compile(), 1.0, 1e-3, rho_inf=0.9)
    e = r.energy()
    assert np.ptp(e["elastic"]) > 10.0 and np.ptp(e["gravitational"]) > 5.0
    # the spring's energy from its length
    pa = np.zeros(3)
    pb = r.point("bob", "A")
    np.testing.assert_allclose(e["elastic"], 0.5 * 200.0 * (np.linalg.norm(pb - pa, axis=1) - 0.6) ** 2,
                               rtol=1e-12, atol=1e-12)
    assert r.energy_balance() <= 1e-3


def test_bushing_torsion_spring_and_loads_energy_balance(wheel_run):
    from femb.results.energy import elastic_energy
    parts = elastic_energy(wheel_run, by_element=True)
    assert set(parts) == {"mount", "torsion"}
    assert np.ptp(parts["mount"]) > 0.1 and np.ptp(parts["torsion"]) > 1e-3
    e = wheel_run.energy()
    assert np.ptp(e["work_loads"]) > 0.5            # the loads do real work on this run
    assert wheel_run.energy_balance() <= 1e-3


def test_load_power_matches_the_kinetic_energy_of_a_free_body():
    """A free body under a dead force at a point and a follower torque: T(t) − T(0) = W_loads(t)."""
    mech = femb.Mechanism("free")
    b = mech.add(SpatialRigidBody("b", 1.5, (0.1, 0.2, 0.3), omega=(0.3, 0.2, 0.1)))
    mech.add(SpatialForce("f", b, (3.0, -1.0, 2.0), point=(0.2, 0.1, -0.1), function=Harmonic(1.0, 4.0)))
    mech.add(SpatialTorque("m", b, (0.5, 0.2, -0.4), follower=True))
    r = femb.simulate(mech.compile(), 1.0, 1e-3, rho_inf=0.9)
    e = r.energy()
    assert np.ptp(e["kinetic"]) > 0.5
    assert np.abs(e["kinetic"] - e["kinetic"][0] - e["work_loads"]).max() <= 1e-3 * np.ptp(e["kinetic"])


# ---------------------------------------------------------------- named outputs
def _check_every_output(r):
    names = r.outputs()
    assert len(names) == len(set(names))
    units = {}
    for n in names:
        v, u = r.series(n)
        assert v.shape == r.t.shape and np.all(np.isfinite(v)), n
        units[n] = u
    return units


def _expected_unit(name):
    last = name.rsplit(".", 1)[1]
    base = last[:-3] if last.endswith("_dd") else last[:-2] if last.endswith("_d") else last
    deriv = 2 if last.endswith("_dd") else 1 if last.endswith("_d") else 0
    if name.startswith("energy."):
        return "J"
    if base in ("x", "y", "z"):
        return ("m", "m/s", "m/s²")[deriv]
    if base in ("p0", "p1", "p2", "p3"):
        return "1"
    if base[:-1] in ("Omega_", "omega_"):
        return ("rad/s", "rad/s²")[deriv]
    if base in ("Fx", "Fy", "Fz"):
        return "N"
    if base in ("Mx", "My", "Mz"):
        return "N·m"
    return "λ"


def test_every_output_of_the_heavy_top_is_readable(top_run):
    units = _check_every_output(top_run)
    names = list(units)
    for n in ("top.p3", "top.Omega_x", "top.omega_z_d", "support.Fx", "support.Mz"):
        assert n in names
    assert "top.p3_d" not in names and "support.M" not in names
    for n, u in units.items():
        if n.startswith("support.") and n[-1] in "xyz" and len(n.rsplit(".", 1)[1]) == 1:
            assert u == "N", n                     # the multipliers support.x, .y, .z: forces (constraint_units)
        else:
            assert u == _expected_unit(n), (n, u)
    # Ω in body axes is the model's velocity entry; ω = R Ω in space axes
    W = top_run.body("top", "qd")[:, 3:6]
    np.testing.assert_array_equal(top_run.series("top.Omega_x")[0], W[:, 0])
    w = top_run.angular_velocity("top", frame="space")
    np.testing.assert_allclose(top_run.series("top.omega_y")[0], w[:, 1], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(top_run.series("top.p0")[0], top_run.rotation("top")[:, 0])
    with pytest.raises(ModelError, match="Mx, My, Mz"):
        top_run.series("support.M")
    with pytest.raises(ModelError, match="angular velocity"):
        top_run.series("top.p3_d")


def test_every_output_of_the_spatial_slider_crank_and_the_wheel_is_readable(crank_run, wheel_run):
    for r in (crank_run, wheel_run):
        units = _check_every_output(r)
        joints = {n.split(".")[0] for n in units if n.endswith(".Mz")}
        assert joints == {e for e, v in r.model.lam_index.items() if len(v)}
        for n, u in units.items():
            if n.rsplit(".", 1)[1] in ("Fx", "Fy", "Fz", "Mx", "My", "Mz") or n.split(".")[0] in r.model.bodies \
                    or n.startswith("energy."):
                assert u == _expected_unit(n), (n, u)


def test_spatial_joint_outputs_are_the_reaction_on_b_in_space_axes(crank_run):
    for joint in ("crank_pivot", "B", "D", "guide"):
        R = crank_run.reaction_at(joint)
        for k, c in enumerate(("Fx", "Fy", "Fz", "Mx", "My", "Mz")):
            v, u = crank_run.series(f"{joint}.{c}")
            np.testing.assert_array_equal(v, R[:, k])
    # the heavy top's spherical joint: the force on the top is λ, no moment about the pivot
    r = femb.simulate(heavy_top.build().compile(), 0.1, 2.0 ** -10, rho_inf=0.9)
    R = r.reaction_at("support")
    np.testing.assert_allclose(R[:, 0:3], r.reaction("support"), rtol=0, atol=1e-9)
    assert np.abs(R[:, 3:6]).max() < 1e-9


def test_to_pandas_and_plot_on_spatial_models(top_run, crank_run, wheel_run, tmp_path):
    pytest.importorskip("pandas")
    for r in (top_run, crank_run, wheel_run):
        df = r.to_pandas()
        expected = [n for n in r.outputs() if not n.endswith("_dd") and not n.startswith("energy.")]
        assert list(df.columns) == expected and len(df) == r.t.size
        assert df.attrs["units"] == {n: r.series(n)[1] for n in expected}
        names = [n for n in r.outputs() if n.endswith(("_dd", ".Mz", ".p1")) or n.startswith("energy.")]
        sel = r.to_pandas(names)
        assert list(sel.columns) == names
        # plot reads each name through series() as to_pandas does (every name above): one panel
        # per kind of output here (node coordinates and their rates, Ω and ω, body points,
        # multipliers, reactions, energies), not one per output (hundreds of panels, minutes)
        kinds = _one_output_per_kind(r.outputs())
        assert len(kinds) >= 15
        f = tmp_path / f"{r.model.name}.png"
        fig = r.plot(kinds, file=f)
        assert f.stat().st_size > 1000
        assert [ax.get_ylabel().split(" (")[0] for ax in fig.axes] == kinds


def _one_output_per_kind(names):
    """The first output name of each kind: the name after its owner, with axis letters and
    indices replaced (``top.x``, ``top.x_d``, ``top.Omega_x``, ``guide.Fx``, ``energy.kinetic``)."""
    import re

    seen = {}
    for n in names:
        base = n.partition(".")[2]
        kind = re.sub(r"[xyz](?=$|_d)|\d+$", "*", base.rsplit(".", 1)[-1])
        seen.setdefault(("." in base, kind), n)
    return list(seen.values())


def test_planar_outputs_list_joint_reactions_too():
    from femb.benchmarks.scenes.planar import pendulum
    r = femb.simulate(pendulum.build().compile(), 0.05, 1e-3)
    names = r.outputs()
    joints = [e for e, v in r.model.lam_index.items() if len(v)]
    for j in joints:
        for c in ("Fx", "Fy", "M"):
            assert f"{j}.{c}" in names
    units = _check_every_output(r)
    assert units[f"{joints[0]}.M"] == "N·m" and units[f"{joints[0]}.Fx"] == "N"


# ---------------------------------------------------------------- reaction_at over all steps
def _per_step(r, joint):
    """The joint's reaction on b from the per-step VTK path (``joint_reactions``, reduced to p_a),
    moved to the joint's point p_b on b (M_pb = M_pa + (p_a − p_b) × F)."""
    m = r.model
    g, k = next((g, k) for g in m.constraint_groups for k, e in enumerate(g.elements) if e.name == joint)
    e = g.elements[k]
    qx = np.hstack((r.q, np.broadcast_to(m.q_fixed, (r.t.size, m.nfix))))
    out = []
    for i, t in enumerate(r.t):
        F, M, pa, pb = joint_reactions(g.cls, g.cls.pack([e]), t, qx[i, g.xdofs[k]][None],
                                       r.lam[i, g.lam[k]][None])
        out.append(np.concatenate((F[0], M[0] + np.cross(pa[0] - pb[0], F[0]))))
    return np.array(out)


def test_reaction_at_agrees_with_the_per_step_joint_output(crank_run, wheel_run):
    for r, joint in ((crank_run, "guide"), (crank_run, "B"), (wheel_run, "axle")):
        ref = _per_step(r, joint)
        R = r.reaction_at(joint)
        scale = np.abs(ref).max()
        assert scale > 0.0
        np.testing.assert_allclose(R, ref, rtol=0, atol=1e-12 * scale)
        Ra = r.reaction_at(joint, on="a")
        np.testing.assert_allclose(Ra[:, 0:3], -R[:, 0:3], rtol=0, atol=1e-12 * scale)


# ---------------------------------------------------------------- imports and docstrings
def test_every_spatial_element_type_is_importable_from_femb_elements():
    import femb.elements as E
    from femb.elements import spatial_bodies, spatial_forces, spatial_joints
    bases = {spatial_joints.SpatialPairElement, spatial_forces._Load}       # abstract bases, not element types
    for mod in (spatial_bodies, spatial_joints, spatial_forces):
        for name in dir(mod):
            obj = getattr(mod, name)
            if isinstance(obj, type) and issubclass(obj, femb.system.element.Element) and obj.__module__ == mod.__name__ \
                    and obj not in bases and not name.startswith("_"):
                exported = [n for n in E.__all__ if getattr(E, n) is obj]
                assert exported, f"{mod.__name__}.{name} is not exported by femb.elements"
    assert E.SpatialRotationalSpringDamper is spatial_forces.RotationalSpringDamper
    assert E.RotationalSpringDamper.__module__ == "femb.elements.forces"
    from femb.elements import SpatialRigidBody, SphericalJoint  # noqa: F401 (the import of the README's example)


def test_spatial_paths_of_result_speak_3d():
    from femb.results.result import Result
    for meth in (Result.position, Result.point, Result.reaction_at, Result.series, Result.outputs):
        doc = meth.__doc__
        assert "(nt, 3)" in doc or "(x, y, z)" in doc or "spatial" in doc.lower(), meth.__name__
