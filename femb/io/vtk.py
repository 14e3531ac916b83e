"""VTK output: merge geometry blocks into one mesh and stream a time series.

Elements describe their looks as :class:`femb.base.geometry.GeometryBlock` records.
This module is the only place that turns those records into files:

* :func:`merge_blocks` joins the blocks of one instant into a single
  :class:`meshio.Mesh` (one unstructured grid per instant);
* :func:`write_vtu` writes such a mesh as a VTK XML ``.vtu`` file, atomically,
  including field data (which meshio's own writer drops);
* :class:`TimeSeriesWriter` streams one ``.vtu`` per frame and keeps a ParaView
  ``.pvd`` collection up to date;
* :func:`read_pvd` and :func:`read_frame` read the results back.

Nothing here imports pyvista; pictures are made by :mod:`femb.io.render`.
"""
from __future__ import annotations

import math
import os
import re
import time as _time
import xml.etree.ElementTree as ET
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import meshio
import numpy as np

__all__ = [
    "OutputError",
    "merge_blocks",
    "write_vtu",
    "TimeSeriesWriter",
    "read_pvd",
    "read_frame",
    "pvd_time",
]

#: Minimum wall time in seconds between two rewrites of the ``.pvd`` file.
PVD_FLUSH_INTERVAL = 0.5

#: Prefix of the field-data entries that map element type names to ids.
ELEMENT_TYPE_PREFIX = "element_type."


from femb.errors import OutputError  # noqa: E402  (femb's own exception class)


# ---------------------------------------------------------------------------
# merging blocks
# ---------------------------------------------------------------------------


def _as_points(block, index):
    pts = np.asarray(block.points, dtype=float)
    if pts.ndim == 1 and pts.size == 0:
        pts = pts.reshape(0, 3)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise OutputError(
            f"geometry block {index} ({block.name!r}): points must have shape (k, 3), "
            f"got {pts.shape}"
        )
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    return pts


def _split_cells(block, index, ctype, conn):
    """Return ``[(ctype, conn2d, rows)]`` for one cell block of a geometry block.

    ``rows`` indexes the cells of the original block in the order they appear
    in the returned sub-blocks (``None`` when nothing was reordered). Polygons
    with different vertex counts are split into one sub-block per count,
    because a meshio cell block stores a rectangular connectivity array.
    """
    if isinstance(conn, np.ndarray) and conn.dtype != object:
        arr = conn
        if arr.ndim == 1 and arr.size == 0:
            arr = arr.reshape(0, 1)
        if arr.ndim == 1 and ctype == "vertex":
            arr = arr.reshape(-1, 1)
        if arr.ndim != 2:
            raise OutputError(
                f"geometry block {index} ({block.name!r}): connectivity of {ctype!r} "
                f"cells must have shape (ncell, nverts), got {arr.shape}"
            )
        return [(ctype, arr.astype(np.int64, copy=False), None)]
    rows_by_count: dict[int, list[int]] = {}
    cells = [np.asarray(c, dtype=np.int64).ravel() for c in conn]
    for i, c in enumerate(cells):
        rows_by_count.setdefault(len(c), []).append(i)
    if len(rows_by_count) > 1 and ctype != "polygon":
        raise OutputError(
            f"geometry block {index} ({block.name!r}): {ctype!r} cells have varying "
            f"vertex counts {sorted(rows_by_count)}; only 'polygon' cells may"
        )
    out = []
    for count, rows in rows_by_count.items():
        arr = np.array([cells[i] for i in rows], dtype=np.int64).reshape(len(rows), count)
        out.append((ctype, arr, np.asarray(rows, dtype=np.intp)))
    if len(out) == 1:
        out[0] = (out[0][0], out[0][1], None)
    return out


def _check_dtype(arr, what):
    if arr.dtype == bool:
        return arr.astype(np.uint8)
    if arr.dtype.kind not in "iuf":
        raise OutputError(f"{what}: data type {arr.dtype} cannot be written to VTK")
    return arr


