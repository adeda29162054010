"""CAD-like meshes, as a tessellator writes them: flat faces cut into long sliver fans,
cylinders of thousands of sections, millimetre units, far from the origin.

For the atlas tests and ``bench/bench_unwrap.py``. Each function returns ``(vertices
(n, 3) float64, faces (m, 3) int64)``, outward-facing, watertight.
"""

from __future__ import annotations

import numpy as np


def _ring(n: int, radius: float, phase: float = 0.0) -> np.ndarray:
    a = phase + 2 * np.pi * np.arange(n) / n
    return radius * np.stack([np.cos(a), np.sin(a)], axis=1)


def _extrude(outline_2d: np.ndarray, top: np.ndarray, holes: list[np.ndarray], height: float):
    """Prism of a 2D region: ``outline_2d`` (n, 2) points, ``top`` (t, 3) triangles of the
    region (indices into the points, counter-clockwise), ``holes`` and the outer boundary
    as index loops (the outer one first, counter-clockwise; holes clockwise)."""
    n = len(outline_2d)
    vertices = np.concatenate([np.column_stack([outline_2d, np.zeros(n)]), np.column_stack([outline_2d, np.full(n, height)])])
    faces = [top + n, top[:, ::-1]]
    for loop in holes:
        a, b = loop, np.roll(loop, -1)
        faces.append(np.stack([a, b, b + n], axis=1))
        faces.append(np.stack([a, b + n, a + n], axis=1))
    return vertices, np.concatenate(faces).astype(np.int64)


def holed_plate(cells: tuple[int, int] = (4, 3), cell: float = 30.0, radius: float = 9.0, segments: int = 256,
                thickness: float = 6.0, offset: float = 1e5):
    """A plate of ``cells`` square cells, each with a round hole of ``segments`` sides.

    Each cell's face is four fans, one from each corner of the square to a quarter of the
    hole (slivers of up to ``segments / 4`` triangles). Units: mm; moved by ``offset``
    along every axis.
    """
    if segments % 4:
        raise ValueError("segments must be a multiple of 4")
    nx, ny = cells
    gx, gy = np.meshgrid(np.arange(nx + 1) * cell, np.arange(ny + 1) * cell, indexing="xy")
    corners = np.column_stack([gx.ravel(), gy.ravel()])  # (nx+1)(ny+1) grid points
    cid = np.arange(len(corners)).reshape(ny + 1, nx + 1)
    points, tris, loops = [corners], [], []
    count = len(corners)
    q = segments // 4
    for j in range(ny):
        for i in range(nx):
            centre = np.array([(i + 0.5) * cell, (j + 0.5) * cell])
            ring = centre + _ring(segments, radius)  # angle 0 at +x
            idx = count + np.arange(segments)
            points.append(ring)
            count += segments
            loops.append(idx[::-1])  # a hole: clockwise
            quad = [cid[j + 1, i + 1], cid[j + 1, i], cid[j, i], cid[j, i + 1]]  # corners at 45, 135, 225, 315 degrees
            for k in range(4):
                arc = idx[(np.arange(k * q, (k + 1) * q + 1)) % segments]
                tris += [(quad[k], arc[t], arc[t + 1]) for t in range(q)]  # a fan from the corner
                tris.append((quad[k], arc[-1], quad[(k + 1) % 4]))  # the corner, the arc's end, the next corner
    outline = np.concatenate(points)
    boundary = np.concatenate([cid[0, :-1], cid[:-1, -1], cid[-1, :0:-1], cid[:0:-1, 0]])  # counter-clockwise
    top = _fix_winding(outline, np.array(tris, dtype=np.int64))
    v, f = _extrude(outline, top, [boundary, *loops], thickness)
    return v + offset, f


def _fix_winding(points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Triangles of a 2D region, each turned counter-clockwise."""
    p = points[tris]
    cross = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0])
    return np.where((cross < 0)[:, None], tris[:, ::-1], tris)


def fan_cylinder(sections: int = 4000, radius: float = 40.0, height: float = 120.0, offset: float = 1e6):
    """A cylinder of ``sections`` sides whose caps are fans from one rim vertex (slivers
    of up to ``sections - 2`` triangles), sides as long thin quads. mm; moved by ``offset``."""
    ring = _ring(sections, radius)
    top = np.stack([np.zeros(sections - 2, np.int64), np.arange(1, sections - 1), np.arange(2, sections)], axis=1)
    v, f = _extrude(ring, top, [np.arange(sections)], height)
    return v + offset, f


def meshes() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The CAD-like meshes of the atlas benchmark, by name."""
    return {
        "plate-12-holes@1e5": holed_plate(),
        "plate-2-holes-1024@1e3": holed_plate(cells=(2, 1), segments=1024, offset=1e3),
        "cylinder-4000@1e6": fan_cylinder(),
    }
