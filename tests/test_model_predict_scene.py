import numpy as np
import pytest
import torch

from tognet.grasping import CropConfig, extract_crops, grasp_depths, prepare_depth
from tognet.grasping.synthetic import render_depth, t_shape, tilted_camera
from tognet.model.config import ArchConfig
from tognet.model.network import TOGNet
from tognet.model.predict import TOGNetPredictor


@pytest.fixture(scope="module")
def scene():
    camera = tilted_camera(0.8)
    return prepare_depth(render_depth(camera, t_shape(0.0, 0.0, yaw=0.3)), camera)


def test_predict_grasps_matches_crops_path(scene):
    torch.manual_seed(0)
    predictor = TOGNetPredictor(TOGNet(ArchConfig()).eval(), device="cpu")
    grasps = np.array([[0.0, 0.0, 0.02, 0.3], [0.05, 0.01, 0.02, 1.8], [-0.08, -0.02, 0.025, 0.0]])
    via_scene = predictor.predict_grasps(scene, grasps)
    crops = extract_crops(scene, None, grasps, CropConfig())
    z = grasp_depths(scene.camera, grasps)
    assert np.all((z > 0.7) & (z < 0.8))
    direct = predictor.predict(crops, z)
    np.testing.assert_array_equal(via_scene.q_t, direct.q_t)
    np.testing.assert_array_equal(via_scene.action_mean, direct.action_mean)
    score = predictor.grasp_score_fn(scene, "grasp")
    out = score(grasps)
    assert out.dtype == np.float64 and out.shape == (3,)
    np.testing.assert_allclose(out, direct.q_g)
    with pytest.raises(ValueError, match="crops of 32 px .* the network takes 64"):
        predictor.predict_grasps(scene, grasps, crop_config=CropConfig(size=32, center_size=16))


@pytest.mark.parametrize("n", [1, 5, 300])
def test_optimised_and_eager_predictors_agree(n):
    torch.manual_seed(2)
    model = TOGNet(ArchConfig()).eval()
    rng = np.random.default_rng(n)
    crops = rng.normal(0.0, 0.02, size=(n, 64, 64)).astype(np.float32)
    z = rng.uniform(0.6, 1.0, size=n).astype(np.float32)
    fast = TOGNetPredictor(model, device="cpu").predict(crops, z, batch_size=128)
    slow = TOGNetPredictor(model, device="cpu", optimize=False).predict(crops, z)
    for field in ("q_g", "q_t_given_g", "q_t", "action_mean"):
        np.testing.assert_allclose(getattr(fast, field), getattr(slow, field), rtol=1e-4, atol=1e-6)
