import numpy as np
import pytest
import torch

from tognet.data.synthetic import write_synthetic_dataset
from tognet.grasping import CropConfig, extract_crops, grasp_depths, prepare_depth
from tognet.grasping.synthetic import render_depth, t_shape, tilted_camera
from tognet.model.checkpoint import load_checkpoint
from tognet.model.config import ArchConfig, TrainConfig
from tognet.model.predict import TOGNetPredictor
from tognet.model.train import TrainingError, train

TINY = ArchConfig(stem_channels=8, block_channels=(8,), block_strides=(2,), bottleneck_channels=4,
                  z_features=8, head_hidden=16)
CFG = TrainConfig(arch=TINY, epochs=1, batch_size=32, val_fraction=0.25, num_threads=1)
CROP = CropConfig(extent=0.3)


def _quiet(_: str) -> None:
    pass


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    root = tmp_path_factory.mktemp("crop")
    data = write_synthetic_dataset(root / "d", task="sweeping", n=96, shard_size=96, n_objects=8,
                                   configs={"crop": CROP})
    return train([data], "sweeping", root / "out", CFG, progress=False, log=_quiet)


def test_checkpoint_records_the_datasets_crop_config(run):
    payload = load_checkpoint(run.best_path)
    assert payload["crop_config"] == CROP.to_dict()
    assert TOGNetPredictor.load(run.best_path).crop_config == CROP


def test_predict_grasps_uses_the_checkpoints_crops_by_default(run):
    camera = tilted_camera(0.8)
    scene = prepare_depth(render_depth(camera, t_shape(0.0, 0.0, yaw=0.3)), camera)
    grasps = np.array([[0.0, 0.0, 0.02, 0.3], [0.05, 0.01, 0.02, 1.8], [-0.08, -0.02, 0.025, 0.0]])
    predictor = TOGNetPredictor.load(run.best_path)
    z = grasp_depths(scene.camera, grasps)
    matching = predictor.predict(extract_crops(scene, None, grasps, CROP), z)
    default = predictor.predict(extract_crops(scene, None, grasps, CropConfig()), z)
    assert not np.array_equal(matching.action_mean, default.action_mean)  # the extent matters
    got = predictor.predict_grasps(scene, grasps)
    np.testing.assert_array_equal(got.action_mean, matching.action_mean)
    np.testing.assert_array_equal(got.q_t, matching.q_t)


def test_crop_config_mismatches_are_refused(run, tmp_path):
    a = write_synthetic_dataset(tmp_path / "a", task="t", n=40, n_objects=4, configs={"crop": CROP})
    b = write_synthetic_dataset(tmp_path / "b", task="t", n=40, n_objects=4, configs={"crop": CropConfig()})
    with pytest.raises(TrainingError, match="different crop configs"):
        train([a, b], "t", tmp_path / "o", CFG, progress=False, log=_quiet)
    c = write_synthetic_dataset(tmp_path / "c", task="t", n=40, n_objects=4,
                                configs={"crop": CropConfig(size=48, extent=0.3)})
    with pytest.raises(TrainingError, match="crops of 48 px"):
        train([c], "t", tmp_path / "o", CFG, progress=False, log=_quiet)
    assert not (tmp_path / "o").exists()
    # A checkpoint written before crop configs were recorded still loads (crop_config None -> default).
    payload = torch.load(run.best_path, weights_only=True)
    payload.pop("crop_config")
    payload.pop("digest")  # and before checkpoints carried a digest
    torch.save(payload, tmp_path / "old.pt")
    assert TOGNetPredictor.load(tmp_path / "old.pt").crop_config is None


def test_eval_refuses_data_made_with_other_crops(run, tmp_path):
    from tognet.model.checkpoint import CheckpointError
    from tognet.model.train import evaluate_checkpoint

    same = write_synthetic_dataset(tmp_path / "same", task="sweeping", n=30, seed=5, configs={"crop": CROP})
    assert evaluate_checkpoint(run.best_path, [same])["count"] == 30
    other = write_synthetic_dataset(tmp_path / "other", task="sweeping", n=30, seed=5,
                                    configs={"crop": CropConfig()})
    with pytest.raises(CheckpointError, match=r"another CropConfig.*\['extent'\]"):
        evaluate_checkpoint(run.best_path, [other])
