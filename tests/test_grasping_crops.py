"""Grasp-aligned metric crops: rotation equivariance, camera invariance, values, holes, errors."""

import numpy as np
import pytest
from scipy import ndimage

from tognet.geometry import Camera, CameraIntrinsics, rot_z
from tognet.grasping import (
    AntipodalConfig,
    CropConfig,
    center_crops,
    crop_grid,
    extract_crops,
    grasp_depths,
    prepare_depth,
    sample_antipodal,
)
from tognet.grasping.synthetic import Box, render_depth, rotate_shapes, t_shape, tilted_camera

TILT = (np.pi / 70, -np.pi / 80)


def _rotate_grasps(grasps: np.ndarray, theta: float, pivot: np.ndarray) -> np.ndarray:
    out = grasps.copy()
    out[:, :2] = (grasps[:, :2] - pivot) @ rot_z(theta)[:2, :2].T + pivot
    out[:, 3] = np.mod(grasps[:, 3] + theta, 2 * np.pi)
    return out


# The default extent and the finer 6 mm pixels of a 0.384 m crop (the thresholds below were set there).
EXTENTS = [CropConfig().extent, 0.384]


@pytest.mark.parametrize("extent", EXTENTS)
@pytest.mark.parametrize("theta", [0.4, np.pi / 2, 2.5, -2.0])
def test_crop_of_rotated_object_equals_crop_with_rotated_grasp(theta, extent):
    camera = tilted_camera(0.9, x=0.02, y=-0.03, tilt=TILT)
    pivot = np.array([0.03, -0.02])
    shapes = t_shape(0.03, -0.02, 0.3)
    d0 = render_depth(camera, shapes)
    grasps = sample_antipodal(d0, camera, AntipodalConfig(), np.random.default_rng(0)).grasps[:20]
    assert len(grasps) == 20
    config = CropConfig(extent=extent)
    crops0 = extract_crops(d0, camera, grasps, config)
    d1 = render_depth(camera, rotate_shapes(shapes, theta, pivot))
    crops1 = extract_crops(d1, camera, _rotate_grasps(grasps, theta, pivot), config)
    diff = np.abs(crops1 - crops0)
    # Equal up to interpolation at the depth steps (a step is 3 cm, a mismatch there is rare).
    assert diff.mean() < 3e-4
    assert np.percentile(diff, 95) < 1e-3
    assert np.percentile(diff, 99.5) < 0.03
    # Control: without rotating the grasp the crops differ a lot (the test can fail). The means are over
    # the crop, so they are shares of its area: the T (a fixed area, wholly inside) covers 7.6 % of a
    # 0.384 m crop and 3.1 % of a 0.6 m one, so both means fall as 1 / extent**2 (their ratio does not
    # change). The absolute floor, set at 0.384 m, is scaled by that area ratio (not by the pixel size).
    control = np.abs(extract_crops(d1, camera, grasps, config) - crops0)
    assert control.mean() > 10 * diff.mean() and control.mean() > 1e-3 * (0.384 / extent) ** 2


def test_crops_are_metric_invariant_to_camera_height_and_focal_length():
    shapes = t_shape(0.0, 0.01, 1.1)
    grasps = np.array([[0.0, 0.01, 0.02, 1.1 + np.pi / 2], [-0.05, -0.01, 0.015, 0.3]])
    low = tilted_camera(0.8, tilt=(0.01, 0.0))
    high_k = CameraIntrinsics(512, 424, 372.0, 370.0, 250.0, 215.0)
    high = tilted_camera(1.0, tilt=(0.0, -0.01), intrinsics=high_k)
    c_low = extract_crops(render_depth(low, shapes), low, grasps, CropConfig())
    c_high = extract_crops(render_depth(high, shapes), high, grasps, CropConfig())
    diff = np.abs(c_low - c_high)
    assert np.median(diff) < 1e-4
    assert diff.mean() < 2e-3  # perspective moves the depth steps by a pixel or so