def merge_blocks(blocks, field_data=None):
    """Join geometry blocks into one mesh.

    Parameters
    ----------
    blocks : sequence of GeometryBlock
        The geometry of one instant, typically one block per element type.
    field_data : dict of str to array_like, optional
        Extra field data (whole-mesh values such as ``{"TimeValue": t}``);
        scalars become arrays of length 1.

    Returns
    -------
    meshio.Mesh
        Points of all blocks stacked in order, shape (sum k, 3); one meshio
        cell block per (geometry block, cell type) in order, with the
        connectivity shifted by the block's point offset. Polygons with
        varying vertex counts are split into one cell block per count (the
        per-cell data is reordered with them).

    Notes
    -----
    * A point or cell data field that only some blocks provide is filled with
      zeros of the same trailing shape and dtype in the others, so every
      field exists on every cell and point (ParaView can colour by it).
    * A block with points but no cells gets one ``"vertex"`` cell per point,
      so its points are visible.
    * Cell data ``element_type`` (int32) holds, for each cell, the index of
      its block's name among the distinct block names in order of first
      appearance; field data ``"element_type.<name>"`` holds ``[index]`` for
      each name, so the numbers can be read back as names.
    """
    blocks = list(blocks)
    names: list[str] = []
    for b in blocks:
        if b.name not in names:
            names.append(b.name)
    type_id = {n: i for i, n in enumerate(names)}

    points, cells, cell_src, npts_per_block = _stack_blocks(blocks)
    point_data = _merged_point_data(blocks, npts_per_block)
    cell_data = _merged_cell_data(blocks, cells, cell_src, type_id)
    fd = {}
    for name in names:
        fd[ELEMENT_TYPE_PREFIX + str(name)] = np.array([type_id[name]], dtype=np.int32)
    for key, val in (field_data or {}).items():
        fd[str(key)] = np.atleast_1d(np.asarray(val))
    return meshio.Mesh(points, cells, point_data=point_data, cell_data=cell_data, field_data=fd)


def _stack_blocks(blocks):
    """The points of all blocks stacked, (sum k, 3); the cell blocks [(cell type, connectivity)] with
    connectivity shifted by each block's point offset; per output cell block (block index, cell
    block index or None, rows or None); the number of points per block."""
    all_points = []
    cells = []  # list of (ctype, conn)
    cell_src = []  # per output cell block: (block index, cell block index, rows)
    offset = 0
    npts_per_block = []
    for bi, b in enumerate(blocks):
        pts = _as_points(b, bi)
        k = len(pts)
        npts_per_block.append(k)
        all_points.append(pts)
        if not b.cells and k:
            # a block of bare points is shown as its points
            cells.append(("vertex", np.arange(offset, offset + k, dtype=np.int64)[:, None]))
            cell_src.append((bi, None, None))
        for ci, item in enumerate(b.cells):
            try:
                ctype, conn = item
            except (TypeError, ValueError):
                raise OutputError(
                    f"geometry block {bi} ({b.name!r}): cell block {ci} must be a "
                    f"(cell type, connectivity) pair"
                ) from None
            for ctype_, arr, rows in _split_cells(b, bi, ctype, conn):
                if arr.shape[0] == 0:
                    continue
                if arr.size and (arr.min() < 0 or arr.max() >= k):
                    raise OutputError(
                        f"geometry block {bi} ({b.name!r}): {ctype_!r} connectivity "
                        f"indexes points outside 0..{k - 1}"
                    )
                cells.append((ctype_, arr + offset))
                cell_src.append((bi, ci, rows))
        offset += k
    points = np.concatenate(all_points) if all_points else np.zeros((0, 3))
    return points, cells, cell_src, npts_per_block


