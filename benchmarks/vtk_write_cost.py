"""Writing a frame: VTK's own XML writer (femb's route) against meshio's writer with the field data patched in.

``python -m femb.benchmarks.vtk_write_cost`` runs a planar scene (Andrews' mechanism) and a spatial one
(the Bricard mechanism), reads their frames back, and writes every frame again both ways, interleaved in
one process: :func:`femb.io.vtk.write_vtu` (``vtkXMLUnstructuredGridWriter``, field data native) and
the route femb took before, kept here as the reference (``meshio.vtu.write``, which drops field data,
then a ``<FieldData>`` element of exact ASCII values inserted after the ``<UnstructuredGrid>`` tag). It
prints the median µs per frame of each (median over ``--repeats`` passes over all frames), their ratio
and the file sizes, and checks that VTK's reader (what ParaView and pyvista use) reads the same points,
cells, point, cell and field data from both files.
"""
from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import numpy as np

_ESC = {'"': "&quot;", "\n": "&#10;", "\t": "&#9;", "\r": "&#13;"}
_TYPES = {np.dtype(t): n for t, n in [(np.int8, "Int8"), (np.int16, "Int16"), (np.int32, "Int32"),
                                      (np.int64, "Int64"), (np.uint8, "UInt8"), (np.uint16, "UInt16"),
                                      (np.uint32, "UInt32"), (np.uint64, "UInt64"), (np.float32, "Float32"),
                                      (np.float64, "Float64")]}


def reference_write(path, mesh):
    """The previous route: meshio's VTU writer, then the field data inserted as ASCII XML."""
    import meshio

    out = meshio.Mesh(mesh.points, [(c.type, c.data) for c in mesh.cells],
                      point_data={escape(k, _ESC): v for k, v in mesh.point_data.items()},
                      cell_data={escape(k, _ESC): list(v) for k, v in mesh.cell_data.items()})
    lines = ["<FieldData>"]
    for name, val in mesh.field_data.items():
        a = np.asarray(val)
        a = a.astype(np.uint8) if a.dtype == bool else a
        flat = a.reshape(a.shape[0] if a.ndim else 1, -1)
        text = " ".join(repr(float(x)) if a.dtype.kind == "f" else str(int(x)) for x in flat.ravel())
        comps = f' NumberOfComponents="{flat.shape[1]}"' if flat.shape[1] != 1 else ""
        lines.append(f'<DataArray type="{_TYPES[a.dtype]}" Name={quoteattr(str(name))} '
                     f'NumberOfTuples="{flat.shape[0]}"{comps} format="ascii">{text}</DataArray>')
    payload = ("\n".join(lines) + "\n</FieldData>\n").encode()
    raw = Path(str(path) + ".raw")
    meshio.vtu.write(raw, out, binary=True, compression="zlib")
    data = raw.read_bytes()
    tag = b"<UnstructuredGrid>\n"
    pos = data.find(tag) + len(tag)
    tmp = Path(str(path) + ".tmp")
    tmp.write_bytes(data[:pos] + payload + data[pos:])
    os.replace(tmp, path)
    raw.unlink()


def _frames(scene, t_end, h, every, folder):
    import femb.cli

    femb.cli.main(["run", scene, "--t-end", str(t_end), "--h", str(h), "--vtk", str(folder), "--every", str(every),
                   "--progress", "off"])
    from femb.io.vtk import read_frame, read_pvd

    return [read_frame(p) for _, p in read_pvd(Path(folder) / "frame.pvd")]


def same_content(a, b):
    """Whether VTK's reader gets the same points, cells and data from two .vtu files."""
    import pyvista as pv

    ga, gb = pv.read(a), pv.read(b)
    if not (np.array_equal(ga.points, gb.points) and np.array_equal(ga.celltypes, gb.celltypes)
            and np.array_equal(ga.cell_connectivity, gb.cell_connectivity)):
        return False
    for da, db in ((ga.point_data, gb.point_data), (ga.cell_data, gb.cell_data), (ga.field_data, gb.field_data)):
        if sorted(da.keys()) != sorted(db.keys()):
            return False
        if any(not np.array_equal(np.asarray(da[k]), np.asarray(db[k])) or np.asarray(da[k]).dtype
               != np.asarray(db[k]).dtype for k in da.keys()):
            return False
    return True


def _pass(write, meshes, folder, tag):
    t0 = time.perf_counter()
    for i, m in enumerate(meshes):
        write(folder / f"{tag}_{i:06d}.vtu", m)
    return (time.perf_counter() - t0) / len(meshes)


def main(argv=None):
    from femb.io.vtk import write_vtu

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    print(f"{'scene':10s} {'frames':>6s} {'vtk µs':>9s} {'meshio+patch µs':>16s} {'ratio':>6s} "
          f"{'vtk kB':>7s} {'ref kB':>7s}  same content")
    for scene, t_end, h, every in (("andrews", 0.003, 1e-5, 10), ("bricard", 1.0, 0.01, 1)):
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            meshes = _frames(scene, t_end, h, every, tmp / "run")
            new, ref = [], []
            for _ in range(args.repeats):          # interleaved: both routes see the same load
                new.append(_pass(write_vtu, meshes, tmp, "vtk"))
                ref.append(_pass(reference_write, meshes, tmp, "ref"))
            n = len(meshes)
            same = all(same_content(tmp / f"vtk_{i:06d}.vtu", tmp / f"ref_{i:06d}.vtu") for i in range(n))
            kb_new = sum((tmp / f"vtk_{i:06d}.vtu").stat().st_size for i in range(n)) / n / 1e3
            kb_ref = sum((tmp / f"ref_{i:06d}.vtu").stat().st_size for i in range(n)) / n / 1e3
            mn, mr = statistics.median(new), statistics.median(ref)
            print(f"{scene:10s} {n:6d} {mn * 1e6:9.0f} {mr * 1e6:16.0f} {mn / mr:6.2f} {kb_new:7.1f} {kb_ref:7.1f}  "
                  f"{'yes' if same else 'NO'}")


if __name__ == "__main__":
    main()
