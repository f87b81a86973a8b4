"""Antipodal sampler on ray-cast depth images of known shapes (slightly tilted camera)."""

import numpy as np
import pytest

from tognet.geometry import DepthImageError
from tognet.grasping import AntipodalConfig, GraspCandidates, grasp_depths, prepare_depth, sample_antipodal
from tognet.grasping.synthetic import Box, Cylinder, render_depth, t_shape, tilted_camera

TILT = (np.pi / 70, -np.pi / 90)


def _camera(seed: int = 0):
    rng = np.random.default_rng(seed)
    return tilted_camera(
        0.9 + rng.uniform(-0.03, 0.03),
        x=rng.uniform(-0.05, 0.05),
        y=rng.uniform(-0.05, 0.05),
        yaw=rng.uniform(-0.2, 0.2),
        tilt=(rng.uniform(-1, 1) * TILT[0], rng.uniform(-1, 1) * TILT[0]),
    )


def _local(points_xy: np.ndarray, cx: float, cy: float, yaw: float) -> np.ndarray:
    """World xy -> the object's frame (x along its length)."""
    c, s = np.cos(yaw), np.sin(yaw)
    d = points_xy - np.array([cx, cy])
    return np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], axis=-1)


def _check_common(cands: GraspCandidates, camera, config: AntipodalConfig, top: float):
    n = len(cands)
    assert cands.grasps.shape == (n, 4) and cands.z_depth.shape == (n,) and cands.pixels.shape == (n, 2)
    assert np.all(cands.widths <= config.max_width) and np.all(cands.widths >= config.min_width)
    assert np.all((cands.quality >= 0) & (cands.quality <= 1))
    assert np.all((cands.grasps[:, 3] >= 0) & (cands.grasps[:, 3] < 2 * np.pi))
    # Gripper centre below the top surface by the sampled offset, never below table + clearance.
    z = cands.grasps[:, 2]
    assert np.all(z >= config.table_z + config.finger_clearance - 1e-9)
    assert np.all(z <= top - config.min_depth_offset + 2e-3)
    np.testing.assert_allclose(cands.z_depth, grasp_depths(camera, cands.grasps), atol=1e-9)
    uv, _ = camera.project(cands.grasps[:, :3])
    np.testing.assert_allclose(cands.pixels, uv, atol=1e-6)
    # Distinct candidates.
    assert np.unique(np.round(cands.grasps, 6), axis=0).shape[0] == n


def _check_spans(contacts, half_width, half_length, rel_phi, config, tol=0.006):
    """Contacts (N, 2, 2) in the bar's frame (x along it). Every candidate touches the bar's boundary
    with both jaws, closes within the friction cone (+6 degrees of normal-estimate error) of the narrow
    axis and fits the opening; at least 90 % span the two long sides (one jaw on each). The others
    touch an end face near a corner, which a 45 degree cone (mu = 1) admits as antipodal.
    Returns the mask of side-spanning candidates. ``tol``: a side hidden from the camera casts a
    shadow of unknown space, counted as occupied, so contacts there lie a few mm out."""
    half_width = np.broadcast_to(np.asarray(half_width, dtype=float).reshape(-1, 1), contacts.shape[:2])
    on_side = np.abs(np.abs(contacts[:, :, 1]) - half_width) < tol
    on_end = np.abs(np.abs(contacts[:, :, 0]) - half_length) < tol
    assert np.all(on_side | on_end)
    assert np.all(np.abs(contacts[:, :, 0]) <= half_length + tol)
    ys = np.sort(contacts[:, :, 1], axis=1)
    spans = on_side.all(axis=1) & (ys[:, 0] < 0) & (ys[:, 1] > 0)
    assert np.mean(spans) >= 0.9
    assert np.all(spans | on_end.any(axis=1))
    assert np.all(np.abs(np.sin(rel_phi)) >= np.cos(np.arctan(config.friction_coef) + np.radians(6)))
    return spans


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_box_candidates_span_the_narrow_dimension(seed):
    rng = np.random.default_rng(seed)
    cx, cy, yaw = rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(0, 2 * np.pi)
    width, length, height = 0.035, 0.16, 0.03
    camera = _camera(seed)
    depth = render_depth(camera, [Box.on_table(cx, cy, (length, width, height), yaw)])
    config = AntipodalConfig()
    cands = sample_antipodal(depth, camera, config, np.random.default_rng(seed))
    assert len(cands) >= 50
    _check_common(cands, camera, config, top=height)
    contacts = _local(cands.contacts[:, :, :2], cx, cy, yaw)  # (N, 2, 2)
    rel = cands.grasps[:, 3] - yaw
    spans = _check_spans(contacts, width / 2, length / 2, rel, config)
    assert np.all(cands.widths[spans] >= width - 0.006)
    # Grasps across the box: the best ones are nearly perpendicular to its length.
    best = np.argsort(-cands.quality)[:10]
    assert np.all(np.abs(np.sin(rel[best])) > 0.97)


@pytest.mark.parametrize("seed", [0, 1])
def test_lying_cylinder_candidates_span_the_diameter(seed):
    rng = np.random.default_rng(10 + seed)
    cx, cy, yaw = rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(0, 2 * np.pi)
    radius, length = 0.016, 0.2
    camera = _camera(seed + 5)
    depth = render_depth(camera, [Cylinder.lying(cx, cy, radius, length, yaw)])
    config = AntipodalConfig()
    cands = sample_antipodal(depth, camera, config, np.random.default_rng(seed))
    assert len(cands) >= 50
    _check_common(cands, camera, config, top=2 * radius)
    contacts = _local(cands.contacts[:, :, :2], cx, cy, yaw)
    # The jaws touch where the cylinder's cross-section is at the gripper-centre height.
    dz = cands.grasps[:, 2] - radius
    half_width = np.where(dz > 0, np.sqrt(np.maximum(radius**2 - dz**2, 0)), radius)
    rel = cands.grasps[:, 3] - yaw
    spans = _check_spans(contacts, half_width, length / 2, rel, config)
    centre = _local(cands.grasps[:, :2], cx, cy, yaw)
    assert np.all(np.abs(centre[spans, 1]) < 0.006)
    # Away from the end caps a slanted chord is 2 * half_width / sin(slant).
    slant = np.abs(np.sin(rel))  # 1 when the jaws close across the axis
    mid = spans & np.all(np.abs(contacts[:, :, 0]) < length / 2 - 0.02, axis=1)
    assert mid.sum() > 0.7 * len(cands)
    np.testing.assert_allclose(cands.widths[mid], 2 * half_width[mid] / slant[mid], atol=0.008)


def test_wide_box_has_no_grasp_across_its_width_beyond_the_opening():
    # 0.10 x 0.12 box: both dimensions exceed the 0.08 opening, so no candidate may exist.
    camera = _camera(3)
    depth = render_depth(camera, [Box.on_table(0.0, 0.0, (0.12, 0.10, 0.03), 0.4)])
    cands = sample_antipodal(depth, camera, AntipodalConfig(), np.random.default_rng(0))
    assert len(cands) == 0


def test_t_shape_respects_max_candidates_and_seed():
    camera = _camera(4)
    depth = render_depth(camera, t_shape(0.02, -0.03, 0.7))
    config = AntipodalConfig(max_candidates=50)
    a = sample_antipodal(depth, camera, config, np.random.default_rng(7))
    b = sample_antipodal(depth, camera, config, np.random.default_rng(7))
    assert len(a) == 50
    np.testing.assert_array_equal(a.grasps, b.grasps)
    canonical = sample_antipodal(
        depth, camera, config.replace(axis_direction="canonical"), np.random.default_rng(7)
    )
    assert np.all(canonical.grasps[:, 3] < np.pi)