def _merged_point_data(blocks, npts_per_block):
    """{name: (sum k, ...)}: each point data field of any block, zeros where a block lacks it."""
    point_data = {}
    pd_names: list[str] = []
    for b in blocks:
        for n in b.point_data:
            if n not in pd_names:
                pd_names.append(n)
    for name in pd_names:
        present = {}
        for bi, b in enumerate(blocks):
            if name in b.point_data:
                a = _check_dtype(
                    np.asarray(b.point_data[name]),
                    f"geometry block {bi} ({b.name!r}) point data {name!r}",
                )
                if a.shape[:1] != (npts_per_block[bi],):
                    raise OutputError(
                        f"geometry block {bi} ({b.name!r}) point data {name!r}: "
                        f"expected {npts_per_block[bi]} values, got shape {a.shape}"
                    )
                present[bi] = a
        trailing = {a.shape[1:] for a in present.values()}
        if len(trailing) > 1:
            raise OutputError(
                f"point data {name!r}: blocks give different shapes per point {sorted(trailing)}"
            )
        tshape = trailing.pop()
        dtype = np.result_type(*[a.dtype for a in present.values()])
        parts = [
            present[bi].astype(dtype, copy=False) if bi in present
            else np.zeros((npts_per_block[bi],) + tshape, dtype)
            for bi in range(len(blocks))
        ]
        point_data[name] = np.concatenate(parts)
    return point_data


def _block_cell_array(bi, b, name, ci):
    """Cell data ``name`` of cell block ``ci`` of block ``bi``, its length checked."""
    arrays = b.cell_data[name]
    if len(arrays) != len(b.cells):
        raise OutputError(
            f"geometry block {bi} ({b.name!r}) cell data {name!r}: expected one "
            f"array per cell block ({len(b.cells)}), got {len(arrays)}"
        )
    a = _check_dtype(
        np.asarray(arrays[ci]),
        f"geometry block {bi} ({b.name!r}) cell data {name!r}",
    )
    ncell = len(b.cells[ci][1])
    if a.shape[:1] != (ncell,):
        raise OutputError(
            f"geometry block {bi} ({b.name!r}) cell data {name!r}, cell block "
            f"{ci}: expected {ncell} values, got shape {a.shape}"
        )
    return a


def _merged_cell_data(blocks, cells, cell_src, type_id):
    """{name: [array per output cell block]}: each cell data field of any block (zeros where a
    block lacks it) and ``element_type``; {} without cells."""
    cell_data = {}
    cd_names: list[str] = []
    for b in blocks:
        for n in b.cell_data:
            if n not in cd_names:
                cd_names.append(n)
    if "element_type" in cd_names:
        raise OutputError("cell data name 'element_type' is reserved for the block id")
    for name in cd_names:
        present = []
        for bi, b in enumerate(blocks):
            if name in b.cell_data:
                for ci in range(len(b.cells)):
                    present.append(_block_cell_array(bi, b, name, ci))
        trailing = {a.shape[1:] for a in present}
        if len(trailing) > 1:
            raise OutputError(
                f"cell data {name!r}: blocks give different shapes per cell "
                f"{sorted(trailing)}"
            )
        tshape = present[0].shape[1:] if present else ()
        dtype = np.result_type(*[a.dtype for a in present]) if present else np.float64
        out = []
        for (bi, ci, rows), (_, arr) in zip(cell_src, cells):
            b = blocks[bi]
            if name in b.cell_data and ci is not None:
                a = _block_cell_array(bi, b, name, ci).astype(dtype, copy=False)
                out.append(a if rows is None else a[rows])
            else:
                out.append(np.zeros((len(arr),) + tshape, dtype))
        cell_data[name] = out
    cell_data["element_type"] = [
        np.full(len(arr), type_id[blocks[bi].name], dtype=np.int32)
        for (bi, _, _), (_, arr) in zip(cell_src, cells)
    ]
    if not cells:
        return {}
    return cell_data


# ---------------------------------------------------------------------------
# writing a single .vtu
# ---------------------------------------------------------------------------

