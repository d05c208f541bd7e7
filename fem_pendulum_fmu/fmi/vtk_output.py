"""ParaView time series of the bodies' nodal fields: one .vtu file per body and frame, one .pvd index.

Plain XML VTK (UnstructuredGrid, inline base64 binary), written with the standard library and
numpy only, so the FMU needs no extra package at run time. The .pvd index is rewritten after every
frame through a temporary file and `os.replace`, so a reader never sees it half written; times are
in seconds.
"""

from __future__ import annotations

import base64
import math
import os
from collections.abc import Sequence
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from ..physics.protocol import BodyField

INDEX_NAME = "pendulum.pvd"
VTK_TRIANGLE = 5
TIME_TOL = 1e-9  # s: communication points this close to a frame's due time count as due


def _data_array(name: str, values: np.ndarray, components: int = 1) -> str:
    """A binary (base64, UInt32 byte-count header) DataArray element."""
    types = {np.dtype(np.float64): "Float64", np.dtype(np.int64): "Int64", np.dtype(np.uint8): "UInt8"}
    data = np.ascontiguousarray(values).astype(values.dtype.newbyteorder("<"), copy=False)
    raw = data.tobytes()
    payload = base64.b64encode(np.uint32(len(raw)).astype("<u4").tobytes() + raw).decode("ascii")
    return (
        f'<DataArray type="{types[values.dtype]}" Name={quoteattr(name)} NumberOfComponents="{components}" '
        f'format="binary">{payload}</DataArray>'
    )


def _xyz(planar: np.ndarray) -> np.ndarray:
    """(N, 2) -> (N, 3) with z = 0 (VTK points and vectors are 3D)."""
    out = np.zeros((len(planar), 3))
    out[:, :2] = planar
    return out


def vtu_text(body: BodyField) -> str:
    """The .vtu file of one body: reference points, triangles, and the nodal displacement, velocity
    and von Mises stress as point data (the deformed shape is points + displacement)."""
    cells = np.asarray(body.cells, dtype=np.int64)
    n_points, n_cells = len(body.points), len(cells)
    offsets = 3 * np.arange(1, n_cells + 1, dtype=np.int64)
    types = np.full(n_cells, VTK_TRIANGLE, dtype=np.uint8)
    point_data = "".join(
        [
            _data_array("displacement", _xyz(body.displacement), 3),
            _data_array("velocity", _xyz(body.velocity), 3),
            _data_array("von_mises", np.asarray(body.von_mises, dtype=np.float64)),
        ]
    )
    return (
        '<?xml version="1.0"?>\n'
        '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt32">\n'
        f'<UnstructuredGrid><Piece NumberOfPoints="{n_points}" NumberOfCells="{n_cells}">\n'
        f'<PointData Vectors="displacement" Scalars="von_mises">{point_data}</PointData>\n'
        f"<Points>{_data_array('points', _xyz(body.points), 3)}</Points>\n"
        f"<Cells>{_data_array('connectivity', cells.ravel())}{_data_array('offsets', offsets)}"
        f"{_data_array('types', types)}</Cells>\n"
        "</Piece></UnstructuredGrid>\n</VTKFile>\n"
    )


class VtkSeries:
    """Frames of the bodies written into `folder` at times at least `interval` apart.

    Raises OSError at construction when the folder cannot be created or written (the caller turns
    that into an error message), ValueError for an interval that is not a positive number."""

    def __init__(self, folder: str | os.PathLike, interval: float):
        if not (math.isfinite(interval) and interval > 0.0):
            raise ValueError(f"output.vtk_interval = {interval!r} is not allowed: it must be a number > 0 (s)")
        self.folder = Path(folder)
        self.interval = float(interval)
        self.entries: list[tuple[float, int, str]] = []  # (time, part, file name)
        self.frames = 0
        self.last_time = -math.inf
        self.folder.mkdir(parents=True, exist_ok=True)
        self._write_index()  # fails here, at initialisation, if the folder is not writable

    @property
    def index(self) -> Path:
        return self.folder / INDEX_NAME

    def due(self, time: float) -> bool:
        """Whether a communication point at `time` gets a frame."""
        return time >= self.last_time + self.interval - TIME_TOL * max(1.0, abs(time))

    def write(self, time: float, bodies: Sequence[BodyField]) -> None:
        """Write one frame (a .vtu per body) and the updated index."""
        for part, body in enumerate(bodies):
            name = f"{body.name}_{self.frames:06d}.vtu"
            (self.folder / name).write_text(vtu_text(body))
            self.entries.append((float(time), part, name))
        self.frames += 1
        self.last_time = float(time)
        self._write_index()

    def _write_index(self) -> None:
        rows = "".join(
            f'  <DataSet timestep="{t!r}" group="" part="{part}" file={quoteattr(name)}/>\n'
            for t, part, name in self.entries
        )
        text = (
            '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
            f"<Collection>\n{rows}</Collection>\n</VTKFile>\n"
        )
        tmp = self.folder / f".{INDEX_NAME}.tmp"
        tmp.write_text(text)
        os.replace(tmp, self.index)