@pytest.mark.parametrize("limit", [50, 51])
def test_both_orientations_come_in_adjacent_pairs(limit):
    camera = _camera(4)
    depth = render_depth(camera, t_shape(0.02, -0.03, 0.7))
    config = AntipodalConfig(max_candidates=limit, axis_direction="both")
    both = sample_antipodal(depth, camera, config, np.random.default_rng(7))
    assert len(both) == limit
    n_pairs = limit // 2
    g = both.grasps[: 2 * n_pairs].reshape(n_pairs, 2, 4)
    np.testing.assert_allclose(g[:, 0, :3], g[:, 1, :3])
    np.testing.assert_allclose(np.mod(g[:, 1, 3] - g[:, 0, 3], 2 * np.pi), np.pi, atol=1e-9)
    np.testing.assert_allclose(both.z_depth[0::2][:n_pairs], both.z_depth[1::2][:n_pairs])
    np.testing.assert_array_equal(both.quality[0::2][:n_pairs], both.quality[1::2][:n_pairs])
    assert both.contacts.shape[0] == limit
    # Distinct contact pairs: half as many as candidates (rounded up).
    assert len({tuple(np.round(x[:3], 6)) for x in both.grasps}) == (limit + 1) // 2


def test_empty_table_gives_explicit_empty_result():
    camera = _camera(5)
    depth = render_depth(camera, [])
    cands = sample_antipodal(depth, camera, AntipodalConfig(), np.random.default_rng(0))
    assert len(cands) == 0
    assert cands.grasps.shape == (0, 4) and cands.pixels.shape == (0, 2) and cands.contacts.shape == (0, 2, 3)


@pytest.mark.parametrize("hole_value", [np.nan, 0.0])
def test_holes_are_handled(hole_value):
    rng = np.random.default_rng(1)
    width, length, yaw = 0.035, 0.16, 0.3
    camera = _camera(6)
    depth = render_depth(camera, [Box.on_table(0.0, 0.0, (length, width, 0.03), yaw)])
    holes = rng.random(depth.shape) < 0.05
    depth[holes] = hole_value
    depth[200:215, 300:330] = hole_value  # a larger dropout region
    scene = prepare_depth(depth, camera)
    assert scene.holes.sum() >= holes.sum() and np.all(np.isfinite(scene.filled))
    cands = sample_antipodal(scene, None, AntipodalConfig(), rng)
    assert len(cands) >= 30
    contacts = _local(cands.contacts[:, :, :2], 0.0, 0.0, yaw)
    spans = _check_spans(contacts, width / 2, length / 2, cands.grasps[:, 3] - yaw, AntipodalConfig())
    assert np.all(cands.widths[spans] >= width - 0.006)


def test_bad_depth_input_raises_clear_errors():
    camera = _camera(0)
    config, rng = AntipodalConfig(), np.random.default_rng(0)
    good = render_depth(camera, [])
    with pytest.raises(DepthImageError, match="shape"):
        sample_antipodal(good[:100], camera, config, rng)
    with pytest.raises(DepthImageError, match="numeric"):
        sample_antipodal(good.astype(str), camera, config, rng)
    with pytest.raises(DepthImageError, match="millimetres"):
        sample_antipodal(good * 1000, camera, config, rng)
    with pytest.raises(DepthImageError, match="no valid pixels"):
        sample_antipodal(np.full_like(good, np.nan), camera, config, rng)
    with pytest.raises(DepthImageError, match="no valid pixels"):
        sample_antipodal(np.zeros_like(good), camera, config, rng)
    with pytest.raises(ValueError, match="camera"):
        sample_antipodal(good, None, config, rng)


