"""`tognet plan --bag` (issue 32): depth images and intrinsics from ROS 1, ROS 2 sqlite3 and ROS 2 MCAP bags
written here with rosbags; the same plan as from the image files."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

pytest.importorskip("rosbags", reason="the ros extra (pip install 'tognet[ros]')")

from rosbags.typesys import Stores, get_typestore  # noqa: E402

from tognet.cli import app  # noqa: E402
from tognet.planning.bags import BagError, read_bag  # noqa: E402
from tognet.planning.camera import save_depth_png, save_intrinsics  # noqa: E402

TASK = "hammering"
DEPTH, INFO = "/camera/depth/image_rect_raw", "/camera/depth/camera_info"


def _messages(store, depth, k, stamp, encoding):
    """(Image, CameraInfo) of ``store`` for a depth image (metres, NaN holes)."""
    t = store.types
    ros1 = "K" in t["sensor_msgs/msg/CameraInfo"].__dataclass_fields__
    time = t["builtin_interfaces/msg/Time"](sec=int(stamp), nanosec=int((stamp % 1) * 1e9))
    header = (t["std_msgs/msg/Header"](seq=0, stamp=time, frame_id="depth") if ros1
              else t["std_msgs/msg/Header"](stamp=time, frame_id="depth"))
    if encoding == "16UC1":
        pixels = np.where(np.isfinite(depth), np.rint(depth * 1000), 0).astype("<u2")
    else:
        pixels = np.where(np.isfinite(depth), depth, np.nan).astype("<f4")
    h, w = depth.shape
    data = np.frombuffer(pixels.tobytes(), np.uint8)
    image = t["sensor_msgs/msg/Image"](header=header, height=h, width=w, encoding=encoding, is_bigendian=0,
                                       step=w * pixels.itemsize, data=data)
    kk = np.array([k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1], dtype=np.float64)
    eye = np.eye(3).reshape(-1)
    proj = np.array([k.fx, 0, k.cx, 0, 0, k.fy, k.cy, 0, 0, 0, 1, 0], dtype=np.float64)
    roi = t["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
    fields = dict(zip(("D", "K", "R", "P") if ros1 else ("d", "k", "r", "p"), (np.zeros(5), kk, eye, proj),
                      strict=True))
    info = t["sensor_msgs/msg/CameraInfo"](header=header, height=h, width=w, distortion_model="plumb_bob",
                                           binning_x=0, binning_y=0, roi=roi, **fields)
    return image, info


def write_bag(path, kind, frames, k, encoding="16UC1"):
    """A bag of ``kind`` ("ros1", "sqlite3", "mcap") with one depth image and camera info per frame
    (time in s, image)."""
    if kind == "ros1":
        from rosbags.rosbag1 import Writer

        store = get_typestore(Stores.ROS1_NOETIC)
        writer, serialize = Writer(path), store.serialize_ros1
    else:
        from rosbags.rosbag2 import StoragePlugin, Writer

        store = get_typestore(Stores.ROS2_HUMBLE)
        plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        writer, serialize = Writer(path, version=9, storage_plugin=plugin), store.serialize_cdr
    with writer:
        image_c = writer.add_connection(DEPTH, "sensor_msgs/msg/Image", typestore=store)
        info_c = writer.add_connection(INFO, "sensor_msgs/msg/CameraInfo", typestore=store)
        for stamp, depth in frames:
            image, info = _messages(store, depth, k, stamp, encoding)
            ns = int(stamp * 1e9)
            writer.write(info_c, ns, serialize(info, "sensor_msgs/msg/CameraInfo"))
            writer.write(image_c, ns, serialize(image, "sensor_msgs/msg/Image"))
    return path


@pytest.fixture(scope="module")
def scene(hammer_sim, tmp_path_factory):
    root = tmp_path_factory.mktemp("bags")
    first = hammer_sim.reset(3)
    second = hammer_sim.reset(5)
    k = first.camera.intrinsics
    return {"root": root, "k": k, "frames": [(100.0, second.depth), (100.5, first.depth)],
            "png": save_depth_png(root / "d.png", first.depth), "intr": save_intrinsics(root / "k.json", k)}


def _plan(*args):
    result = CliRunner().invoke(app, ["plan", "--task", TASK, *map(str, args)])
    return result


@pytest.mark.parametrize("kind, encoding", [("ros1", "16UC1"), ("sqlite3", "16UC1"), ("mcap", "16UC1"),
                                            ("mcap", "32FC1")])
def test_a_bag_gives_the_plan_of_the_image_files(kind, encoding, scene, tmp_path):
    path = tmp_path / ("d.bag" if kind == "ros1" else "d")
    write_bag(path, kind, scene["frames"], scene["k"], encoding)
    # the second frame, 0.5 s after the first: --at picks it
    frame = read_bag(path, DEPTH, INFO, at=0.4)
    assert frame.time == pytest.approx(0.5) and frame.intrinsics == scene["k"]
    assert frame.depth.dtype == (np.uint16 if encoding == "16UC1" else np.float32)
    from_bag = _plan("--bag", path, "--depth-topic", DEPTH, "--info-topic", INFO, "--at", 0.4, "--out",
                     tmp_path / "bag.json")
    assert from_bag.exit_code == 0, from_bag.output
    image = scene["png"]  # the same millimetres, or the same float metres
    if encoding == "32FC1":
        image = tmp_path / "d.npy"
        np.save(image, scene["frames"][1][1].astype(np.float32))
    from_files = _plan("--depth", image, "--intrinsics", scene["intr"], "--out", tmp_path / "file.json")
    assert from_files.exit_code == 0, from_files.output
    a, b = (json.loads((tmp_path / f).read_text()) for f in ("bag.json", "file.json"))
    assert a["grasp"] == b["grasp"] and a["alternatives"] == b["alternatives"]


def test_a_missing_topic_lists_the_bags_topics(scene, tmp_path):
    path = write_bag(tmp_path / "d", "sqlite3", scene["frames"][:1], scene["k"])
    result = _plan("--bag", path, "--depth-topic", "/camera/depth", "--info-topic", INFO)
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert "no topic /camera/depth; the bag's topics: " in lines[0] and DEPTH in lines[0] and INFO in lines[0]
    result = _plan("--bag", path, "--depth-topic", INFO, "--info-topic", INFO)  # not an image
    assert result.exit_code == 2 and "holds sensor_msgs/msg/CameraInfo, not sensor_msgs" in result.output
    result = _plan("--bag", path, "--depth-topic", DEPTH)  # no intrinsics
    assert result.exit_code == 2 and "--info-topic" in result.output
    result = _plan("--bag", path, "--depth-topic", DEPTH, "--info-topic", INFO, "--at", 30)
    assert result.exit_code == 2 and "outside the bag" in result.output
    with pytest.raises(BagError, match="not a readable ROS bag"):
        read_bag(scene["png"], DEPTH)
