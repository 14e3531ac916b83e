"""Output that cannot be written: one femb error naming the path and what was written so far (which
stays readable), raised before a run when the place is unwritable from the start.

Read-only places: a path under a regular file (works for any user, root included), and a real
read-only directory (a non-root user: mode 0555; root: a read-only tmpfs mount; skipped where
neither is possible). A full disk mid-run: the frame writer made to fail with ENOSPC, and a real
small tmpfs where one can be mounted.
"""
import errno
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from femb.base.geometry import GeometryBlock
from femb.errors import OutputError
from femb.io import vtk
from femb.io.vtk import TimeSeriesWriter, read_pvd


def _mount_tmpfs(path, opts):
    if os.geteuid() != 0 or not shutil.which("mount"):
        return False
    path.mkdir(parents=True, exist_ok=True)
    return subprocess.run(["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(path)],
                          capture_output=True).returncode == 0


@pytest.fixture
def read_only_dir(tmp_path):
    d = tmp_path / "ro"
    if os.geteuid() != 0:
        d.mkdir()
        d.chmod(0o555)
        yield d
        d.chmod(0o755)
        return
    if not _mount_tmpfs(d, "ro,size=1m"):
        pytest.skip("running as root without the right to mount a read-only file system")
    yield d
    subprocess.run(["umount", str(d)], check=False)


@pytest.fixture
def under_a_file(tmp_path):
    f = tmp_path / "a-file"
    f.write_text("not a folder")
    return f / "out"


def _blocks(k):
    pts = np.array([[0.0, 0.0, 0.0], [1.0, 0.1 * k, 0.0]])
    return [GeometryBlock("B", pts, [("line", np.array([[0, 1]]))])]


@pytest.mark.parametrize("where", ["read_only_dir", "under_a_file"])
def test_a_time_series_into_an_unwritable_place_fails_before_any_frame(where, request):
    d = request.getfixturevalue(where)
    with pytest.raises(OutputError) as ei:
        TimeSeriesWriter(d)
    assert str(d) in str(ei.value)
    if where == "read_only_dir":
        assert "cannot write into the output directory" in str(ei.value)


def test_a_full_disk_mid_run_is_one_error_naming_the_path_and_the_frames_written(tmp_path, monkeypatch):
    real = vtk.write_vtu
    calls = {"n": 0}

    def filling(path, mesh, **kw):
        calls["n"] += 1
        if calls["n"] > 3:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        return real(path, mesh, **kw)

    monkeypatch.setattr(vtk, "write_vtu", filling)
    monkeypatch.setattr(vtk, "PVD_FLUSH_INTERVAL", 1e9)       # the .pvd is stale when the disk fills
    with pytest.raises(OutputError) as ei:
        with TimeSeriesWriter(tmp_path / "out") as w:
            for k in range(6):
                w.write(0.1 * k, _blocks(k))
    msg = str(ei.value)
    assert str(tmp_path / "out") in msg and "frame 3" in msg and "No space left" in msg, msg
    assert "3 frames written before" in msg and "frame.pvd" in msg, msg
    assert ei.value.__context__ is None or not isinstance(ei.value.__context__, OutputError)
    listed = read_pvd(tmp_path / "out" / "frame.pvd")
    assert [t for t, _ in listed] == pytest.approx([0.0, 0.1, 0.2])
    for _, f in listed:
        vtk.read_frame(f)                   # the frames written stay readable


def test_a_full_disk_at_the_final_collection_is_one_error(tmp_path, monkeypatch):
    w = TimeSeriesWriter(tmp_path / "out")
    w.write(0.0, _blocks(0))
    w.write(0.1, _blocks(1))

    def full(path, text):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(vtk, "_atomic_write_text", full)
    with pytest.raises(OutputError, match="collection file.*No space left.*1 frame written before.*frame.pvd"):
        w.close()


@pytest.mark.skipif(os.geteuid() != 0, reason="mounts a small tmpfs (root)")
def test_femb_run_vtk_on_a_really_full_disk_stops_with_one_line(tmp_path):
    d = tmp_path / "small"
    if not _mount_tmpfs(d, "size=64k"):
        pytest.skip("cannot mount a tmpfs here")
    try:
        out = subprocess.run([sys.executable, "-m", "femb.console.cli", "run", "pendulum", "--t-end", "2", "--vtk", str(d),
                              "--progress", "off"], capture_output=True, text=True, timeout=600)
        assert out.returncode == 1, out.stderr
        lines = [ln for ln in out.stderr.splitlines() if ln.startswith("femb: error")]
        assert len(lines) == 1 and "Traceback" not in out.stderr, out.stderr
        assert str(d) in lines[0] and "No space left" in lines[0] and "written before" in lines[0], lines[0]
        listed = read_pvd(d / "frame.pvd")
        assert len(listed) > 0
        vtk.read_frame(listed[-1][1])
    finally:
        subprocess.run(["umount", str(d)], check=False)


def _cli(argv, capsys):
    """``femb ARGV`` in this process (``femb.console.cli.main``, as the console script calls it): the exit
    status, stdout and stderr. The full-disk test above runs the same command line in a process of
    its own."""
    from femb.console import cli
    try:
        code = cli.main(argv)
    except SystemExit as exc:
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.parametrize("where", ["read_only_dir", "under_a_file"])
def test_femb_run_json_and_vtk_into_an_unwritable_place_fail_before_the_run(where, request, capsys):
    d = request.getfixturevalue(where)
    for opt, dest in (("--json", d / "run.json"), ("--vtk", d / "frames" if where == "under_a_file" else d)):
        code, stdout, stderr = _cli(["run", "pendulum", "--t-end", "20", "--h", "1e-4", opt, str(dest)], capsys)
        assert code == 2, stderr
        assert str(d) in stderr, stderr
        assert "Traceback" not in stderr and "pendulum:" not in stdout, stdout
        assert "steps" not in stdout


@pytest.mark.parametrize("where", ["read_only_dir", "under_a_file"])
def test_render_png_into_an_unwritable_place_names_the_file(where, request):
    from femb.io.render import render_animation, render_png
    d = request.getfixturevalue(where)
    with pytest.raises(OutputError, match="out_png") as ei:
        render_png("no-such.pvd", d / "x.png")
    assert str(d) in str(ei.value)
    with pytest.raises(OutputError, match="out="):
        render_animation("no-such.pvd", d / "x.gif")


def test_save_png_on_a_full_disk_is_an_output_error(tmp_path, monkeypatch):
    from PIL import Image

    from femb.io import render

    def full(self, fp, *a, **k):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(fp))

    monkeypatch.setattr(Image.Image, "save", full)
    with pytest.raises(OutputError, match="x.png.*No space left.*nothing was written"):
        render._save_png(np.zeros((4, 4, 3), dtype=np.uint8), tmp_path / "x.png")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("where", ["read_only_dir", "under_a_file"])
