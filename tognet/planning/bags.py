"""Depth images and intrinsics from ROS bags (``tognet plan --bag``; the optional extra ``ros``: the
pure-Python ``rosbags`` library, no ROS install).

A ROS 1 bag (``.bag``) or a ROS 2 bag (its folder, sqlite3 or MCAP storage) is read with
``rosbags.highlevel.AnyReader``. The depth image is a ``sensor_msgs/Image`` with encoding ``16UC1``
(millimetres, 0 = no reading) or ``32FC1`` (metres, NaN or 0 = no reading); the intrinsics a
``sensor_msgs/CameraInfo`` (its K matrix and size; an image with distortion coefficients other than zero
is refused, as an intrinsics file with them is). ``at``: seconds from the bag's start; the depth message
nearest to it is taken (default: the first), and the camera info nearest to that message.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.errors import TognetError
from tognet.geometry import CameraIntrinsics

EXTRA_HINT = "pip install 'tognet[ros]'"


class BagError(TognetError):
    """A bag, a topic or a message that cannot give a depth image; the message names it."""


@dataclass(frozen=True)
class BagFrame:
    """A depth image from a bag: ``depth`` (uint16 millimetres or float32 metres, as the message held it),
    the intrinsics when a camera-info topic was read, the message's time (s from the bag's start), and its
    topic."""

    depth: NDArray[Any]
    intrinsics: CameraIntrinsics | None
    time: float
    topic: str


def _reader(path: Path) -> Any:
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise BagError(f"--bag needs the ros extra (the rosbags library): {EXTRA_HINT}") from None
    if not path.exists():
        raise FileNotFoundError(f"bag not found: {path}")
    store = Stores.ROS1_NOETIC if path.suffix == ".bag" else Stores.ROS2_HUMBLE
    try:
        return AnyReader([path], default_typestore=get_typestore(store))
    except Exception as exc:  # noqa: BLE001 (rosbags' own errors: not a bag, damaged)
        raise BagError(f"{path}: not a readable ROS bag ({' '.join(str(exc).split())})") from None


def _topic(reader: Any, path: Path, topic: str, kinds: tuple[str, ...]) -> list[Any]:
    """The connections of ``topic``; BagError listing the bag's topics when it has none of that name or
    of another type."""
    conns = [c for c in reader.connections if c.topic == topic]
    listing = ", ".join(f"{c.topic} ({c.msgtype}, {c.msgcount} msgs)" for c in reader.connections)
    if not conns:
        raise BagError(f"{path}: no topic {topic}; the bag's topics: {listing or 'none'}")
    if conns[0].msgtype not in kinds:
        raise BagError(f"{path}: {topic} holds {conns[0].msgtype}, not {' or '.join(kinds)}; the bag's "
                       f"topics: {listing}")
    return conns


def _nearest(reader: Any, conns: list[Any], stamp: int) -> tuple[int, Any]:
    """(time, raw message) of the message of ``conns`` nearest to ``stamp`` (ns)."""
    best: tuple[int, int, Any] | None = None
    for conn, t, raw in reader.messages(connections=conns):
        gap = abs(t - stamp)
        if best is None or gap < best[0]:
            best = (gap, t, (conn, raw))
        elif t > stamp:
            break
    assert best is not None
    return best[1], best[2]


def image_array(msg: Any, where: str) -> NDArray[Any]:
    """A sensor_msgs/Image as an array: uint16 millimetres (16UC1) or float32 metres (32FC1)."""
    kinds = {"16uc1": np.uint16, "mono16": np.uint16, "32fc1": np.float32}
    encoding = str(msg.encoding).lower()
    if encoding not in kinds:
        raise BagError(f"{where}: image encoding {msg.encoding!r} is not a depth image (16UC1 millimetres or "
                       "32FC1 metres)")
    dtype = np.dtype(kinds[encoding]).newbyteorder(">" if msg.is_bigendian else "<")
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    data = np.frombuffer(bytes(msg.data), dtype=np.uint8)
    if step < w * dtype.itemsize or len(data) < h * step:
        raise BagError(f"{where}: the image holds {len(data)} bytes for {w} x {h} pixels of {msg.encoding} "
                       f"(step {step}): truncated?")
    rows = data[: h * step].reshape(h, step)[:, : w * dtype.itemsize]
    return np.ascontiguousarray(rows).view(dtype).reshape(h, w).astype(kinds[encoding])


def camera_info(msg: Any, where: str) -> CameraIntrinsics:
    """A sensor_msgs/CameraInfo's pinhole intrinsics (ROS 1 names its matrix K, ROS 2 k)."""
    k = np.asarray(getattr(msg, "k", getattr(msg, "K", None)), dtype=np.float64).reshape(-1)
    d = np.asarray(getattr(msg, "d", getattr(msg, "D", [])), dtype=np.float64)
    if k.size != 9 or not np.all(np.isfinite(k)) or k[0] <= 0 or k[4] <= 0:
        raise BagError(f"{where}: the camera info's K is not a pinhole matrix ({k.tolist()})")
    if d.size and np.any(d != 0):
        raise BagError(f"{where}: the camera info has distortion coefficients {d.tolist()}; tognet plans on "
                       "undistorted (rectified) depth images: record the rectified topic")
    return CameraIntrinsics(width=int(msg.width), height=int(msg.height), fx=float(k[0]), fy=float(k[4]),
                            cx=float(k[2]), cy=float(k[5]))


