"""Function sizes in ``femb/``: no function longer than 100 lines or with more than 10 parameters.

The scan reads the source (``ast``), every function and method at any depth (closures
included, named ``outer.<locals>.inner``). Measures:

* **lines**: from the ``def`` line to the last line of the body, without the docstring (a
  public function's numpydoc Parameters section is documentation, not code to split);
* **parameters**: every named parameter, positional or keyword-only, ``*args`` and
  ``**kwargs`` one each, without the ``self``/``cls`` of a method.

A function over either limit must be in :data:`ALLOWED` with its measured reason; the
list is mirrored in docs/engine.md, section "Functions that stay long". An entry whose
function is back within the limits (or gone) fails too, so the list stays true.
"""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MAX_LINES = 100
MAX_PARAMS = 10

#: {"file:qualified name": reason}, one line each (mirrored in docs/engine.md)
ALLOWED = {
    # the compiled call of a user or built-in kernel: its arguments are the element contract's
    "femb/base/jit.py:call_force": "the element contract's 10 kernel arguments plus the kernel's address (packing them changes every element type)",
    "femb/base/jit.py:call_constraint": "the element contract's 10 kernel arguments plus the kernel's address (packing them changes every element type)",
    "femb/base/jit.py:call_velocity_constraint": "the element contract's 12 kernel arguments plus the kernel's address (packing them changes every element type)",
}


#: functions whose code is within the limits but which, counted with their docstrings, run over 100
#: lines: {"file:qualified name": measured reason}, mirrored in docs/engine.md (same section)
LONG_WITH_DOCSTRING = {
    "femb/analysis/static.py:solve_static": "165 lines: 10 of code, 155 of docstring (every strategy and keyword)",
    "femb/io/render.py:render_strip": "123 lines: 86 of code, 37 of docstring",
    "femb/io/render.py:render_animation": "109 lines: 69 of code, 40 of docstring",
    "femb/solve/solver.py:simulate": "137 lines: 50 of code, 87 of docstring (every solver keyword)",
    "femb/study/sweep.py:sweep": "144 lines: 60 of code, 84 of docstring (every keyword, the result's columns)",
    "femb/system/initial.py:consistent_initial_state": "159 lines: 73 of code, 86 of docstring (the start's equations)",
}

def _docstring_lines(fn):
    body = fn.body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
            and isinstance(body[0].value.value, str):
        return body[0].end_lineno - body[0].lineno + 1
    return 0


def _n_params(fn):
    a = fn.args
    names = [p.arg for p in a.posonlyargs + a.args]
    n = len(names) + len(a.kwonlyargs) + (a.vararg is not None) + (a.kwarg is not None)
    if names and names[0] in ("self", "cls"):
        n -= 1
    return n


def function_sizes(root=ROOT / "femb", base=ROOT):
    """{"femb/file.py:qualified name": (lines without docstring, parameters)} for every function."""
    sizes = {}
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(base).as_posix()

        def visit(node, prefix):
            for ch in ast.iter_child_nodes(node):
                if isinstance(ch, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    name = prefix + ch.name
                    lines = ch.end_lineno - ch.lineno + 1 - _docstring_lines(ch)
                    sizes[f"{rel}:{name}"] = (lines, _n_params(ch))
                    visit(ch, name + ".<locals>.")
                elif isinstance(ch, ast.ClassDef):
                    visit(ch, prefix + ch.name + ".")
                else:
                    visit(ch, prefix)

        visit(ast.parse(path.read_text(encoding="utf-8")), "")
    return sizes


def _too_big(sizes):
    return {k: v for k, v in sizes.items() if v[0] > MAX_LINES or v[1] > MAX_PARAMS}


def test_no_function_over_the_limits():
    big = _too_big(function_sizes())
    bad = [f"{k}: {lines} lines, {n} parameters" for k, (lines, n) in sorted(big.items()) if k not in ALLOWED]
    assert not bad, ("functions over 100 lines (docstring excluded) or 10 parameters; split them, or add "
                     "them to ALLOWED with the measured reason:\n" + "\n".join(bad))


def test_allow_list_is_current():
    big = _too_big(function_sizes())
    stale = [k for k in ALLOWED if k not in big]
    assert not stale, "ALLOWED names functions within the limits (or gone): remove " + ", ".join(stale)


def test_allow_list_mirrored_in_docs():
    text = (ROOT / "docs" / "engine.md").read_text(encoding="utf-8")
    section = text.split("## Functions that stay long", 1)
    assert len(section) == 2, "docs/engine.md has no section 'Functions that stay long'"
    missing = [k for k in ALLOWED if f"`{k}`" not in section[1]]
    assert not missing, "docs/engine.md, 'Functions that stay long', does not name " + ", ".join(missing)


@pytest.mark.parametrize("src, expected", [
    ('def f(a, b, *c, d, **e):\n    """doc\n\n    more"""\n    return 1\n', (2, 5)),
    ("class C:\n    def m(self, x):\n        def g():\n            pass\n        return g\n", None),
])
def test_scan_measures(tmp_path, src, expected):
    pkg = tmp_path / "femb"
    pkg.mkdir()
    (pkg / "x.py").write_text(src)
    sizes = function_sizes(pkg, tmp_path)
    if expected is not None:
        assert sizes["femb/x.py:f"] == expected
    else:
        assert sizes["femb/x.py:C.m"] == (4, 1)
        assert sizes["femb/x.py:C.m.<locals>.g"] == (2, 0)


def _total_lines(root=ROOT / "femb", base=ROOT):
    """{"file:name": lines from def to end, docstring included} for every function of ``root``."""
    out = {}
    for path in sorted(Path(root).rglob("*.py")):
        rel = path.relative_to(base).as_posix()

        def visit(node, prefix):
            for ch in ast.iter_child_nodes(node):
                if isinstance(ch, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    out[f"{rel}:{prefix}{ch.name}"] = ch.end_lineno - ch.lineno + 1
                    visit(ch, prefix + ch.name + ".<locals>.")
                elif isinstance(ch, ast.ClassDef):
                    visit(ch, prefix + ch.name + ".")
                else:
                    visit(ch, prefix)

        visit(ast.parse(path.read_text(encoding="utf-8")), "")
    return out


def test_functions_long_with_their_docstrings_are_named():
    """Counted with docstrings, every function over 100 lines is in ALLOWED or LONG_WITH_DOCSTRING
    (with its measured code and docstring lengths), and both lists name only such functions."""
    long = {k for k, n in _total_lines().items() if n > MAX_LINES} - set(ALLOWED)
    assert long == set(LONG_WITH_DOCSTRING), (sorted(long - set(LONG_WITH_DOCSTRING)),
                                              sorted(set(LONG_WITH_DOCSTRING) - long))
    text = (ROOT / "docs" / "engine.md").read_text(encoding="utf-8").split("## Functions that stay long", 1)[1]
    missing = [k for k in LONG_WITH_DOCSTRING if f"`{k}`" not in text]
    assert not missing, "docs/engine.md, 'Functions that stay long', does not name " + ", ".join(missing)
