"""How often two objects touching are split or reported, and how often one tool is (issue 35 item 5).

Generated test-split tools settled by MuJoCo (tests/touching_testlib.py): every tool alone (2 settles x 4
views: Kinect2 at 0.7 m straight down and 0.9 m tilted 25 degrees, RealSense at 0.8 m tilted 20 and
0.6 m tilted 10), and pairs side by side (slid together until 1 mm apart) or one dropped across the
other (primitive + primitive, complex + complex, primitive + complex), through the sensor model. A pair's
outcome: apart (two regions already), split right (two halves, each 80 % or more one tool, different
tools), split wrong, reported (one region with the warning) or missed.

    python benchmarks/touching_counts.py --count 24            # objects generated into a temporary folder
    python benchmarks/touching_counts.py --count 72 --objects /tmp/sets --first 24
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import zlib
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from touching_testlib import KINECT2, REALSENSE, aim, outcome, owners, render, settle  # noqa: E402

from tognet.geometry import Camera  # noqa: E402
from tognet.grasping.depth import height_map  # noqa: E402
from tognet.objects.generate import generate_set, realistic_count  # noqa: E402
from tognet.planning.segment import SegmentConfig, segment_objects, table_noise  # noqa: E402
from tognet.planning.table import plane_from_pose  # noqa: E402
from tognet.sim.glcamera import SensorModel  # noqa: E402

VIEWS = [(KINECT2, 0.7, 0.0), (REALSENSE, 0.8, 20.0), (KINECT2, 0.9, 25.0), (REALSENSE, 0.6, 10.0)]


def _photo(scene, view, seed):
    k, distance, tilt = VIEWS[view]
    camera = aim(scene, k, distance, tilt, azimuth=float(seed))
    clean = render(scene.meshes, camera)
    depth = SensorModel().apply(clean, np.random.default_rng(seed))
    table = Camera(k, plane_from_pose(camera.pose).table_from_camera())
    height = height_map(depth, table)
    return depth, height, table, camera, clean


def _segment(depth, height, table, config):
    return segment_objects(height, depth, table.intrinsics, table.pose, config, table_noise(height, depth))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=24, help="tools of each kind (and pairs of each mix)")
    parser.add_argument("--first", type=int, default=0, help="first object index")
    parser.add_argument("--objects", type=Path, default=None, help="folder of the generated sets (reused)")
    args = parser.parse_args()
    root = args.objects or Path(tempfile.mkdtemp(prefix="touching-"))
    end = args.first + args.count
    sets = {kind: generate_set(kind, "test", min(end, realistic_count()) if kind == "realistic" else end,
                               root / kind) for kind in ("primitive", "complex", "realistic")}
    config, times, counts = SegmentConfig(), {True: [], False: []}, Counter()
    for kind, records in sets.items():
        for rec in records[args.first:end]:
            for settle_seed in (1000, 2000):
                scene = settle([rec], "alone", settle_seed + zlib.crc32(rec.object_id.encode()) % 97)
                for view in range(len(VIEWS)):
                    depth, height, table, _, _ = _photo(scene, view, settle_seed + view)
                    for on in (False, True):
                        t0 = time.perf_counter()
                        found = _segment(depth, height, table, config.replace(touching=on))
                        times[on].append(time.perf_counter() - t0)
                    flagged = [o for o in found if o.touching is not None]
                    counts[(kind, "alone", "images")] += 1
                    if flagged:
                        what = "split" if any(o.split for o in flagged) else "reported"
                        counts[(kind, "alone", what)] += 1
                        print(f"{what}: {rec.object_id} (settle {settle_seed}, view {view}): "
                              + str(flagged[0].touching))
    prim, comp = sets["primitive"], sets["complex"]
    for arrangement in ("side", "across"):
        for mix, (a, b) in {"primitive+primitive": (prim, prim), "complex+complex": (comp, comp),
                            "primitive+complex": (prim, comp)}.items():
            for i in range(args.first, end):
                j = (i * 7 + 3) % end
                scene = settle([a[i], b[j]], arrangement, seed=i)
                depth, height, table, camera, clean = _photo(scene, i % len(VIEWS), i)
                counts[(mix, arrangement, outcome(_segment(depth, height, table, config),
                                                   owners(scene, camera, clean)))] += 1
    for key in sorted(counts):
        print(" / ".join(key[:2]), key[2], counts[key])
    for on in (False, True):
        t = np.array(times[on]) * 1000
        print(f"segment_objects, touching={on}: median {np.median(t):.1f} ms, "
              f"95th {np.percentile(t, 95):.0f}, max {t.max():.0f} ms ({len(t)} images)")


if __name__ == "__main__":
    main()
