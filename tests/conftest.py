"""Shared test fixtures: small mechanisms using every element type."""
import importlib.util
import math
import os
import sys
from pathlib import Path

import numpy as np
import pytest

# the suite measures what it compiles itself: no background compilation of the built-in kernels
# after the engine's first compilation (femb.solve.cache.start_background_build)
os.environ.setdefault("FEMB_BACKGROUND_BUILD", "0")

import femb  # noqa: E402


def _use_checkout_subpackages():
    """Import ``femb.elements`` and ``femb.benchmarks`` from this checkout.

    pyproject.toml maps them to the top-level folders ``elements/`` and
    ``benchmarks/``; an editable install records the folders of the checkout
    it was made from, so with ``PYTHONPATH`` pointing at another checkout
    ``femb`` would come from that checkout but its two subpackages from the
    installed one. When ``femb`` itself is this checkout's, load them from here.
    """
    root = Path(__file__).resolve().parent.parent
    if Path(femb.__file__).resolve().parent != root / "femb":
        return
    for name, folder in (("femb.elements", "elements"), ("femb.benchmarks", "benchmarks")):
        init = root / folder / "__init__.py"
        if name in sys.modules or not init.is_file():
            continue
        spec = importlib.util.spec_from_file_location(name, init,
                                                      submodule_search_locations=[str(root / folder)])
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
        setattr(femb, folder, module)


_use_checkout_subpackages()

from femb import Mechanism  # noqa: E402
from femb.base.functions import Harmonic, Polynomial, TimeFunction


def every_element_mechanism():
    """A (not physically meaningful) mechanism with one of every element type.

    Used for Jacobian checks: constraints need not be satisfied there.
    """
    from femb.elements import (DrivenAngle, DrivenDisplacement, Force, Gravity, Hinge, PointMass,
                               PointOnLine, RigidBody, RotationalSpringDamper, Slider, SpringDamper,
                               Torque)
    m = Mechanism("every")
    b1 = m.add(RigidBody("b1", 1.2, 0.05, (0.1, 0.2), 0.3, points={"p": (0.2, -0.1), "q": (-0.3, 0.05)}))
    b2 = m.add(RigidBody("b2", 0.7, 0.02, (0.6, -0.1), -0.4, points={"p": (-0.15, 0.1)}))
    b3 = m.add(RigidBody("b3", 0.4, 0.01, (1.0, 0.4), 1.1))
    pm = m.add(PointMass("pm", 0.3, (0.5, 0.5)))
    m.ground.add_point("A", (-0.2, 0.1))
    m.add(Hinge("h1", "ground", b1, point_a="A", point_b="q"))
    m.add(Hinge("h2", b1, b2, point_a="p", point_b="p"))
    m.add(Hinge("h3", b2, pm, point_a=(0.1, 0.2)))
    m.add(Slider("s1", b2, b3, axis=(0.6, 0.8), point_a=(0.05, 0.0), point_b=(-0.1, 0.02)))
    m.add(PointOnLine("l1", "ground", pm, axis=(1.0, 0.3)))
    m.add(DrivenAngle("da", b1, b3, Harmonic(0.3, 5.0, 0.2)))
    m.add(DrivenDisplacement("dd", b3, b2, Polynomial([0.0, 0.1, -0.4]), axis=(0.2, 1.0),
                             point_a=(0.03, 0.01), point_b=(0.02, -0.05)))
    m.add(SpringDamper("k1", b1, b3, 50.0, 0.7, 0.5, point_a="p", point_b=(0.1, 0.1)))
    m.add(SpringDamper("k2", b3, "ground", 20.0, 0.0, 0.3, point_b="A"))
    m.add(RotationalSpringDamper("r1", b2, b3, 3.0, 0.2, 0.1))
    m.add(Force("F1", b2, (1.5, -0.5), point="p"))
    m.add(Force("F2", b3, (Harmonic(2.0, 3.0), 0.7), point=(0.2, 0.1), frame="body"))
    m.add(Torque("T1", b1, 0.4))
    m.add(Torque("T2", b3, Harmonic(0.5, 2.0)))
    m.add(Gravity((0.0, -9.81)))
    return m


@pytest.fixture
def every_model():
    return every_element_mechanism().compile()


@pytest.fixture(scope="session")
def renderer():
    """Off-screen rendering: the tests that draw are skipped only when femb.io.can_render says
    no OpenGL context can be made on this machine (the reason is in the skip message)."""
    from femb.io import can_render

    ok, reason = can_render()
    if not ok:
        pytest.skip(f"off-screen rendering unavailable: {reason}")
    return reason


# --- CPU time per test -------------------------------------------------------------------------
# Wall times (``--durations``) are disturbed by other processes on a shared machine; the CPU time
# of the process running a test is much less so. ``--cpu-durations=N`` lists the N tests that used
# the most CPU time (setup + call + teardown, in the worker that ran them, so it works with xdist;
# the subprocesses a test waited for included), and the sum per test module.

def pytest_addoption(parser):
    parser.addoption("--cpu-durations", type=int, default=None, metavar="N",
                     help="list the N tests with the most CPU time (os.times, finished subprocesses included), 0 for all, "
                          "and the CPU time per test module")


def _cpu_seconds():
    """CPU time of this process and of its finished child processes (a test's subprocesses), in s."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def _timed_phase(item):
    t0 = _cpu_seconds()
    yield
    item.user_properties.append(("cpu_time", _cpu_seconds() - t0))


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_setup(item):
    yield from _timed_phase(item)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_call(item):
    yield from _timed_phase(item)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_teardown(item):
    yield from _timed_phase(item)


_CPU_TIMES = {}


def pytest_runtest_logreport(report):
    if report.when == "teardown":
        _CPU_TIMES[report.nodeid] = sum(v for k, v in report.user_properties if k == "cpu_time")


def pytest_terminal_summary(terminalreporter, config):
    n = config.getoption("--cpu-durations")
    if n is None or not _CPU_TIMES:
        return
    tr = terminalreporter
    ranked = sorted(_CPU_TIMES.items(), key=lambda kv: -kv[1])
    tr.write_sep("=", f"CPU time per test ({len(ranked)} tests, {sum(_CPU_TIMES.values()):.1f} s in all)")
    for nodeid, cpu in ranked[:n] if n else ranked:
        tr.write_line(f"{cpu:9.2f}s  {nodeid}")
    per_module = {}
    for nodeid, cpu in _CPU_TIMES.items():
        module = nodeid.split("::")[0]
        per_module[module] = per_module.get(module, 0.0) + cpu
    tr.write_sep("=", "CPU time per test module")
    for module, cpu in sorted(per_module.items(), key=lambda kv: -kv[1]):
        tr.write_line(f"{cpu:9.2f}s  {module}")
