"""femb.base.jit.borrowed: the arrays of a (nested) tuple as views without reference counts, for the
arguments of a compiled entry point (femb/contact/loop.py, run_steps; docs/contact.md §7)."""
import os
import subprocess
import sys

import numba
import numpy as np

from femb.base.jit import borrowed


@numba.njit(cache=False)
def _fill(P, pack):
    P, pack = borrowed(P), borrowed(pack)
    a, (b, c), n = pack
    for i in range(a.size):
        a[i] += 1.0
    b[1, :] = P[0]
    c[:] = n
    v = a[1:]                       # a view of a borrowed array
    v[0] = -5.0
    return a.sum() + b.sum() + c.sum(), b.shape[0], v.size


def test_borrowed_views_read_and_write_the_callers_arrays():
    P = np.arange(6.0).reshape(2, 3)
    a, b, c = np.zeros(4), np.zeros((2, 3)), np.zeros(3, dtype=np.int64)
    total, rows, nv = _fill(P, (a, (b, c), 7))
    np.testing.assert_array_equal(a, [1.0, -5.0, 1.0, 1.0])
    np.testing.assert_array_equal(b, [[0.0, 0.0, 0.0], [0.0, 1.0, 2.0]])
    np.testing.assert_array_equal(c, [7, 7, 7])
    assert total == a.sum() + b.sum() + c.sum() and rows == 2 and nv == 3
    for _ in range(1000):           # many calls: nothing freed that the caller still holds
        _fill(P, (a, (b, c), 7))
    assert a[0] == 1001.0 and b[1, 2] == 2.0


def test_borrowed_without_the_jit_is_the_identity():
    code = ("import numpy as np; from femb.base.jit import borrowed, jit_disabled; x = (np.zeros(2), (np.ones(1), 3)); "
            "assert jit_disabled() and borrowed(x) is x; print('ok')")
    out = subprocess.run([sys.executable, "-c", code], env=dict(os.environ, NUMBA_DISABLE_JIT="1"),
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr
