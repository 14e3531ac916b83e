"""femb's compile cache: what it is keyed on, several processes at once, an unwritable directory."""
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from femb.base import jit


USER_MODULE = textwrap.dedent('''
    import numpy as np
    from femb.system.element import Element
    from femb.base.jit import kernel
    from {helpers} import stiffness


    @kernel
    def pull_force(P, t, tf, xe, ve, jac, fe, fq, fv):
        for e in range(xe.shape[0]):
            k = stiffness(P[e, 0])
            fe[e, 0] = -k * xe[e, 0]
            fe[e, 1] = -k * xe[e, 1]
            if jac:
                fq[e, 0, 0] = -k
                fq[e, 1, 1] = -k


    class Pull(Element):
        has_force = True
        kernels = {{"force": pull_force}}

        def __init__(self, name, body, k):
            super().__init__(name)
            self.body, self.k = body, float(k)

        def resolve(self, lookup):
            self.body = lookup(self.body, "body")

        def nodes(self):
            return [self.body.node]

        @classmethod
        def pack(cls, elements):
            return {{"P": np.array([[e.k] for e in elements], dtype=float).reshape(-1, 1)}}
''')

HELPERS = textwrap.dedent('''
    from femb.base.jit import kernel


    @kernel
    def stiffness(k):
        return {factor} * k
''')

RUN = textwrap.dedent('''
    import sys
    sys.path.insert(0, {folder!r})
    import femb
    from femb.elements import RigidBody
    from {module} import Pull
    m = femb.Mechanism("pull")
    b = m.add(RigidBody("b", mass=1.0, inertia=0.1, position=(0.1, 0.0)))
    m.add(Pull("pull", b, 40.0))
    r = femb.simulate(m.compile(), t_end=0.05, h=1e-3)
    print("x =", r.body("b")[-1, 0])
''')


def _write_user_package(folder, tag, factor=1.0):
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"helpers_{tag}.py").write_text(HELPERS.format(factor=factor))
    (folder / f"user_{tag}.py").write_text(USER_MODULE.format(helpers=f"helpers_{tag}"))
    (folder / "unrelated.py").write_text("X = 1\n")
    return folder


def _import_fresh(folder, name):
    import importlib
    sys.path.insert(0, str(folder))
    try:
        for mod in [m for m in sys.modules if m.startswith(("user_", "helpers_"))]:
            del sys.modules[mod]
        importlib.invalidate_caches()
        return importlib.import_module(name)
    finally:
        sys.path.remove(str(folder))


def test_the_key_follows_the_kernels_own_files_and_not_unrelated_ones(tmp_path):
    folder = _write_user_package(tmp_path / "pkg", "a")
    mod = _import_fresh(folder, "user_a")
    key0 = jit.source_key(mod.pull_force.py_func)
    files = {Path(f).name for f in jit.dependency_files(mod.pull_force.py_func)}
    assert {"user_a.py", "helpers_a.py"} <= files
    assert "unrelated.py" not in files
    # an edit of an unrelated file beside the kernel: same key
    (folder / "unrelated.py").write_text("X = 2  # edited\n")
    jit._file_hashes.clear()
    assert jit.source_key(_import_fresh(folder, "user_a").pull_force.py_func) == key0
    # an edit of the helper the kernel calls (another file): a new key
    (folder / "helpers_a.py").write_text(HELPERS.format(factor=2.0))
    jit._file_hashes.clear()
    assert jit.source_key(_import_fresh(folder, "user_a").pull_force.py_func) != key0


def test_the_key_does_not_depend_on_the_user_or_the_cache_location(tmp_path, monkeypatch):
    from femb import engine
    key = jit.source_key(engine.run.py_func)
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("USER", "somebody-else")
    monkeypatch.setenv("FEMB_CACHE_DIR", str(tmp_path / "elsewhere"))
    assert jit.source_key(engine.run.py_func) == key


def _engine_only_cache(dst):
    """A cache directory holding this process's compiled engine only (no kernels)."""
    from femb import engine
    engine.ensure_engine(verbose=False)
    src = jit.cache_dir() / "numba"
    (dst / "numba").mkdir(parents=True)
    for d in src.iterdir():
        if d.is_dir() and d.name.startswith("engine."):
            shutil.copytree(d, dst / "numba" / d.name)
    return dst


def _env(cache):
    env = dict(os.environ, FEMB_CACHE_DIR=str(cache))
    env.pop("FEMB_DEBUG", None)
    return env