_VTK_TYPES = {
    np.dtype(np.int8): "Int8",
    np.dtype(np.int16): "Int16",
    np.dtype(np.int32): "Int32",
    np.dtype(np.int64): "Int64",
    np.dtype(np.uint8): "UInt8",
    np.dtype(np.uint16): "UInt16",
    np.dtype(np.uint32): "UInt32",
    np.dtype(np.uint64): "UInt64",
    np.dtype(np.float32): "Float32",
    np.dtype(np.float64): "Float64",
}


def _field_data_xml(field_data):
    """ASCII ``<FieldData>`` element; floats are written with ``repr`` (exact)."""
    if not field_data:
        return b""
    lines = ["<FieldData>"]
    for name, val in field_data.items():
        a = np.asarray(val)
        if a.dtype == bool:
            a = a.astype(np.uint8)
        a = a.astype(a.dtype.newbyteorder("="), copy=False)
        if a.dtype not in _VTK_TYPES:
            raise OutputError(f"field data {name!r}: data type {a.dtype} cannot be written")
        flat = a.reshape(a.shape[0] if a.ndim else 1, -1)
        ncomp = flat.shape[1]
        if a.dtype.kind == "f":
            text = " ".join(repr(float(x)) for x in flat.ravel())
        else:
            text = " ".join(str(int(x)) for x in flat.ravel())
        comps = f' NumberOfComponents="{ncomp}"' if ncomp != 1 else ""
        lines.append(
            f'<DataArray type="{_VTK_TYPES[a.dtype]}" Name={quoteattr(str(name))} '
            f'NumberOfTuples="{flat.shape[0]}"{comps} format="ascii">{text}</DataArray>'
        )
    lines.append("</FieldData>\n")
    return "\n".join(lines).encode()


_XML_ATTR_ESC = {'"': "&quot;", "\n": "&#10;", "\t": "&#9;", "\r": "&#13;"}


def _escaped(d):
    # meshio's XML writer puts names into attributes verbatim; escape them here
    # so any name round-trips through a reader that unescapes.
    return {escape(str(k), _XML_ATTR_ESC): v for k, v in d.items()}


def write_vtu(path, mesh, *, compression="zlib"):
    """Write a mesh as a VTK XML unstructured grid (``.vtu``), atomically.

    Parameters
    ----------
    path : str or Path
        Target file; written under a temporary name in the same directory and
        renamed, so readers never see a partial file.
    mesh : meshio.Mesh
        The mesh; its ``field_data`` is written too (as exact ASCII values),
        which ``meshio.write`` alone would drop.
    compression : {"zlib", "lzma", None}
        Compression of the binary arrays.

    Raises
    ------
    OutputError
        If the directory does not exist or the mesh cannot be written.
    """
    path = Path(path)
    if path.suffix != ".vtu":
        raise OutputError(f"{path}: unknown output suffix {path.suffix!r}; expected '.vtu'")
    if not path.parent.is_dir():
        raise OutputError(f"{path}: directory {path.parent} does not exist")
    out = meshio.Mesh(
        mesh.points,
        [(c.type, c.data) for c in mesh.cells],
        point_data=_escaped(mesh.point_data),
        cell_data=_escaped({k: list(v) for k, v in mesh.cell_data.items()}),
    )
    fd_xml = _field_data_xml(getattr(mesh, "field_data", None))
    # Temporary names in the same directory (so os.replace is atomic), created
    # with plain open() so the final file gets the usual permissions.
    raw = path.with_name(f".{path.name}.{os.getpid()}.raw")
    final_tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        try:
            meshio.vtu.write(raw, out, binary=True, compression=compression)
        except Exception as exc:  # meshio raises assorted errors
            raise OutputError(f"{path}: cannot write mesh ({exc})") from exc
        if fd_xml:
            _insert_after_grid_tag(raw, final_tmp, fd_xml)
            os.replace(final_tmp, path)
        else:
            os.replace(raw, path)
    finally:
        for p in (raw, final_tmp):
            if p.exists():
                p.unlink()