def test_sweep_out_into_an_unwritable_place_fails_before_any_case(where, request):
    pytest.importorskip("distributed")
    pytest.importorskip("pyarrow")
    import femb
    d = request.getfixturevalue(where)
    dest = d / "sweep"
    with pytest.raises(OutputError, match="out: cannot") as ei:
        femb.sweep("slider_crank", grid={"k": [1e3, 1e5]}, t_end=0.03, h=5e-3, out=dest,
                   client="no-such-scheduler:1")
    assert str(dest) in str(ei.value) and "nothing was run" in str(ei.value)


def test_sweep_rows_on_a_full_disk_are_one_error_with_what_was_written(tmp_path, monkeypatch):
    pd = pytest.importorskip("pandas")
    pytest.importorskip("pyarrow")
    import importlib
    sw = importlib.import_module("femb.study.sweep")
    w = sw._Writer(tmp_path, flush_rows=2, flush_interval=1e9)
    w.add([{"case": 0, "case_id": "a", "x": 1.0}, {"case": 1, "case_id": "b", "x": 2.0}])
    real = pd.DataFrame.to_parquet

    def full(self, path, *a, **k):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(pd.DataFrame, "to_parquet", full)
    with pytest.raises(OutputError) as ei:
        w.add([{"case": 2, "case_id": "c", "x": 3.0}, {"case": 3, "case_id": "d", "x": 4.0}])
    assert "2 rows in 1 files written before" in str(ei.value) and str(tmp_path) in str(ei.value)
    w.flush()                                 # the final flush raises no second error
    monkeypatch.setattr(pd.DataFrame, "to_parquet", real)
    assert len(sw.read_results(tmp_path)) == 2
