"""One-way layers: the import graph of femb's modules, read from the source (every import
statement, at module level or inside a function).

* the library module :mod:`femb.sweep` depends on no command-line module, directly or
  through others;
* the command-line modules import each other one way (``cli`` → ``cli_sweep`` →
  ``cli_common``);
* the benchmark suite's runners (``adaptive_suite``, ``stress``, ``work_precision``,
  ``suite``) form no cycle: what they share lives in ``bench_common``.
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
    assert "femb.benchmarks.registry" in graph["femb.sweep"]          # imported inside a function
    assert "femb.benchmarks.peers" in graph["femb.benchmarks.stress"]  # from . import peers


def test_sweep_depends_on_no_command_line_module(graph):
    cli = {"femb.cli", "femb.cli_sweep", "femb.cli_common"}
    assert not (_reachable(graph, "femb.sweep") & cli), _reachable(graph, "femb.sweep") & cli
    assert "femb.parsing" in graph["femb.sweep"]


def test_command_line_modules_import_one_way(graph):
    nodes = ["femb.cli", "femb.cli_sweep", "femb.cli_common", "femb.parsing", "femb.sweep"]
    assert _cycle(graph, nodes) is None, _cycle(graph, nodes)
    assert "femb.cli" not in _reachable(graph, "femb.cli_sweep")


def test_benchmark_runners_form_no_cycle(graph):
    nodes = [f"femb.benchmarks.{m}" for m in ("adaptive_suite", "stress", "work_precision", "suite",
                                                "bench_common")]
    assert _cycle(graph, nodes) is None, _cycle(graph, nodes)
    assert not (_reachable(graph, "femb.benchmarks.bench_common") & set(nodes))


def test_the_shared_helpers_are_the_same_objects_everywhere():
    from femb import cli, cli_sweep, parsing
    from femb.benchmarks import adaptive_suite, bench_common, stress, work_precision
    assert cli.parse_value is parsing.parse_value and cli.UsageError is cli_sweep.UsageError
    for name in ("clean", "first_line", "simulate_timed", "errors"):
        assert getattr(work_precision, name) is getattr(bench_common, name)
        assert getattr(adaptive_suite, name) is getattr(bench_common, name)
    assert stress.criterion is adaptive_suite.criterion is bench_common.criterion
    assert set(adaptive_suite.TESTS) <= set(stress.TESTS)
