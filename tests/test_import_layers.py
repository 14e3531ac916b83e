"""One-way layers: the import graph of femb's modules, read from the source (every import
statement, at module level or inside a function).

* the library module :mod:`femb.study.sweep` depends on no command-line module, directly or
  through others;
* the command-line modules import each other one way (``cli`` → ``cli_sweep`` →
  ``cli_common``);
* the benchmark suite's runners (``adaptive_suite``, ``stress``, ``work_precision``,
  ``suite``) form no cycle: what they share lives in ``bench_common``.
* every module stands on a floor of :data:`FLOORS` and imports only from its own floor or lower
  ones; no import circle in the whole tree; nothing below the benchmarks imports them.
"""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = {"femb": ROOT / "femb", "femb.benchmarks": ROOT / "benchmarks", "femb.elements": ROOT / "elements"}


def _modules():
    mods = {}
    for pkg, folder in PACKAGES.items():
        for f in folder.rglob("*.py"):
            rel = f.relative_to(folder).with_suffix("")
            parts = [p for p in rel.parts if p != "__init__"]
            name = ".".join([pkg] + parts)
            mods[name] = (f, f.name == "__init__.py")
    return mods


def _resolve(mods, name):
    """The longest known module that ``name`` starts with (a name inside a module → the module)."""
    while name and name not in mods:
        name = name.rpartition(".")[0]
    return name or None


def import_graph():
    """{module: set of femb modules it imports} over femb, femb.benchmarks and femb.elements."""
    mods = _modules()
    graph = {}
    for name, (path, is_pkg) in mods.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        package = name if is_pkg else name.rpartition(".")[0]
        deps = set()
        for node in ast.walk(tree):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = package.split(".")
                    up = up[:len(up) - (node.level - 1)]
                    base = ".".join(up + ([base] if base else []))
                targets = [f"{base}.{a.name}" for a in node.names] + [base]
            for t in targets:
                r = _resolve(mods, t)
                if r is not None and r != name:
                    deps.add(r)
        graph[name] = deps
    return graph


def _reachable(graph, start):
    seen, todo = set(), [start]
    while todo:
        m = todo.pop()
        for d in graph.get(m, ()):
            if d not in seen:
                seen.add(d)
                todo.append(d)
    return seen


def _cycle(graph, nodes):
    """A cycle within ``nodes`` (list of modules), or None."""
    sub = {n: [d for d in graph[n] if d in nodes] for n in nodes}
    state = {}

    def visit(n, path):
        state[n] = 1
        for d in sub[n]:
            if state.get(d) == 1:
                return path[path.index(d):] + [d]
            if d not in state:
                c = visit(d, path + [d])
                if c:
                    return c
        state[n] = 2
        return None

    for n in nodes:
        if n not in state:
            c = visit(n, [n])
            if c:
                return c
    return None


@pytest.fixture(scope="module")
def graph():
    return import_graph()


def test_the_graph_sees_lazy_and_relative_imports(graph):
    assert "femb.study.registry" in graph["femb.study.sweep"]          # imported inside a function
    assert "femb.benchmarks.peers" in graph["femb.benchmarks.runners.stress"]  # from . import peers


def test_sweep_depends_on_no_command_line_module(graph):
    cli = {"femb.console.cli", "femb.console.cli_sweep", "femb.console.cli_common"}
    assert not (_reachable(graph, "femb.study.sweep") & cli), _reachable(graph, "femb.study.sweep") & cli
    assert "femb.study.parsing" in graph["femb.study.sweep"]


def test_command_line_modules_import_one_way(graph):
    nodes = ["femb.console.cli", "femb.console.cli_sweep", "femb.console.cli_common", "femb.study.parsing", "femb.study.sweep"]
    assert _cycle(graph, nodes) is None, _cycle(graph, nodes)
    assert "femb.console.cli" not in _reachable(graph, "femb.console.cli_sweep")