def test_two_processes_compile_a_new_kernel_once_and_both_run(tmp_path):
    cache = _engine_only_cache(tmp_path / "cache")
    folder = _write_user_package(tmp_path / "pkg", "b")
    script = RUN.format(folder=str(folder), module="user_b")
    procs = [subprocess.Popen([sys.executable, "-c", script], env=_env(cache), stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]
    outs = [p.communicate(timeout=600) for p in procs]
    for p, (out, err) in zip(procs, outs):
        assert p.returncode == 0, err
        assert "x =" in out
        assert "compiling the engine" not in err      # the engine came from the cache
    compiled = [err for _, err in outs if "compiled" in err and "Pull" in err]
    assert len(compiled) == 1, [e for _, e in outs]
    assert outs[0][0] == outs[1][0]
    # a third process loads everything: nothing compiles
    out = subprocess.run([sys.executable, "-c", script], env=_env(cache), capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0 and "compiled" not in out.stderr, out.stderr


def test_an_unwritable_cache_runs_in_memory_with_one_warning(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory")
    folder = _write_user_package(tmp_path / "pkg", "c")
    script = "import warnings\nwarnings.simplefilter('always')\n" + RUN.format(folder=str(folder), module="user_c")
    # the engine compiles in memory here: the price of an unwritable cache. What is checked is the
    # cache handling, not the machine code: LLVM without optimization (NUMBA_OPT=0) compiles it with
    # about 40 % less CPU time (measured: 56 s against 98 s on a loaded machine)
    env = dict(_env(blocker / "cache"), NUMBA_OPT="0")
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr
    assert "x =" in out.stdout
    assert out.stderr.count("CacheWarning") == 1, out.stderr
    assert "not writable" in out.stderr
    assert "Traceback" not in out.stderr


@pytest.mark.skipif(jit.jit_disabled(), reason="no compilation without the JIT")
def test_cache_commands_show_and_clear(tmp_path):
    env = _env(_engine_only_cache(tmp_path / "cache"))
    info = subprocess.run([sys.executable, "-m", "femb.console.cli", "cache", "info"], env=env, capture_output=True,
                          text=True, timeout=300)
    assert info.returncode == 0, info.stderr
    assert str(tmp_path / "cache") in info.stdout and "engine: compiled" in info.stdout
    clear = subprocess.run([sys.executable, "-m", "femb.console.cli", "cache", "clear"], env=env, capture_output=True,
                           text=True, timeout=300)
    assert clear.returncode == 0 and "cleared" in clear.stdout
    assert not any((tmp_path / "cache").iterdir())


COMPILE_ONLY = textwrap.dedent('''
    import sys
    sys.path.insert(0, {folder!r})
    from femb.system import kernels
    from {module} import Pull
    kernels.compiled_kernel("Pull", "force", Pull.kernels["force"])
    print("compiled" if kernels._fresh else "loaded")
''')


def test_one_cache_serves_machines_with_different_cpus(tmp_path):
    """numba's index records the CPU of each entry: a second CPU (here the generic one) adds its
    own entry beside the first, and each loads its own afterwards."""
    cache = tmp_path / "cache"
    folder = _write_user_package(tmp_path / "pkg", "d")
    script = COMPILE_ONLY.format(folder=str(folder), module="user_d")

    def run(**extra):
        env = dict(_env(cache), **extra)
        if not extra:
            env.pop("NUMBA_CPU_NAME", None)
        out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=300)
        assert out.returncode == 0, out.stderr
        return out.stdout.strip()

    assert run() == "compiled"
    assert run(NUMBA_CPU_NAME="generic") == "compiled"
    assert run() == "loaded"
    assert run(NUMBA_CPU_NAME="generic") == "loaded"


MANY_SIGNATURES = textwrap.dedent('''
    import sys
    sys.path.insert(0, {folder!r})
    import numpy as np
    from poly_{tag} import poly
    args = [3, 2.5, 1.5 + 2j, np.arange(3.0), np.int32(4), np.float32(0.5)]
    order = {order}
    out = [poly(args[i]) for i in order]
    print(repr(sorted(zip(order, map(repr, out)))))
''')

POLY = textwrap.dedent('''
    from femb.base.jit import kernel


    @kernel(allocates=True)
    def poly(x):
        return x * 2 + x * x
''')


def test_processes_saving_different_signatures_at_once_never_corrupt_the_cache(tmp_path):
    """Several processes compile different signatures of one function into one cache at once;
    afterwards every signature loads its own code (numba's index alone can point a signature at
    another's data file when two processes save at once)."""
    cache = tmp_path / "cache"
    folder = tmp_path / "pkg"
    folder.mkdir()
    (folder / "poly_e.py").write_text(POLY)
    orders = [[0, 1, 2, 3, 4, 5], [5, 4, 3, 2, 1, 0], [2, 0, 4, 1, 5, 3], [3, 5, 1, 4, 0, 2]]
    procs = [subprocess.Popen([sys.executable, "-c", MANY_SIGNATURES.format(folder=str(folder), tag="e", order=o)],
                              env=_env(cache), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for o in orders]
    outs = [p.communicate(timeout=600) for p in procs]
    for p, (out, err) in zip(procs, outs):
        assert p.returncode == 0, err
    expect = outs[0][0]
    assert all(out == expect for out, _ in outs)
    # fresh processes load each signature from the cache and get the same values
    for o in orders[:2]:
        out = subprocess.run([sys.executable, "-c", MANY_SIGNATURES.format(folder=str(folder), tag="e", order=o)],
                             env=_env(cache), capture_output=True, text=True, timeout=600)
        assert out.returncode == 0, out.stderr
        assert out.stdout == expect


def _damage(path, how):
    data = Path(path).read_bytes()
    if how == "truncated":
        Path(path).write_bytes(data[:len(data) // 3])
    elif how == "garbage":
        Path(path).write_bytes(bytes((7 * i + 13) % 256 for i in range(len(data))))
    else:
        Path(path).write_bytes(b"")


@pytest.fixture(scope="module")
def compiled_user_kernel(tmp_path_factory):
    """A cache holding the engine and the compiled kernels of a user package, made once per module.

    Every damaged-entry case starts from a copy of it: the first run that compiles and saves the
    user kernel is the same in each case, so it runs once (and its result is checked here).
    Returns (cache, script, stdout of the first run).
    """
    if jit.jit_disabled():
        pytest.skip("no compilation without the JIT")
    root = tmp_path_factory.mktemp("damaged-kernel")
    cache = _engine_only_cache(root / "cache")
    folder = _write_user_package(root / "pkg", "f")
    script = "import warnings\nwarnings.simplefilter('always')\n" + RUN.format(folder=str(folder), module="user_f")
    first = subprocess.run([sys.executable, "-c", script], env=_env(cache), capture_output=True, text=True,
                           timeout=600)
    assert first.returncode == 0, first.stderr
    assert "x =" in first.stdout
    return cache, script, first.stdout


@pytest.mark.skipif(jit.jit_disabled(), reason="no compilation without the JIT")
@pytest.mark.parametrize("which, how", [("nbi", "truncated"), ("nbi", "garbage"), ("nbc", "truncated"),
                                        ("nbc", "garbage"), ("nbc", "empty")])
def test_a_damaged_kernel_entry_is_discarded_and_compiled_again_with_one_warning(tmp_path, which, how,
                                                                                 compiled_user_kernel):
    template, script, first_stdout = compiled_user_kernel
    cache = Path(shutil.copytree(template, tmp_path / "cache"))
    files = sorted((cache / "numba").glob(f"user_f-*/*pull_force*.{which}"))
    assert files, sorted(p.name for p in (cache / "numba").rglob("*"))
    for f in files:
        _damage(f, how)
    out = subprocess.run([sys.executable, "-c", script], env=_env(cache), capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr
    assert out.stdout == first_stdout
    assert out.stderr.count("CacheWarning") == 1, out.stderr
    assert "damaged" in out.stderr and "compiling again" in out.stderr
    assert "Traceback" not in out.stderr
    # the entry was rewritten: the next run loads it, silently
    again = subprocess.run([sys.executable, "-c", script], env=_env(cache), capture_output=True, text=True,
                           timeout=600)
    assert again.returncode == 0 and again.stdout == first_stdout
    assert "CacheWarning" not in again.stderr and "compiled" not in again.stderr, again.stderr


@pytest.mark.skipif(jit.jit_disabled(), reason="no compilation without the JIT")
def test_a_damaged_engine_entry_is_discarded_and_compiled_again(tmp_path):
    cache = _engine_only_cache(tmp_path / "cache")
    small = sorted((cache / "numba").glob("engine.*/*lie_reset-*.nbc"))
    assert small
    for f in small:
        _damage(f, "garbage")
    script = ("import warnings\nwarnings.simplefilter('always')\nfrom femb import engine\n"
              "engine.ensure_engine()\nprint('ready')")
    out = subprocess.run([sys.executable, "-c", script], env=_env(cache), capture_output=True, text=True,
                         timeout=900)
    assert out.returncode == 0 and "ready" in out.stdout, out.stderr
    assert out.stderr.count("CacheWarning") == 1 and "damaged" in out.stderr, out.stderr
    assert "Traceback" not in out.stderr


def _read_only_runner(cache):
    """A command prefix under which ``cache`` cannot be written (its files stay readable), or None.

    A non-root user: the cache's modes without write permission. Root ignores modes, so root
    runs the process in a new user namespace (``unshare -U``: same files, no capabilities).
    """
    for p in [cache, *cache.rglob("*")]:
        p.chmod(p.stat().st_mode & ~0o222)
    if os.geteuid() != 0:
        return []
    if shutil.which("unshare"):
        probe = subprocess.run(["unshare", "-U", sys.executable, "-c",
                                f"import os; print(os.access({str(cache)!r}, os.W_OK))"],
                               capture_output=True, text=True, timeout=60)
        if probe.returncode == 0 and probe.stdout.strip() == "False":
            return ["unshare", "-U"]
    return None


@pytest.mark.skipif(jit.jit_disabled(), reason="no compilation without the JIT")
def test_a_complete_read_only_cache_loads_without_compiling_and_never_claims_to_cache(tmp_path):
    cache = _engine_only_cache(tmp_path / "cache")
    folder = _write_user_package(tmp_path / "pkg", "g")
    script = "import warnings\nwarnings.simplefilter('always')\n" + RUN.format(folder=str(folder), module="user_g")
    fill = subprocess.run([sys.executable, "-c", script], env=_env(cache), capture_output=True, text=True,
                          timeout=600)
    assert fill.returncode == 0, fill.stderr
    for lock in (cache / "numba").rglob("*.lock"):
        lock.unlink()           # as a copied image would be: no lock files
    prefix = _read_only_runner(cache)
    try:
        if prefix is None:
            pytest.skip("no way to make a directory read-only for this process")
        out = subprocess.run([*prefix, sys.executable, "-c", script], env=_env(cache), capture_output=True,
                             text=True, timeout=600)
        assert out.returncode == 0, out.stderr
        assert out.stdout == fill.stdout
        assert "compil" not in out.stderr and "CacheWarning" not in out.stderr, out.stderr
        # a kernel that is not there compiles in memory: one warning, never "cached"
        other = _write_user_package(tmp_path / "pkg2", "h", factor=2.0)
        script2 = "import warnings\nwarnings.simplefilter('always')\n" + RUN.format(folder=str(other), module="user_h")
        out = subprocess.run([*prefix, sys.executable, "-c", script2], env=_env(cache), capture_output=True,
                             text=True, timeout=600)
        assert out.returncode == 0, out.stderr
        assert "compiling the engine" not in out.stderr
        assert out.stderr.count("CacheWarning") == 1 and "not writable" in out.stderr, out.stderr
        assert "cached" not in out.stderr.replace("not writable", ""), out.stderr
        assert "in memory" in out.stderr
    finally:
        for p in [cache, *cache.rglob("*")]:
            p.chmod(p.stat().st_mode | 0o200)


def test_the_lock_is_filelock_with_a_timeout(tmp_path):
    import threading
    import warnings
    path = tmp_path / "x.lock"
    held, release = threading.Event(), threading.Event()

    def holder():
        with jit._file_lock(path):
            held.set()
            release.wait(30)

    t = threading.Thread(target=holder)
    t.start()
    held.wait(30)
    try:
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            with jit._file_lock(path, timeout=0.2):
                pass
        assert any(issubclass(x.category, jit.CacheWarning) and "compile lock" in str(x.message) for x in w)
    finally:
        release.set()
        t.join()


def test_the_default_cache_location_follows_platformdirs_and_the_environment(tmp_path, monkeypatch):
    import platformdirs
    monkeypatch.delenv("FEMB_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert jit.cache_dir() == Path(platformdirs.user_cache_dir("femb", appauthor=False))
    if sys.platform.startswith("linux"):
        assert jit.cache_dir() == tmp_path / "xdg" / "femb"
        monkeypatch.delenv("XDG_CACHE_HOME")
        monkeypatch.setenv("HOME", str(tmp_path / "home"))
        assert jit.cache_dir() == tmp_path / "home" / ".cache" / "femb"
    monkeypatch.setenv("FEMB_CACHE_DIR", str(tmp_path / "mine"))
    assert jit.cache_dir() == tmp_path / "mine" and (tmp_path / "mine").is_dir()