def test_finger_collision_check_drops_grasps_next_to_a_tall_obstacle():
    # A low bar (3 cm wide, 2 cm tall) with a 10 cm wall 3 cm beside it: the fingers come down fully
    # open (8 cm), so one of them would land on the wall whenever the jaws close across the bar.
    camera = _camera(2)
    shapes = [
        Box.on_table(0.0, 0.0, (0.16, 0.03, 0.02), 0.0),
        Box.on_table(0.0, 0.055, (0.16, 0.02, 0.10), 0.0),
    ]
    depth = render_depth(camera, shapes)
    with_check = sample_antipodal(depth, camera, AntipodalConfig(), np.random.default_rng(0))
    without = sample_antipodal(
        depth, camera, AntipodalConfig(collision_check=False), np.random.default_rng(0)
    )

    def on_low_bar(c):  # away from the bar's ends, where slanted grasps can reach past the wall
        g = c.grasps
        return (np.abs(g[:, 1]) < 0.01) & (g[:, 2] < 0.02) & (np.abs(g[:, 0]) < 0.05)

    assert on_low_bar(without).sum() > 10
    assert on_low_bar(with_check).sum() == 0
    assert len(with_check) > 50  # the wall itself is still graspable
    # Moved 6 cm away, the wall no longer blocks the bar.
    far = [shapes[0], Box.on_table(0.0, 0.085, (0.16, 0.02, 0.10), 0.0)]
    free = sample_antipodal(render_depth(camera, far), camera, AntipodalConfig(), np.random.default_rng(0))
    assert on_low_bar(free).sum() > 10


def test_workspace_restricts_candidates_and_keeps_the_count():
    camera = _camera(7)
    shapes = [
        Box.on_table(-0.15, 0.0, (0.16, 0.03, 0.03), 0.3),
        Box.on_table(0.15, 0.0, (0.16, 0.03, 0.03), 1.2),
    ]
    depth = render_depth(camera, shapes)
    config = AntipodalConfig(max_candidates=60, workspace=(0.0, 0.4, -0.3, 0.3))
    cands = sample_antipodal(depth, camera, config, np.random.default_rng(0))
    assert len(cands) == 60
    assert np.all(cands.grasps[:, 0] > 0.03)


def test_holes_at_an_object_edge_are_filled_from_the_background():
    # A dropout band straddling the box's long side: filled from the farthest neighbour, the band's
    # pixels off the box read the table (the outline does not grow; a nearest/nearer fill would
    # extend the box over the whole band on one side).
    camera = tilted_camera(0.9)
    depth = render_depth(camera, [Box.on_table(0.0, 0.0, (0.16, 0.04, 0.03), 0.0)])
    on_box = depth < np.nanmax(depth) - 0.01
    rows = np.nonzero(on_box.any(axis=1))[0]
    band = np.zeros_like(on_box)
    band[rows[0] - 6 : rows[0] + 6, 200:300] = True  # 12 px across the top edge
    holey = np.where(band, np.nan, depth)
    scene = prepare_depth(holey, camera)
    off_box = band & ~on_box
    assert off_box.sum() >= 500
    np.testing.assert_allclose(scene.filled[off_box], depth[off_box], atol=2e-3)
    assert np.mean(np.abs(scene.filled[band] - depth[band]) > 0.005) < 0.25


def test_open_fingers_never_land_on_a_thin_rib_crossing_the_handle():
    # A 6 mm rib, 3 cm tall, crosses a handle (a plus shape). The rib runs along the jaw axis of the
    # grasps across the handle, so the jaw-axis scan cannot see it: only the landing-zone samples across
    # each 4 cm pad can. With samples 2 cm apart about 7 % of the candidates put a pad on the rib.
    camera = tilted_camera(0.9, tilt=(0.01, -0.01))
    rib_w, rib_h = 0.006, 0.03
    shapes = [
        Box.on_table(0.0, 0.0, (0.24, 0.025, 0.025), 0.0),
        Box.on_table(0.0, 0.0, (rib_w, 0.14, rib_h), 0.0),
    ]
    config = AntipodalConfig()
    cands = sample_antipodal(render_depth(camera, shapes), camera, config, np.random.default_rng(0))
    assert len(cands) >= 100
    g = cands.grasps
    axis = np.stack([np.cos(g[:, 3]), np.sin(g[:, 3])], axis=1)
    normal = np.stack([-axis[:, 1], axis[:, 0]], axis=1)
    along = config.max_width / 2 + np.linspace(0.0, config.finger_offset, 6)
    along = np.concatenate([-along, along])
    across = np.linspace(-0.5, 0.5, 41) * config.finger_width
    pads = (
        g[:, None, None, :2]
        + along[None, :, None, None] * axis[:, None, None, :]
        + across[None, None, :, None] * normal[:, None, None, :]
    )  # dense pad footprints (N, 12, 41, 2)
    on_rib = (np.abs(pads[..., 0]) < rib_w / 2) & (np.abs(pads[..., 1]) < 0.07)
    lands = on_rib.any(axis=(1, 2)) & (g[:, 2] - config.pad_height / 2 < rib_h)
    assert lands.sum() == 0


def test_contacts_keep_away_from_corners_where_the_normal_is_undefined():
    # Edge pixels whose window gradients disagree (corners) are dropped; without that filter about
    # 23 % of the candidates on a 12 x 4 cm box have a contact within 8 mm of an end, with it ~2 %.
    camera = tilted_camera(0.9, tilt=(0.03, -0.02), yaw=0.1)
    length, n_near, n_all = 0.12, 0, 0
    for seed in range(3):
        rng = np.random.default_rng(seed)
        yaw = rng.uniform(0, np.pi)
        depth = render_depth(camera, [Box.on_table(0.0, 0.0, (length, 0.04, 0.03), yaw)])
        cands = sample_antipodal(depth, camera, AntipodalConfig(), rng)
        along = _local(cands.contacts[:, :, :2], 0.0, 0.0, yaw)[:, :, 0]
        n_near += int(np.sum((np.abs(np.abs(along) - length / 2) < 0.008).any(axis=1)))
        n_all += len(cands)
    assert n_all >= 300
    assert n_near / n_all < 0.12


@pytest.mark.parametrize("noise", [0.001, 0.003])
def test_sensor_noise_does_not_drown_the_edges(noise):
    # Gaussian depth noise of 1-3 mm (Kinect class). Without smoothing before the gradients, 2 mm of
    # noise put most table pixels over the edge threshold and left no candidate (1 mm: about half).
    width, length, yaw = 0.035, 0.16, 0.5
    camera = _camera(8)
    depth = render_depth(camera, [Box.on_table(0.0, 0.0, (length, width, 0.03), yaw)])
    rng = np.random.default_rng(0)
    depth = depth + rng.normal(0.0, noise, depth.shape).astype(np.float32)
    config = AntipodalConfig()
    cands = sample_antipodal(depth, camera, config, rng)
    assert len(cands) >= 150
    centre = _local(cands.grasps[:, :2], 0.0, 0.0, yaw)
    assert np.all(np.abs(centre[:, 0]) < length / 2 + 0.005) and np.all(
        np.abs(centre[:, 1]) < width / 2 + 0.005
    )
    rel = cands.grasps[:, 3] - yaw
    assert np.all(np.abs(np.sin(rel)) >= np.cos(np.arctan(config.friction_coef) + np.radians(6)))
    assert np.median(np.abs(np.sin(rel))) > 0.9
    assert np.median(np.abs(cands.widths - width)) < 0.004


def test_gaussian_smoothing_matches_scipy():
    from scipy import ndimage

    from tognet.grasping.antipodal import _gaussian_smooth

    image = np.random.default_rng(0).random((40, 57)).astype(np.float32)
    for sigma in (0.6, 1.0, 1.7):
        expected = ndimage.gaussian_filter(image, sigma, truncate=2.0, mode="nearest")
        np.testing.assert_allclose(_gaussian_smooth(image, sigma), expected, atol=1e-6)


@pytest.mark.parametrize("height", [0.006, 0.007])
def test_flat_parts_a_few_millimetres_tall_still_have_edges(height):
    # Smoothing lowers a step's peak gradient to ~65 %; with the unscaled threshold a 7 mm tall part
    # lost all its edges (and so its candidates).
    camera = _camera(9)
    depth = render_depth(camera, [Box.on_table(0.0, 0.0, (0.16, 0.035, height), 0.5)])
    cands = sample_antipodal(depth, camera, AntipodalConfig(), np.random.default_rng(0))
    assert len(cands) >= 100