def _insert_after_grid_tag(src, dst, payload, chunk=1 << 20):
    tag = b"<UnstructuredGrid>\n"
    with open(src, "rb") as fin, open(dst, "wb") as fout:
        head = fin.read(4096)
        pos = head.find(tag)
        if pos < 0:  # pragma: no cover - meshio always writes the tag early
            raise OutputError(f"{src}: unexpected VTU layout from meshio")
        pos += len(tag)
        fout.write(head[:pos])
        fout.write(payload)
        fout.write(head[pos:])
        while True:
            buf = fin.read(chunk)
            if not buf:
                break
            fout.write(buf)


# ---------------------------------------------------------------------------
# time series
# ---------------------------------------------------------------------------


def pvd_time(t):
    """The text of a time in a ``.pvd`` collection: ``t`` rounded to 15 significant digits.

    Times accumulated as ``k * h`` carry round-off in their last digits
    (``5 * 3e-4`` is ``0.0014999999999999998``); ParaView shows the
    attribute as written. Rounding to 15 significant digits (the precision a
    float64 holds for any decimal) and printing the shortest ``repr`` of the
    rounded float gives ``"0.0015"``. The exact time stays in each frame's
    ``TimeValue`` field data.

    Parameters
    ----------
    t : float
        Finite time in s.

    Returns
    -------
    str
        E.g. ``pvd_time(5 * 3e-4) == "0.0015"``, ``pvd_time(1e-300) == "1e-300"``.
    """
    return repr(float(format(float(t), ".15g")))


def _pvd_text(entries):
    lines = [
        '<?xml version="1.0"?>',
        '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
        "  <Collection>",
    ]
    for t, fname in entries:
        lines.append(
            f'    <DataSet timestep="{pvd_time(t)}" group="" part="0" file={quoteattr(fname)}/>'
        )
    lines.append("  </Collection>")
    lines.append("</VTKFile>")
    return "\n".join(lines) + "\n"


def check_writable_dir(directory, what="output directory"):
    """Raise :class:`OutputError` unless a file can be created in ``directory`` (an existing folder).

    Creates and removes one empty probe file: permission bits (:func:`os.access`) do not tell
    for root, a read-only mount or a network share, a real file does.
    """
    directory = Path(directory)
    if not directory.is_dir():
        why = "is a file, not a folder" if directory.exists() else "does not exist"
        parent = next((p for p in directory.parents if p.exists()), None)
        if parent is not None and not parent.is_dir():
            why = f"lies under {parent}, which is a file, not a folder"
        raise OutputError(f"{directory}: the {what} {why}; nothing was written")
    probe = directory / f".femb-write-test.{os.getpid()}"
    try:
        with open(probe, "wb"):
            pass
        probe.unlink()
    except OSError as exc:
        raise OutputError(f"{directory}: cannot write into the {what} ({exc.strerror or exc}); "
                          f"nothing was written") from None


def _atomic_write_text(path, text):
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