def test_crop_values_are_distance_below_the_gripper_centre():
    camera = Camera.looking_down(CameraIntrinsics.kinect2(), [0.0, 0.0, 0.9])
    box = Box.on_table(0.0, 0.0, (0.2, 0.03, 0.04), 0.0)
    depth = render_depth(camera, [box])
    z = 0.025
    grasps = np.array([[0.0, 0.0, z, np.pi / 2], [0.0, 0.0, z, 0.0]])
    config = CropConfig()
    crops = extract_crops(depth, camera, grasps, config)
    assert crops.shape == (2, 64, 64) and crops.dtype == np.float32
    # Straight-down camera: depth - gripper depth; on the box top that is z - 0.04, on the table z.
    # Which crop pixels fall on the box top depends on the pixel size, so they are picked by their world
    # points (5 mm, two depth-image pixels, clear of the box's edges).
    xy = np.abs(crop_grid(grasps, config)[..., :2])
    on_top = (xy[..., 0] < 0.1 - 0.005) & (xy[..., 1] < 0.015 - 0.005)
    assert on_top[:, 28:36, 28:36].sum(axis=(1, 2)).min() >= 2 * 8  # at least 2 px across the 3 cm
    np.testing.assert_allclose(crops[on_top], z - 0.04, atol=1e-5)
    np.testing.assert_allclose(crops[:, 0, 0], z, atol=1e-5)
    z_depth = grasp_depths(camera, grasps)
    np.testing.assert_allclose(z_depth, 0.9 - z)
    # phi = pi/2: the jaw axis (crop columns) runs across the 3 cm box width, so the box's 0.2 m length
    # runs down the rows; phi = 0: along the columns.
    res = config.resolution
    on_box = crops < z - 0.02
    assert abs(on_box[0].sum(axis=0).max() * res - 0.2) < 2 * res
    assert abs(on_box[0].sum(axis=1).max() * res - 0.03) < 2 * res
    assert abs(on_box[1].sum(axis=1).max() * res - 0.2) < 2 * res
    # Row direction: for phi = 0 rows go to world -y, like the image of a yaw-0 camera.
    grid = crop_grid(grasps[1:], config)
    assert grid[0, -1, 32, 1] < grid[0, 0, 32, 1] and grid[0, 32, -1, 0] > grid[0, 32, 0, 0]


@pytest.mark.parametrize("config", [CropConfig(), CropConfig(size=48, extent=0.45)], ids=["default", "48px"])
def test_center_crops_and_metric_extent(config):
    crops = np.random.default_rng(0).random((3, 64, 64)).astype(np.float32)
    centre = center_crops(crops)
    assert centre.shape == (3, 32, 32)
    np.testing.assert_array_equal(centre, crops[:, 16:48, 16:48])
    assert config.resolution == pytest.approx(config.extent / config.size)
    # The grasp-quality stream's centre crop sees the whole open gripper.
    assert config.center_size * config.resolution > AntipodalConfig().max_width
    grid = crop_grid(np.zeros((1, 4)), config)
    assert grid.shape == (1, config.size, config.size, 3)
    span = grid[0, 0, -1, 0] - grid[0, 0, 0, 0]
    assert span == pytest.approx(config.extent * (config.size - 1) / config.size)
    np.testing.assert_allclose(np.diff(grid[0, 0, :, 0]), config.resolution)
    with pytest.raises(ValueError, match="shape"):
        center_crops(crops[:, :20, :20])


def test_holes_are_filled_and_outside_reads_table():
    camera = tilted_camera(0.9, tilt=TILT)
    depth = render_depth(camera, [Box.on_table(0.0, 0.0, (0.15, 0.03, 0.03), 0.2)])
    clean = extract_crops(depth, camera, np.array([[0.0, 0.0, 0.02, 1.77]]), CropConfig())
    holey = depth.copy()
    rng = np.random.default_rng(0)
    holey[rng.random(depth.shape) < 0.03] = np.nan
    holey[rng.random(depth.shape) < 0.03] = 0.0
    crops = extract_crops(holey, camera, np.array([[0.0, 0.0, 0.02, 1.77]]), CropConfig())
    assert np.all(np.isfinite(crops))
    assert np.mean(np.abs(crops - clean) > 0.005) < 0.02
    # A grasp near the image border: the grid points beyond it read the table height (0).
    far = extract_crops(depth, camera, np.array([[0.6, 0.0, 0.02, 0.0]]), CropConfig())
    np.testing.assert_allclose(far[0, :, -1], 0.02, atol=1e-6)


