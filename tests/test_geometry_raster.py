"""Mesh depth by rasterised exact ray-triangle intersection, against brute-force ray casting."""

import numpy as np
import pytest
import trimesh

from tognet.geometry import Camera, CameraIntrinsics
from tognet.geometry.raster import mesh_depth
from tognet.geometry.transforms import make_pose, rot_x, rot_y, rot_z


def brute_force(camera: Camera, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Every pixel's ray against every triangle (Moller-Trumbore, two-sided); inf where nothing is hit."""
    k = camera.intrinsics
    dirs = camera.pixel_directions().reshape(-1, 3) @ camera.pose[:3, :3].T  # camera z of each = 1
    origin = camera.position
    best = np.full(len(dirs), np.inf)
    for a, b, c in vertices[faces]:
        e1, e2 = b - a, c - a
        p = np.cross(dirs, e2)
        det = p @ e1
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            s = origin - a
            u = (p @ s) * inv
            q = np.cross(s, e1)
            v = (dirs @ q) * inv
            t = (q @ e2) * inv
        hit = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
        best = np.where(hit & (t < best), t, best)
    return best.reshape(k.height, k.width)


def camera(position=(0.02, -0.01, 0.5), tilt=(0.05, -0.04, 0.3)) -> Camera:
    intr = CameraIntrinsics(width=96, height=80, fx=70.0, fy=72.0, cx=47.3, cy=39.6)
    down = Camera.looking_down(intr, position).pose[:3, :3]
    return Camera(intr, make_pose(rot_z(tilt[2]) @ rot_y(tilt[1]) @ rot_x(tilt[0]) @ down, position))


def cast(cam: Camera, vertices: np.ndarray, faces: np.ndarray, depth: np.ndarray) -> bool:
    """mesh_depth with the camera's pose and intrinsics."""
    k = cam.intrinsics
    intr = (k.fx, k.fy, k.cx, k.cy, k.width, k.height)
    return mesh_depth(cam.pose[:3, :3], cam.position, intr, vertices, np.asarray(faces), depth)


@pytest.mark.parametrize(
    "mesh",
    [
        trimesh.creation.box(extents=(0.2, 0.05, 0.04)),
        trimesh.creation.cylinder(radius=0.03, height=0.25, sections=24),  # fans of sliver triangles
        trimesh.creation.icosphere(subdivisions=2, radius=0.06),
    ],
    ids=["box", "cylinder", "sphere"],
)
def test_mesh_depth_equals_brute_force_ray_casting(mesh):
    rng = np.random.default_rng(4)
    cam = camera()
    for _ in range(3):
        rot = rot_z(rng.uniform(0, 6.3)) @ rot_y(rng.uniform(0, 6.3)) @ rot_x(rng.uniform(0, 6.3))
        verts = mesh.vertices @ rot.T + np.array([rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), 0.05])
        k = cam.intrinsics
        got = np.full(k.width * k.height, np.inf)
        assert cast(cam, verts, np.asarray(mesh.faces), got)
        want = brute_force(cam, verts, np.asarray(mesh.faces))
        got = got.reshape(want.shape)
        assert np.isfinite(want).sum() > 100  # the mesh is in view
        np.testing.assert_array_equal(np.isfinite(got), np.isfinite(want))
        np.testing.assert_allclose(got[np.isfinite(got)], want[np.isfinite(want)], rtol=1e-12)


def test_mesh_partly_outside_the_image_and_depth_only_lowered():
    cam = camera(tilt=(0.0, 0.0, 0.0))
    mesh = trimesh.creation.box(extents=(0.9, 0.1, 0.05))  # much wider than the view
    k = cam.intrinsics
    prior = np.full(k.width * k.height, 0.47)  # something nearer than the box's top everywhere but a strip
    prior[: k.width * 10] = np.inf
    got = prior.copy()
    assert cast(cam, mesh.vertices, np.asarray(mesh.faces), got)
    want = np.minimum(prior, brute_force(cam, mesh.vertices, np.asarray(mesh.faces)).ravel())
    np.testing.assert_allclose(got, want, rtol=1e-12)
    assert np.all(got <= prior)


def test_vertex_behind_the_camera_is_refused_without_touching_the_depth():
    cam = camera(position=(0.0, 0.0, 0.03))
    mesh = trimesh.creation.box(extents=(0.1, 0.1, 0.1))  # reaches 5 cm up: above the camera
    k = cam.intrinsics
    depth = np.full(k.width * k.height, np.inf)
    assert not cast(cam, mesh.vertices, np.asarray(mesh.faces), depth)
    assert np.all(np.isinf(depth))