def read_bag(path: str | Path, depth_topic: str, info_topic: str | None = None, at: float | None = None
             ) -> BagFrame:
    """The depth image of ``depth_topic`` nearest to ``at`` seconds from the bag's start (default: the
    first), and with ``info_topic`` its intrinsics (see the module docstring)."""
    path = Path(path)
    reader = _reader(path)
    try:
        reader.open()
    except Exception as exc:  # noqa: BLE001 (rosbags' own errors)
        raise BagError(f"{path}: not a readable ROS bag ({' '.join(str(exc).split())})") from None
    try:
        return _frame(reader, path, depth_topic, info_topic, at)
    finally:
        reader.close()


def _frame(reader: Any, path: Path, depth_topic: str, info_topic: str | None, at: float | None) -> BagFrame:
    """:func:`read_bag` on an open reader."""
    image_kinds = ("sensor_msgs/msg/Image", "sensor_msgs/Image")
    conns = _topic(reader, path, depth_topic, image_kinds)
    info_conns = None if info_topic is None else _topic(
        reader, path, info_topic, ("sensor_msgs/msg/CameraInfo", "sensor_msgs/CameraInfo"))
    start = reader.start_time
    if at is not None and not 0 <= at <= (reader.end_time - start) / 1e9 + 1e-9:
        raise BagError(f"--at {at:g} s is outside the bag ({(reader.end_time - start) / 1e9:.3f} s long)")
    stamp, (conn, raw) = _nearest(reader, conns, start + int(round((at or 0.0) * 1e9)))
    where = f"{path} {depth_topic} at {(stamp - start) / 1e9:.3f} s"
    depth = image_array(reader.deserialize(raw, conn.msgtype), where)
    intrinsics = None
    if info_conns is not None:
        _, (iconn, iraw) = _nearest(reader, info_conns, stamp)
        intrinsics = camera_info(reader.deserialize(iraw, iconn.msgtype), f"{path} {info_topic}")
        if (intrinsics.width, intrinsics.height) != (depth.shape[1], depth.shape[0]):
            raise BagError(f"{where}: the image is {depth.shape[1]} x {depth.shape[0]} but {info_topic} "
                           f"says {intrinsics.width} x {intrinsics.height}")
    return BagFrame(depth, intrinsics, (stamp - start) / 1e9, depth_topic)
