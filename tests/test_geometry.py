import json

import numpy as np
import pytest

from tognet.geometry import (
    Camera,
    CameraIntrinsics,
    DepthImageError,
    Grasp,
    invert_pose,
    make_pose,
    mat_to_quat,
    quat_to_mat,
    rot_x,
    rot_z,
    validate_depth,
)


def test_quaternion_round_trip():
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        q = q if q[0] >= 0 else -q
        np.testing.assert_allclose(mat_to_quat(quat_to_mat(q)), q, atol=1e-12)


def test_pose_inverse():
    pose = make_pose(rot_z(0.3) @ rot_x(0.2), [0.1, -0.2, 0.5])
    np.testing.assert_allclose(pose @ invert_pose(pose), np.eye(4), atol=1e-12)


def test_camera_project_deproject_round_trip():
    cam = Camera.looking_down(CameraIntrinsics.kinect2(), [0.0, 0.0, 1.0], yaw=0.4)
    pts = np.array([[0.05, 0.1, 0.0], [-0.2, 0.1, 0.05]])
    uv, z = cam.project(pts)
    np.testing.assert_allclose(z, 1.0 - pts[:, 2])
    back = cam.deproject_pixels(uv[:, 0], uv[:, 1], z)
    np.testing.assert_allclose(back, pts, atol=1e-12)


def test_camera_looking_down_sees_table_centre_at_principal_point():
    k = CameraIntrinsics.kinect2()
    cam = Camera.looking_down(k, [0.3, 0.1, 1.2])
    uv, z = cam.project([[0.3, 0.1, 0.0]])
    np.testing.assert_allclose(uv[0], [k.cx, k.cy])
    assert z[0] == pytest.approx(1.2)
    depth = np.full(k.shape, 1.2)
    pts = cam.deproject(depth)
    np.testing.assert_allclose(pts[..., 2], 0.0, atol=1e-12)


def test_camera_json_round_trip(tmp_path):
    cam = Camera.looking_down(CameraIntrinsics.kinect2(), [0.0, 0.0, 1.0], yaw=0.1)
    loaded = Camera.load(cam.save(tmp_path / "cam.json"))
    np.testing.assert_allclose(loaded.pose, cam.pose)
    assert loaded.intrinsics == cam.intrinsics
    (tmp_path / "broken.json").write_text('{"intrinsics": {"width": 5}}')
    with pytest.raises(ValueError, match="malformed"):
        Camera.load(tmp_path / "broken.json")


def test_grasp_wraps_and_rejects_bad_values():
    g = Grasp.from_array([0.0, 0.0, 0.1, -np.pi / 2])
    assert g.phi == pytest.approx(1.5 * np.pi)
    with pytest.raises(ValueError, match="4 finite numbers"):
        Grasp.from_array([0.0, np.nan, 0.0, 0.0])


def test_validate_depth_cases():
    k = CameraIntrinsics(width=8, height=6, fx=5, fy=5, cx=3.5, cy=2.5)
    img = np.full((6, 8), 0.8)
    img[0, 0] = 0.0
    img[1, 1] = np.nan
    out = validate_depth(img, k)
    assert out.dtype == np.float32 and np.isnan(out[0, 0]) and np.isnan(out[1, 1])
    with pytest.raises(DepthImageError, match="does not match"):
        validate_depth(np.full((8, 6), 0.8), k)
    with pytest.raises(DepthImageError, match="millimetres"):
        validate_depth(np.full((6, 8), 800.0), k)
    with pytest.raises(DepthImageError, match="no valid pixels"):
        validate_depth(np.zeros((6, 8)), k)
    with pytest.raises(DepthImageError, match="2-D"):
        validate_depth(np.zeros((2, 6, 8)), k)


def test_one_camera_file_serves_intrinsics_and_pose_and_the_older_layout_still_loads(tmp_path):
    from tognet.planning.camera import load_camera_pose, load_intrinsics

    cam = Camera.looking_down(CameraIntrinsics.kinect2(), [0.0, 0.0, 1.0], yaw=0.1)
    path = cam.save(tmp_path / "cam.json")
    assert load_intrinsics(path) == cam.intrinsics
    np.testing.assert_allclose(load_camera_pose(path), cam.pose)
    k = cam.intrinsics
    old = {"intrinsics": {"width": k.width, "height": k.height, "fx": k.fx, "fy": k.fy, "cx": k.cx,
                          "cy": k.cy}, "pose": cam.pose.tolist()}
    (tmp_path / "old.json").write_text(json.dumps(old))
    loaded = Camera.load(tmp_path / "old.json")
    assert loaded.intrinsics == cam.intrinsics and load_intrinsics(tmp_path / "old.json") == cam.intrinsics
    np.testing.assert_allclose(load_camera_pose(tmp_path / "old.json"), cam.pose)