class TimeSeriesWriter:
    """Stream a motion to ``.vtu`` frames and a ParaView ``.pvd`` collection.

    Each :meth:`write` writes its frame file at once (nothing is kept in
    memory but the list of (t, file name) pairs). The collection file
    ``<basename>.pvd`` is rewritten atomically (temporary file in the same
    directory + :func:`os.replace`) after the first frame, then at most every
    :data:`PVD_FLUSH_INTERVAL` seconds of wall time, and always on
    :meth:`close`, which the context manager calls also when an exception
    propagates: the frames written so far stay listed and readable.

    Parameters
    ----------
    directory : str or Path
        Output directory, created if missing.
    basename : str, default "frame"
        Frame files are ``<basename>_000000.vtu``, ``<basename>_000001.vtu``...
        and the collection is ``<basename>.pvd``.
    every : int, default 1
        Keep one call of :meth:`write` out of ``every`` (the first, then every
        ``every``-th); the others return without writing.
    compression : {"zlib", "lzma", None}, default "zlib"
        Compression of the binary arrays in the frame files.
    clean : bool, default True
        Remove frame files ``<basename>_<digits>.vtu`` left in ``directory``
        by an earlier run, so the directory holds exactly this series.

    Attributes
    ----------
    path : Path
        The ``.pvd`` file.
    frames : int
        Number of frames written so far.
    entries : list of (float, str)
        Time and file name (relative to ``directory``) of each frame written.

    Examples
    --------
    >>> with TimeSeriesWriter("out", basename="pendulum") as w:  # doctest: +SKIP
    ...     for t, blocks in motion:
    ...         w.write(t, blocks)
    """

    def __init__(self, directory, basename="frame", every=1, *, compression="zlib", clean=True):
        if not isinstance(every, (int, np.integer)) or every < 1:
            raise OutputError(f"every must be a positive integer, got {every!r}")
        if not basename or os.sep in basename or (os.altsep and os.altsep in basename):
            raise OutputError(f"basename must be a plain file name stem, got {basename!r}")
        self.directory = Path(directory)
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"cannot create output directory {self.directory}: {exc}") from exc
        check_writable_dir(self.directory)
        self._listed = 0          # frames listed in the .pvd file on disk
        self.basename = basename
        self.every = int(every)
        self.compression = compression
        self.path = self.directory / f"{basename}.pvd"
        self.entries: list[tuple[float, str]] = []
        self._calls = 0
        self._closed = False
        self._last_flush = -math.inf
        if clean:
            pattern = re.compile(re.escape(basename) + r"_\d{6,}\.vtu")
            for p in self.directory.iterdir():
                if pattern.fullmatch(p.name) and p.is_file():
                    p.unlink()

    @property
    def frames(self):
        """Number of frames written so far."""
        return len(self.entries)

    def write(self, t, blocks_or_mesh, field_data=None):
        """Write the frame at time ``t`` (subject to ``every``).

        Parameters
        ----------
        t : float
            Time of the frame in s; written to 15 significant digits into
            the collection (:func:`pvd_time`) and exactly as field data
            ``TimeValue``.
        blocks_or_mesh : sequence of GeometryBlock or meshio.Mesh
            The geometry at ``t``; blocks are joined with :func:`merge_blocks`.
        field_data : dict, optional
            Extra field data for this frame.

        Returns
        -------
        str or None
            The frame's file name, or None when skipped because of ``every``.
        """
        if self._closed:
            raise OutputError(f"{self.path}: the time series writer is closed")
        t = float(t)
        if not math.isfinite(t):
            raise OutputError(f"{self.path}: time of a frame must be finite, got {t!r}")
        call = self._calls
        self._calls += 1
        if call % self.every:
            return None
        fd = {"TimeValue": np.array([t])}
        if field_data:
            fd.update(field_data)
        if isinstance(blocks_or_mesh, meshio.Mesh):
            m = blocks_or_mesh
            mesh = meshio.Mesh(
                m.points, m.cells, point_data=m.point_data, cell_data=m.cell_data,
                field_data={**m.field_data, **fd},
            )
        else:
            mesh = merge_blocks(blocks_or_mesh, field_data=fd)
        fname = f"{self.basename}_{len(self.entries):06d}.vtu"
        try:
            write_vtu(self.directory / fname, mesh, compression=self.compression)
        except (OutputError, OSError) as exc:
            self._fail(f"writing frame {len(self.entries)} ({fname}, t = {t:.6g} s) failed", exc)
        self.entries.append((t, fname))
        now = _time.monotonic()
        if now - self._last_flush >= PVD_FLUSH_INTERVAL:
            self.flush()
        return fname

    def _fail(self, what, exc):
        """Raise one OutputError: what failed, and what is on disk (listed in the .pvd, readable)."""
        if self._listed < len(self.entries):
            try:                  # list what was written, if the disk still takes the small .pvd
                self.flush()
            except OutputError:
                pass
        self._closed = True
        cause = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc).splitlines()[0]
        listed = (f"{self._listed} frame{'s' if self._listed != 1 else ''} written before, listed in {self.path}"
                  if self._listed else f"no frame listed in {self.path}")
        raise OutputError(f"{self.directory}: {what}: {cause}; {listed} (readable)") from exc

    def flush(self):
        """Rewrite the ``.pvd`` collection now (atomically)."""
        try:
            _atomic_write_text(self.path, _pvd_text(self.entries))
        except OSError as exc:
            raise OutputError(f"{self.path}: cannot write the collection file ({exc.strerror or exc}); "
                              f"{self._listed} frames listed in it before (readable)") from exc
        self._listed = len(self.entries)
        self._last_flush = _time.monotonic()

    def close(self):
        """Write the final ``.pvd`` collection; further writes raise."""
        if self._closed:
            return
        self._closed = True
        try:
            self.flush()
        except OutputError as exc:
            self._fail("writing the collection file at the end failed", exc.__cause__ or exc)

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.close()
        else:             # the error in flight names the failure: do not raise a second one
            try:
                self.close()
            except OutputError:
                pass
        return False

    def __repr__(self):
        return f"TimeSeriesWriter({str(self.path)!r}, frames={self.frames})"