def test_empty_and_bad_grasps():
    camera = tilted_camera(0.9)
    scene = prepare_depth(render_depth(camera, []), camera)
    assert extract_crops(scene, None, np.zeros((0, 4)), CropConfig()).shape == (0, 64, 64)
    assert grasp_depths(camera, np.zeros((0, 4))).shape == (0,)
    with pytest.raises(ValueError, match=r"\(N, 4\)"):
        extract_crops(scene, None, np.zeros((3, 3)), CropConfig())
    with pytest.raises(ValueError, match="NaN"):
        extract_crops(scene, None, np.full((1, 4), np.nan), CropConfig())


def test_far_surfaces_are_clipped():
    # A camera wide enough to see past the table: with no table plane the floor is 0.75 m down.
    camera = tilted_camera(0.9)
    depth = render_depth(camera, [Box.on_table(0.0, 0.0, (0.2, 0.03, 0.04), 0.0)], table_z=None)
    depth[np.isnan(depth)] = 0.9 + 0.75  # the floor
    grasp = np.array([[0.0, 0.0, 0.02, 0.0]])
    clipped = extract_crops(depth, camera, grasp, CropConfig())
    raw = extract_crops(depth, camera, grasp, CropConfig(max_value=None))
    assert raw.max() > 0.7 and clipped.max() == pytest.approx(0.3)
    np.testing.assert_array_equal(clipped[raw < 0.3], raw[raw < 0.3])


def test_crops_match_an_independent_projection_of_the_crop_grid():
    # Reference: project every crop_grid point through Camera.project and interpolate the height image
    # bilinearly there with scipy. Checks the vectorised perspective map of extract_crops on its own
    # (a strongly tilted, yawed, off-centre camera), including the row/column order and the pixel
    # convention, which the rotation test cannot see.
    camera = tilted_camera(0.75, x=-0.05, y=0.04, yaw=0.7, tilt=(0.3, -0.2))
    shapes = t_shape(0.02, -0.01, 2.2) + [Box.on_table(-0.12, 0.1, (0.1, 0.03, 0.05), 0.4)]
    scene = prepare_depth(render_depth(camera, shapes), camera)
    rng = np.random.default_rng(0)
    grasps = np.column_stack(
        [rng.uniform(-0.15, 0.15, (12, 2)), rng.uniform(0.01, 0.04, 12), rng.uniform(0, 2 * np.pi, 12)]
    )
    config = CropConfig()
    crops = extract_crops(scene, None, grasps, config)
    uv, _ = camera.project(crop_grid(grasps, config).reshape(-1, 3))
    heights = ndimage.map_coordinates(scene.height, [uv[:, 1], uv[:, 0]], order=1, mode="constant", cval=0.0)
    ref = np.minimum(grasps[:, 2, None, None] - heights.reshape(crops.shape), config.max_value)
    h, w = scene.height.shape
    inside = ((uv[:, 0] >= 0) & (uv[:, 0] <= w - 1) & (uv[:, 1] >= 0) & (uv[:, 1] <= h - 1)).reshape(
        crops.shape
    )
    assert inside.mean() > 0.5
    diff = np.abs(crops - ref)[inside]
    assert np.percentile(diff, 99.9) < 1e-4 and diff.max() < 2e-3
    assert np.mean(ref < grasps[:, 2, None, None] - 0.005) > 0.01  # the crops do see the objects


def test_a_prepared_scene_refuses_a_different_camera():
    camera = tilted_camera(0.9)
    scene = prepare_depth(render_depth(camera, []), camera)
    assert prepare_depth(scene, camera) is scene
    same_pose = Camera(CameraIntrinsics(512, 424, 300.0, 300.0, 256.0, 212.0), camera.pose)
    with pytest.raises(ValueError, match="intrinsics differ"):
        extract_crops(scene, same_pose, np.zeros((1, 4)), CropConfig())
    moved = tilted_camera(0.8)
    with pytest.raises(ValueError, match="pose differs"):
        sample_antipodal(scene, moved, AntipodalConfig(), np.random.default_rng(0))
