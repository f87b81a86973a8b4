"""Antipodal grasp candidates from one depth image, in the manner of Dex-Net 2.0.

1. Edge pixels: the depth gradient (central differences, metres per pixel) exceeds a threshold.
2. Each edge pixel gets a contact point (deprojected at the nearest-to-camera depth of its 3x3
   neighbourhood, i.e. on the object's top rim) and an outward surface normal: the image-plane depth
   gradient (it points from the object towards the farther background), mapped into the world table
   plane through the camera model (so a slightly tilted camera is handled exactly).
3. Pairs of contacts closer than the maximum opening (a k-d tree in the table plane) whose normals
   are antiparallel within the friction cone (half angle atan(mu)) around the line joining them are
   antipodal. The grasp centre is their midpoint, the jaw axis (phi) the world yaw of that line.
4. Grasp height: the highest surface between the contacts (world heights from the depth image) minus
   a sampled offset, never lower than the table plus a finger clearance. Candidates whose fingers would
   land on something higher than the grasp centre are dropped.
5. Distinct candidates: one pair per cell of (centre pixel / separation, jaw-axis angle / bin), cells
   chosen at random, up to ``max_candidates``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from tognet.config import Config, doc
from tognet.geometry import Camera
from tognet.grasping.depth import DepthScene, prepare_depth


@dataclass(frozen=True)
class AntipodalConfig(Config):
    """Thresholds of the depth-image antipodal sampler."""

    friction_coef: float = doc(1.0, "Friction coefficient mu; the friction cone half angle is atan(mu).")
    max_width: float = doc(0.08, "Gripper maximum opening (m): contacts farther apart are rejected.")
    min_width: float = doc(0.005, "Minimum contact distance (m): closer pairs are rejected.")
    depth_grad_thresh: float = doc(
        0.0025, "Depth-gradient magnitude (m per pixel, central differences) above which a pixel is an edge."
    )
    normal_radius: int = doc(
        3, "Half size (pixels) of the Gaussian-weighted window averaging the depth gradient for normals."
    )
    max_edge_pixels: int = doc(1500, "Edge pixels kept (random subset) before pairing, to bound the cost.")
    max_candidates: int = doc(200, "Maximum number of distinct candidates returned.")
    min_pixel_separation: float = doc(
        4.0,
        "Cell size (pixels) of grasp centres for distinctness: at most one candidate per cell and angle bin.",
    )
    angle_bin: float = doc(np.pi / 16, "Angle bin (rad) of the jaw axis (mod pi) for distinctness.")
    min_depth_offset: float = doc(
        0.005, "Smallest sampled distance (m) of the gripper centre below the top surface."
    )
    max_depth_offset: float = doc(
        0.025, "Largest sampled distance (m) of the gripper centre below the top surface."
    )
    table_z: float = doc(0.0, "World z of the table top (m).")
    finger_clearance: float = doc(
        0.01, "The gripper centre never goes lower than table_z + finger_clearance (m)."
    )
    min_object_height: float = doc(
        0.005, "The top surface between the contacts must rise this much (m) above the table."
    )
    collision_check: bool = doc(
        True, "Drop candidates whose fingers land on a surface above the gripper centre."
    )
    finger_offset: float = doc(
        0.01,
        "Distance (m) outside each contact, along the jaw axis, where the finger collision check samples.",
    )
    axis_direction: Literal["random", "canonical"] = doc(
        "random",
        "phi and phi + pi close on the same contacts but hold the tool the other way round: 'random' picks "
        "one at random per candidate; 'canonical' keeps phi in [0, pi).",
    )
    workspace: tuple[float, float, float, float] | None = doc(
        None, "Optional world (x_min, x_max, y_min, y_max) box the grasp centre must lie in."
    )


@dataclass(frozen=True)
class GraspCandidates:
    """Antipodal candidates, N of them (N may be 0).

    Attributes:
        grasps: (N, 4) world grasps (x, y, z, phi), see :mod:`tognet.geometry.grasp`.
        z_depth: (N,) camera-frame depth of the grasp centre (the network's gripper-depth input).
        pixels: (N, 2) pixel (u, v) of the grasp centre.
        widths: (N,) distance (m) between the contacts in the table plane.
        quality: (N,) antipodality score in [0, 1]: 1 when both normals lie on the jaw axis, 0 at the
            friction-cone boundary (min over the two contacts).
        contacts: (N, 2, 3) world contact points on the object's top rim.
    """

    grasps: NDArray[np.float64]
    z_depth: NDArray[np.float64]
    pixels: NDArray[np.float64]
    widths: NDArray[np.float64]
    quality: NDArray[np.float64]
    contacts: NDArray[np.float64]

    def __len__(self) -> int:
        return int(self.grasps.shape[0])

    @classmethod
    def empty(cls) -> GraspCandidates:
        """The explicit empty result."""
        z = np.zeros(0)
        return cls(np.zeros((0, 4)), z, np.zeros((0, 2)), z.copy(), z.copy(), np.zeros((0, 2, 3)))

    def subset(self, index: NDArray[np.integer] | slice) -> GraspCandidates:
        """The candidates at ``index`` (any numpy index)."""
        return GraspCandidates(
            self.grasps[index],
            self.z_depth[index],
            self.pixels[index],
            self.widths[index],
            self.quality[index],
            self.contacts[index],
        )


def grasp_depths(camera: Camera, grasps: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N,) camera-frame depth of the grasp centres (the network's z input)."""
    grasps = np.asarray(grasps, dtype=np.float64).reshape(-1, 4)
    if grasps.shape[0] == 0:
        return np.zeros(0)
    _, z = camera.project(grasps[:, :3])
    return z


def _lookup(image: NDArray[np.float32], u: NDArray, v: NDArray) -> NDArray[np.float32]:
    """Nearest-pixel lookup, clamped to the image."""
    h, w = image.shape
    ui = np.clip(np.rint(u).astype(np.intp), 0, w - 1)
    vi = np.clip(np.rint(v).astype(np.intp), 0, h - 1)
    return image[vi, ui]


def _edge_pixels(filled: NDArray[np.float32], thresh: float) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Rows and columns of pixels whose depth gradient exceeds ``thresh``, and the gradient images."""
    gx = np.zeros_like(filled)
    gy = np.zeros_like(filled)
    gx[:, 1:-1] = (filled[:, 2:] - filled[:, :-2]) * 0.5
    gy[1:-1, :] = (filled[2:, :] - filled[:-2, :]) * 0.5
    mag2 = gx * gx + gy * gy
    rows, cols = np.nonzero(mag2 > thresh * thresh)
    return rows, cols, gx, gy


def _smoothed_normals(
    gx: NDArray[np.float32], gy: NDArray[np.float32], rows: NDArray, cols: NDArray, radius: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit image-plane normals at (rows, cols): Gaussian-weighted mean gradient over a window.

    Per-pixel central differences on an aliased (stair-step) edge point along the pixel grid; the
    window average recovers the edge's true direction (Dex-Net blurs the image for the same reason).
    """
    h, w = gx.shape
    sx = np.zeros(rows.size, dtype=np.float64)
    sy = np.zeros(rows.size, dtype=np.float64)
    sigma2 = max(radius, 1) ** 2 / 2.0
    for dr in range(-radius, radius + 1):
        rr = np.clip(rows + dr, 0, h - 1)
        for dc in range(-radius, radius + 1):
            wgt = np.exp(-(dr * dr + dc * dc) / (2 * sigma2))
            cc = np.clip(cols + dc, 0, w - 1)
            sx += wgt * gx[rr, cc]
            sy += wgt * gy[rr, cc]
    norm = np.maximum(np.hypot(sx, sy), 1e-12)
    return sx / norm, sy / norm


def sample_antipodal(
    depth: NDArray | DepthScene, camera: Camera | None, config: AntipodalConfig, rng: np.random.Generator
) -> GraspCandidates:
    """Sample up to ``config.max_candidates`` distinct antipodal grasps on a depth image.

    ``depth`` is a raw image (validated here: holes NaN or 0 are filled, wrong shape/dtype/units raise
    :class:`tognet.geometry.DepthImageError`) or a :class:`DepthScene` from :func:`prepare_depth`.
    An image without any antipodal pair (an empty table) gives an empty :class:`GraspCandidates`.
    """
    scene = prepare_depth(depth, camera)
    cam = scene.camera
    filled = scene.filled
    h, w = filled.shape

    rows, cols, gx, gy = _edge_pixels(filled, config.depth_grad_thresh)
    # Ignore the outermost image border (no central difference there).
    inner = (rows > 0) & (rows < h - 1) & (cols > 0) & (cols < w - 1)
    rows, cols = rows[inner], cols[inner]
    # Keep the near side of each step: the pixel one step outward (along the gradient) is farther.
    ex, ey = gx[rows, cols], gy[rows, cols]
    gnorm = np.hypot(ex, ey)
    nu, nv = ex / gnorm, ey / gnorm
    ahead = filled[rows + np.rint(nv).astype(np.intp), cols + np.rint(nu).astype(np.intp)]
    near = ahead > filled[rows, cols] + np.float32(0.5 * config.depth_grad_thresh)
    rows, cols = rows[near], cols[near]
    if rows.size < 2:
        return GraspCandidates.empty()
    if rows.size > config.max_edge_pixels:
        keep = rng.choice(rows.size, size=config.max_edge_pixels, replace=False)
        rows, cols = rows[keep], cols[keep]
    nu, nv = _smoothed_normals(gx, gy, rows, cols, config.normal_radius)

    # Contact depth: nearest-to-camera value of the 3x3 neighbourhood (the object's top rim).
    nb = np.stack([filled[rows + dr, cols + dc] for dr in (-1, 0, 1) for dc in (-1, 0, 1)], axis=0)
    d_contact = nb.min(axis=0).astype(np.float64)
    u = cols.astype(np.float64)
    v = rows.astype(np.float64)
    p = cam.deproject_pixels(u, v, d_contact)
    p_n = cam.deproject_pixels(u + nu, v + nv, d_contact)
    n_xy = (p_n - p)[:, :2]
    n_len = np.hypot(n_xy[:, 0], n_xy[:, 1])
    ok = n_len > 1e-9
    if ok.sum() < 2:
        return GraspCandidates.empty()
    p, n_xy, n_len = p[ok], n_xy[ok], n_len[ok]
    u, v = u[ok], v[ok]
    n_xy = (n_xy / n_len[:, None]).astype(np.float32)
    pxy = p[:, :2].astype(np.float32)

    pairs = cKDTree(p[:, :2]).query_pairs(config.max_width, output_type="ndarray")
    if pairs.shape[0] == 0:
        return GraspCandidates.empty()
    i, j = pairs[:, 0], pairs[:, 1]
    dx = pxy[j, 0] - pxy[i, 0]
    dy = pxy[j, 1] - pxy[i, 1]
    dist = np.sqrt(dx * dx + dy * dy)
    inv = 1.0 / np.maximum(dist, np.float32(1e-9))
    # Outward normal at i must point away from j (n_i . axis = -1 ideally), at j away from i (+1).
    ni, nj = n_xy[i], n_xy[j]
    cos_i = -(ni[:, 0] * dx + ni[:, 1] * dy) * inv
    cos_j = (nj[:, 0] * dx + nj[:, 1] * dy) * inv
    cos_cone = np.float32(np.cos(np.arctan(config.friction_coef)))
    good = np.nonzero((cos_i >= cos_cone) & (cos_j >= cos_cone) & (dist >= config.min_width))[0]
    if good.size == 0:
        return GraspCandidates.empty()
    i, j = i[good], j[good]
    dist = dist[good].astype(np.float64)
    axis = np.column_stack([dx[good], dy[good]]).astype(np.float64) / dist[:, None]
    min_cos = np.minimum(cos_i[good], cos_j[good]).astype(np.float64)
    quality = np.clip((min_cos - cos_cone) / max(1.0 - cos_cone, 1e-9), 0.0, 1.0)

    # Distinct cells in (centre pixel, jaw-axis angle mod pi).
    cu = 0.5 * (u[i] + u[j])
    cv = 0.5 * (v[i] + v[j])
    phi_line = np.mod(np.arctan2(axis[:, 1], axis[:, 0]), np.pi)
    sep = max(config.min_pixel_separation, 1e-6)
    n_abin = max(int(np.ceil(np.pi / config.angle_bin)), 1)
    key = (
        np.floor(cu / sep).astype(np.int64) * 100003 + np.floor(cv / sep).astype(np.int64)
    ) * 1009 + np.minimum((phi_line / config.angle_bin).astype(np.int64), n_abin - 1)
    order = rng.permutation(key.size)
    _, first = np.unique(key[order], return_index=True)
    cells = order[first]
    cells = cells[rng.permutation(cells.size)]

    # Evaluate cells in order until enough pass the height / collision checks (vectorised in chunks).
    chosen: list[NDArray] = []
    z_chosen: list[NDArray] = []
    n_have = 0
    chunk = max(2 * config.max_candidates, 64)
    for start in range(0, cells.size, chunk):
        sel = cells[start : start + chunk]
        z, ok = _grasp_heights(scene, p[i[sel]], p[j[sel]], axis[sel], config, rng)
        chosen.append(sel[ok])
        z_chosen.append(z[ok])
        n_have += int(ok.sum())
        if n_have >= config.max_candidates:
            break
    sel = np.concatenate(chosen)[: config.max_candidates]
    z = np.concatenate(z_chosen)[: config.max_candidates]
    if sel.size == 0:
        return GraspCandidates.empty()

    centre = 0.5 * (p[i[sel], :2] + p[j[sel], :2])
    phi = phi_line[sel]
    if config.axis_direction == "random":
        phi = phi + np.pi * (rng.random(sel.size) < 0.5)
    grasps = np.column_stack([centre, z, np.mod(phi, 2 * np.pi)])
    if config.workspace is not None:
        x0, x1, y0, y1 = config.workspace
        inside = (grasps[:, 0] >= x0) & (grasps[:, 0] <= x1) & (grasps[:, 1] >= y0) & (grasps[:, 1] <= y1)
        grasps, sel = grasps[inside], sel[inside]
        if sel.size == 0:
            return GraspCandidates.empty()
    uv, zc = cam.project(grasps[:, :3])
    contacts = np.stack([p[i[sel]], p[j[sel]]], axis=1)
    return GraspCandidates(grasps, zc, uv, dist[sel], quality[sel], contacts)


def _grasp_heights(
    scene: DepthScene,
    pa: NDArray,
    pb: NDArray,
    axis: NDArray,
    config: AntipodalConfig,
    rng: np.random.Generator,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Gripper-centre heights for contact pairs and whether each passes the height/collision checks."""
    cam = scene.camera
    n = pa.shape[0]
    # Highest surface on the segment between the contacts (9 samples, ends included).
    t = np.linspace(0.0, 1.0, 9)
    seg = pa[:, None, :2] + t[None, :, None] * (pb - pa)[:, None, :2]
    z_ref = np.maximum(pa[:, 2], pb[:, 2])
    pts = np.concatenate([seg, np.broadcast_to(z_ref[:, None, None], (n, t.size, 1))], axis=2)
    uv, _ = cam.project(pts.reshape(-1, 3))
    top = _lookup(scene.height, uv[:, 0], uv[:, 1]).reshape(n, t.size).max(axis=1).astype(np.float64)
    offset = rng.uniform(config.min_depth_offset, config.max_depth_offset, size=n)
    floor = config.table_z + config.finger_clearance
    z = np.maximum(top - offset, floor)
    ok = top >= config.table_z + config.min_object_height
    if config.collision_check:
        out_a = pa[:, :2] - axis * config.finger_offset
        out_b = pb[:, :2] + axis * config.finger_offset
        fingers = np.concatenate([out_a, out_b], axis=0)
        fz = np.concatenate([z, z])[:, None]
        uvf, _ = cam.project(np.concatenate([fingers, fz], axis=1))
        hf = _lookup(scene.height, uvf[:, 0], uvf[:, 1]).astype(np.float64)
        ok &= (hf[:n] < z) & (hf[n:] < z)
    return z, ok