# ---------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------


def read_pvd(path):
    """Read a ParaView collection file.

    Parameters
    ----------
    path : str or Path
        The ``.pvd`` file.

    Returns
    -------
    list of (float, Path)
        Time and frame file (resolved against the ``.pvd`` directory) of each
        data set, sorted by time (stable for equal times).

    Raises
    ------
    OutputError
        If the file is missing or is not a VTK collection.
    """
    path = Path(path)
    if not path.is_file():
        raise OutputError(f"{path}: no such .pvd file")
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise OutputError(f"{path}: not a valid .pvd file ({exc})") from exc
    coll = root.find("Collection")
    if root.tag != "VTKFile" or root.get("type") != "Collection" or coll is None:
        raise OutputError(f"{path}: not a VTK collection (.pvd) file")
    out = []
    for i, ds in enumerate(coll.iter("DataSet")):
        f = ds.get("file")
        if f is None:
            raise OutputError(f"{path}: DataSet {i} has no 'file' attribute")
        try:
            t = float(ds.get("timestep", i))
        except ValueError:
            raise OutputError(
                f"{path}: DataSet {i} has a bad timestep {ds.get('timestep')!r}"
            ) from None
        out.append((t, path.parent / f))
    out.sort(key=lambda e: e[0])
    return out


def read_frame(path):
    """Read one frame file (``.vtu``) into a :class:`meshio.Mesh`.

    Raises
    ------
    OutputError
        If the file is missing or unreadable.
    """
    path = Path(path)
    if not path.is_file():
        raise OutputError(f"{path}: no such frame file")
    try:
        return meshio.read(path)
    except Exception as exc:
        empty = _read_empty_vtu(path)
        if empty is not None:
            return empty
        raise OutputError(f"{path}: cannot read frame ({exc})") from exc


def _read_empty_vtu(path):
    """A frame with no points (which meshio cannot read), else None."""
    try:
        if path.stat().st_size > 1 << 16:
            return None
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError):
        return None
    pieces = root.findall("./UnstructuredGrid/Piece")
    if not pieces or any(p.get("NumberOfPoints") != "0" for p in pieces):
        return None
    field_data = {}
    for da in root.findall("./UnstructuredGrid/FieldData/DataArray"):
        dtype = np.float64 if da.get("type", "").startswith("Float") else np.int64
        field_data[da.get("Name")] = np.array((da.text or "").split(), dtype=dtype)
    return meshio.Mesh(np.zeros((0, 3)), [], field_data=field_data)