def test_benchmark_runners_form_no_cycle(graph):
    nodes = [f"femb.benchmarks.runners.{m}" for m in ("adaptive_suite", "stress", "work_precision", "suite",
                                                "bench_common")]
    assert _cycle(graph, nodes) is None, _cycle(graph, nodes)
    assert not (_reachable(graph, "femb.benchmarks.runners.bench_common") & set(nodes))


def test_the_shared_helpers_are_the_same_objects_everywhere():
    from femb.benchmarks.runners import adaptive_suite, bench_common, stress, work_precision
    from femb.console import cli, cli_sweep
    from femb.study import parsing
    assert cli.parse_value is parsing.parse_value and cli.UsageError is cli_sweep.UsageError
    for name in ("clean", "first_line", "simulate_timed", "errors"):
        assert getattr(work_precision, name) is getattr(bench_common, name)
        assert getattr(adaptive_suite, name) is getattr(bench_common, name)
    assert stress.criterion is adaptive_suite.criterion is bench_common.criterion
    assert set(adaptive_suite.TESTS) <= set(stress.TESTS)


# ---- the floors of the house ----
#: module prefix -> floor (docs/engine.md, "The house"). A module imports only from its own floor or
#: lower ones; the longest prefix decides. A new package gets its floor here.
FLOORS = {
    "femb": 0,
    "femb.errors": 0,
    "femb.base": 1,
    "femb.engine": 2,
    "femb.system": 3,
    "femb.elements": 3,
    "femb.io": 4,
    "femb.results": 5,
    "femb.solve": 6,
    "femb.analysis": 7,
    "femb.contact": 8,
    "femb.study": 9,
    "femb.benchmarks": 10,
    "femb.benchmarks.references": 10,
    "femb.benchmarks.scenes": 11,
    "femb.benchmarks.peers": 11,
    "femb.benchmarks.accuracy": 12,
    "femb.benchmarks.cost": 13,
    "femb.benchmarks.runners": 14,
    "femb.console": 15,
}


#: packages whose floor is their own ``__init__`` only: a module directly in them needs its own entry
EXACT = {"femb", "femb.benchmarks"}


def floor_of(module):
    """The floor of ``module`` (its longest prefix in :data:`FLOORS`, but :data:`EXACT`), or None."""
    probe = module
    while probe:
        if probe in FLOORS and (probe == module or probe not in EXACT):
            return FLOORS[probe]
        probe = probe.rpartition(".")[0]
    return None


def test_every_module_has_a_floor(graph):
    assert floor_of("femb.new_module") is None and floor_of("femb.solve.new_module") == FLOORS["femb.solve"]
    assert not [m for m in graph if floor_of(m) is None], sorted(m for m in graph if floor_of(m) is None)


def test_imports_go_down_or_stay_on_their_floor(graph):
    up = sorted(f"{m} (floor {floor_of(m)}) imports {d} (floor {floor_of(d)})"
                for m, deps in graph.items() for d in deps
                if None not in (floor_of(m), floor_of(d)) and floor_of(d) > floor_of(m))
    assert not up, "\n".join(up)


def test_the_floor_table_sees_upward_imports():
    fake = {"femb.system.model": {"femb.solve.solver"}, "femb.solve.solver": set()}
    assert floor_of("femb.system.model") < floor_of("femb.solve.solver")
    assert [d for m, deps in fake.items() for d in deps if floor_of(d) > floor_of(m)] == ["femb.solve.solver"]


def test_no_import_circle_in_the_whole_tree(graph):
    # a package's __init__ runs before its modules: a module importing its own package is no circle
    g = {m: {d for d in deps if not m.startswith(d + ".")} for m, deps in graph.items()}
    assert _cycle(g, sorted(g)) is None, _cycle(g, sorted(g))


def test_the_core_imports_no_benchmark(graph):
    core = [m for m in graph if not m.startswith(("femb.benchmarks", "femb.console"))]
    bad = sorted(f"{m} imports {d}" for m in core for d in graph[m] if d.startswith("femb.benchmarks"))
    assert not bad, bad
