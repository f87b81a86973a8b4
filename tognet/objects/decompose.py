"""Convex decomposition (CoACD) with a vertex cap per piece and a convex-hull fallback.

MuJoCo collides convex meshes with their hulls; fewer hull vertices make contacts cheaper, so every
piece is capped at ``max_vertices`` (CoACD's own decimation, then farthest-point thinning if needed).
If CoACD fails or returns nothing usable, the mesh's convex hull (capped) is the single piece.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import trimesh

from tognet.config import Config, doc

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class DecomposeConfig(Config):
    """CoACD settings (https://github.com/SarahWeiii/CoACD)."""

    threshold: float = doc(0.08, "Concavity threshold: lower cuts more pieces (CoACD's -t).")
    max_pieces: int = doc(12, "At most this many convex pieces (CoACD merges beyond it); -1 = no limit.")
    max_vertices: int = doc(48, "At most this many vertices per convex piece.")
    preprocess_resolution: int = doc(30, "Voxel resolution of CoACD's manifold pre-processing.")
    resolution: int = doc(1000, "CoACD's sampling resolution for the concavity metric.")
    mcts_iterations: int = doc(60, "CoACD's tree-search iterations per cut (fewer = faster, coarser).")
    max_input_faces: int = doc(6000, "Meshes with more faces are simplified (vertex clustering) first.")


def _log_level_quiet() -> None:
    import coacd

    coacd.set_log_level("error")


def thin_vertices(points: np.ndarray, count: int) -> np.ndarray:
    """``count`` of ``points`` by farthest-point sampling (deterministic: starts at the lexicographic max)."""
    points = np.asarray(points, dtype=np.float64)
    if len(points) <= count:
        return points
    start = int(np.lexsort(points.T[::-1])[-1])
    chosen = [start]
    dist = np.linalg.norm(points - points[start], axis=1)
    for _ in range(count - 1):
        nxt = int(np.argmax(dist))
        chosen.append(nxt)
        dist = np.minimum(dist, np.linalg.norm(points - points[nxt], axis=1))
    return points[np.sort(chosen)]


def capped_hull(points: np.ndarray, max_vertices: int) -> trimesh.Trimesh | None:
    """Convex hull of ``points`` with at most ``max_vertices`` vertices; None if it has no volume."""
    try:
        hull = trimesh.convex.convex_hull(np.asarray(points, dtype=np.float64))
        if len(hull.vertices) > max_vertices:
            hull = trimesh.convex.convex_hull(thin_vertices(hull.vertices, max_vertices))
    except Exception:  # qhull raises on flat / degenerate input
        return None
    if not hull.is_volume or hull.volume <= 1e-12:
        return None
    return hull


def decompose(
    mesh: trimesh.Trimesh, config: DecomposeConfig | None = None, seed: int = 0
) -> list[trimesh.Trimesh]:
    """Convex pieces of ``mesh`` (each a closed convex trimesh with at most ``max_vertices`` vertices)."""
    import coacd

    config = config or DecomposeConfig()
    _log_level_quiet()
    source = mesh
    if len(mesh.faces) > config.max_input_faces:
        pitch = float(np.max(mesh.extents)) / 60.0
        simplified = _cluster_simplify(mesh, pitch)
        if simplified is not None:
            source = simplified
    pieces: list[trimesh.Trimesh] = []
    try:
        parts = coacd.run_coacd(
            coacd.Mesh(np.asarray(source.vertices, np.float64), np.asarray(source.faces, np.int32)),
            threshold=config.threshold,
            max_convex_hull=config.max_pieces,
            preprocess_resolution=config.preprocess_resolution,
            resolution=config.resolution,
            mcts_iterations=config.mcts_iterations,
            decimate=True,
            max_ch_vertex=config.max_vertices,
            seed=int(seed) % (2**31),
        )
        for vertices, _faces in parts:
            hull = capped_hull(vertices, config.max_vertices)
            if hull is not None:
                pieces.append(hull)
    except Exception as exc:  # CoACD raises plain RuntimeErrors on meshes it cannot handle
        log.warning("CoACD failed (%s); using the convex hull", exc)
        pieces = []
    if not pieces:
        hull = capped_hull(np.asarray(mesh.vertices), config.max_vertices)
        if hull is not None:
            pieces = [hull]
    # A stable order: by centroid, so equal input gives equal files.
    pieces.sort(key=lambda p: tuple(np.round(p.vertices.mean(axis=0), 6)))
    return pieces


def _cluster_simplify(mesh: trimesh.Trimesh, pitch: float) -> trimesh.Trimesh | None:
    """Vertex clustering on a grid of ``pitch``: merge vertices per cell, drop collapsed faces."""
    keys = np.floor(mesh.vertices / pitch).astype(np.int64)
    _, inverse = np.unique(keys, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    count = int(inverse.max()) + 1
    sums = np.zeros((count, 3))
    np.add.at(sums, inverse, mesh.vertices)
    weights = np.bincount(inverse, minlength=count)[:, None]
    faces = inverse[mesh.faces]
    keep = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    if keep.sum() < 4:
        return None
    out = trimesh.Trimesh(sums / weights, faces[keep], process=True)
    return out
