"""The static and buckling beam scenes (benchmarks/scenes/beams/beam_rollup.py, beam_bend45.py, argyris_frame.py).

References: the exact circle of pure bending; GXBeam's tip at F = 600 and Simo & Vu-Quoc's
tip positions (docs/beams.md, "Validation (spatial)"); Argyris et al. 1979, P_cr = 1.088 N.
"""
import json

import numpy as np
import pytest

from femb.console import cli
from femb.study import registry


@pytest.mark.parametrize("n", [3, 5, 16])
def test_rollup_scene_on_the_exact_circle(n):
    sc = registry.load("beam_rollup")
    model = sc.model(n_elements=n)
    r = sc.module.solve(model, load_steps=max(4, 2 * n))
    out, ref = sc.outputs(r), sc.reference(r.t)
    assert r.t[-1] == 1.0
    L = sc.module.DATA["L"]
    assert out["max_node_error"].max() <= 1e-9 * L               # every node, every level
    for k in ("tip_x", "tip_y", "tip_z"):
        assert np.abs(out[k] - ref[k]).max() <= 1e-9 * L
    assert abs(out["tip_x"][-1]) <= 1e-9 * L and abs(out["tip_y"][-1]) <= 1e-9 * L   # closed circle


def test_rollup_refuses_fewer_than_three_elements():
    with pytest.raises(ValueError):
        registry.load("beam_rollup").model(n_elements=2)


def test_bend45_scene_against_gxbeam_and_simo_vu_quoc():
    sc = registry.load("beam_bend45")
    m = sc.module
    out = sc.outputs(m.solve(sc.model()))
    u = np.array([out["u_x"][-1], out["u_y"][-1], out["u_z"][-1]])
    assert np.linalg.norm(u - m.GXBEAM) <= 1e-3 * np.linalg.norm(m.GXBEAM)          # measured 4.7e-4
    assert np.abs(u - m.BATHE).max() <= 0.25                                         # 3 published digits
    out8 = sc.outputs(m.solve(sc.model(n_elements=8)))
    for F, ref in m.SIMO_VU_QUOC.items():
        k = int(np.argmin(np.abs(out8["F"] - F)))
        x = m.TIP0 + np.array([out8["u_x"][k], out8["u_y"][k], out8["u_z"][k]])
        assert np.linalg.norm(x - ref) <= 2e-3 * np.linalg.norm(ref)


@pytest.fixture(scope="module")
def bend45_meshes():
    """The tip at F = 600 on 8, 16, 32 and 64 elements (each mesh solved on its own), shared by the
    two refinement checks below: the continuum check reads the first three meshes."""
    return registry.load("beam_bend45").module.refinement((8, 16, 32, 64))


def test_bend45_mesh_refinement_is_second_order(bend45_meshes):
    st = bend45_meshes
    assert np.all(np.abs(st["orders"] - 2.0) < 0.05)                                 # measured 2.01, 2.00


def test_bend45_converges_to_the_continuum_rod(bend45_meshes):
    """The check independent of femb: the Cosserat rod equations solved by shooting with scipy
    (benchmarks/references/cosserat_rod.py). Errors per component fall at order 2 and 16 elements are
    within 0.1 % of every component (measured 4.8e-4, 8.6e-4, 6.6e-4; GXBeam's 16 elements: 2.0e-3 in u_x)."""
    m = registry.load("beam_bend45").module
    uc = m.continuum()
    assert bend45_meshes["n"][:3] == [8, 16, 32]
    u = bend45_meshes["u"][:3]
    err = np.abs(u / uc - 1.0)                             # (3 meshes, 3 components)
    assert np.all(err[1] < 1e-3), err[1]
    assert np.all(np.abs(np.log2(err[:-1] / err[1:]) - 2.0) < 0.05), err


def test_continuum_rod_reference_is_exact_on_the_rollup():
    """The shooting reference itself, on a case with a closed form: a straight rod under the end moment
    2πEI/L closes into a circle (tip back at the clamp, frame back to the start)."""
    from femb.benchmarks.references.cosserat_rod import clamped_rod
    EI, L = 2.0, 1.5
    C = np.diag([1e3, 1e3, 1e3, 1.0, EI, EI])
    out = clamped_rod(C, L, np.eye(3), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), M=(0.0, 0.0, 2 * np.pi * EI / L),
                      load_steps=8)
    assert np.abs(out["x"]).max() < 1e-9 * L
    assert np.abs(out["R"] - np.eye(3)).max() < 1e-9


def test_argyris_frame_scene():
    sc = registry.load("argyris_frame")
    r = sc.module.solve(sc.model(n_elements=20))
    out = sc.outputs(r)
    assert abs(out["P_cr"][0] / 1.088 - 1.0) < 1e-3                                 # measured −3.1e-4
    assert out["mode_in_plane"][0] < 1e-2                                            # lateral mode


def test_femb_run_static_scenes(tmp_path, capsys):
    assert cli.main(["run", "argyris_frame", "--json", str(tmp_path / "a.json")]) == 0
    data = json.loads((tmp_path / "a.json").read_text())
    assert data["analysis"] == "buckling" and abs(data["outputs"]["P_cr"] - 1.088) < 0.01
    assert data["params"]["n_elements"] == {"value": 10, "unit": "-", "given": False}
    assert data["femb_version"] and data["settings"] == {}          # its solve() takes no settings
    assert cli.main(["run", "beam_rollup", "--set", "n_elements=4", "--set", "load_steps=8",
                     "--json", str(tmp_path / "r.json")]) == 0
    data = json.loads((tmp_path / "r.json").read_text())
    assert data["settings"] == {"load_steps": 8} and data["params"]["n_elements"]["given"] is True
    out = capsys.readouterr().out
    assert "beam_rollup: static analysis, 9 level(s)" in out
    assert "beam_rollup" not in registry.names() and "beam_rollup" in registry.static_names()
