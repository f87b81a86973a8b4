"""Disk bytes per item of the commands that check space before long work, measured from real files.

Usage: .venv/bin/python benchmarks/space.py [--workers 2]

Runs the real ``tognet`` commands (the venv's CLI, with this checkout on PYTHONPATH) in a temporary folder,
each at two small sizes, and prints per kind of item: the bytes per item (the slope between the two sizes,
so fixed files such as manifests, configs and reports are left out), the fixed overhead, the estimate the
command uses (``tognet/cli``) and their ratio. Bytes are what the files take on the disk (allocated blocks,
``st_blocks * 512``, the directories included), since that is what the free space loses; the files'
apparent sizes are printed beside them. About 3 minutes on 2 cores.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TOGNET = str(Path(sys.executable).parent / "tognet")


def tognet(*args: str) -> None:
    """Run one ``tognet`` command of this checkout; its output is shown only when it fails."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([TOGNET, *args], capture_output=True, text=True, env=env)
    if done.returncode != 0:
        raise SystemExit(f"tognet {' '.join(args)} failed:\n{done.stdout}{done.stderr}")


def usage(folder: Path, skip: tuple[str, ...] = ()) -> tuple[int, int]:
    """(allocated, apparent) bytes of ``folder`` and everything under it, but the entries named in
    ``skip`` directly under it."""
    allocated = apparent = 0
    paths = [folder, *(p for p in folder.rglob("*") if p.relative_to(folder).parts[0] not in skip)]
    for path in paths:
        st = path.lstat()
        allocated += st.st_blocks * 512
        apparent += st.st_size
    return allocated, apparent


@dataclass(frozen=True)
class Kind:
    """One kind of item: how to make ``n`` of them into a folder and the estimate in use."""

    name: str
    sizes: tuple[int, int]
    estimate: float
    make: Callable[[Path, int], None]
    skip: tuple[str, ...] = ()
    per: int = 1  # items per counted unit (e.g. methods per evaluated scene), for the per-item figure


def kinds(root: Path, workers: str) -> list[Kind]:
    from tognet.cli.collect import trial_bytes
    from tognet.cli.data import SYNTHETIC_BYTES
    from tognet.cli.evaluate import SCENE_BYTES
    from tognet.cli.objects import OBJECT_BYTES_BY_KIND
    from tognet.collect.config import CollectConfig
    from tognet.planning.method_names import METHOD_NAMES

    objs = root / "collect-objects"

    def objects(kind: str, split: str = "train") -> Callable[[Path, int], None]:
        return lambda out, n: tognet("objects", "generate", "--kind", kind, "--split", split,
                                     "--count", str(n), "--out", str(out))

    def collect(per_job: int) -> Callable[[Path, int], None]:
        def run(out: Path, n: int) -> None:
            if not objs.exists():
                objects("primitive")(objs, 10)
            config = root / f"collect-{per_job}.json"
            CollectConfig(trials_per_scene=per_job // 4, scenes_per_job=4).save(config)
            tognet("collect", "--task", "hammering", "--objects", str(objs), "--out", str(out), "--episodes",
                   str(n), "--config", str(config), "--workers", workers, "--no-progress")
        return run

    def synthetic(out: Path, n: int) -> None:
        tognet("data", "synthetic", str(out), "--episodes", str(n), "--shard-size", "1024", "--no-progress")

    def evaluate(out: Path, n: int) -> None:
        tognet("evaluate", "--task", "hammering", "--category", "pg-primitive", "--episodes", str(n),
               "--out", str(out), "--no-animations", "--workers", workers, "--no-progress")

    return [
        Kind("object, primitive (objects generate)", (10, 40), OBJECT_BYTES_BY_KIND["primitive"],
             objects("primitive")),
        Kind("object, complex", (5, 20), OBJECT_BYTES_BY_KIND["complex"], objects("complex")),
        Kind("object, realistic (test)", (10, 40), OBJECT_BYTES_BY_KIND["realistic"],
             objects("realistic", "test")),
        Kind("trial (collect, 32 per job: the default)", (64, 256), trial_bytes(32), collect(32)),
        Kind("trial (collect, 4 per job)", (16, 64), trial_bytes(4), collect(4)),
        Kind("synthetic episode (64 x 64 crop)", (1024, 4096), SYNTHETIC_BYTES, synthetic),
        Kind(f"evaluation scene ({len(METHOD_NAMES)} methods, 2 per job)", (4, 12), SCENE_BYTES, evaluate,
             skip=("objects",)),
        Kind("  per method on a scene", (4, 12), SCENE_BYTES / len(METHOD_NAMES), evaluate,
             skip=("objects",), per=len(METHOD_NAMES)),
    ]


def human(n: float) -> str:
    return f"{n:,.0f} B"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", default="2", help="--workers of collect and evaluate")
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT))
    start = time.perf_counter()
    print(f"{platform.node()}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}, "
          f"block size {os.statvfs(tempfile.gettempdir()).f_bsize} B")
    print(f"{'item':<42} {'sizes':>11} {'per item':>10} {'apparent':>10} {'overhead':>10} "
          f"{'estimate':>10} {'est/meas':>8}")
    with tempfile.TemporaryDirectory(prefix="tognet-space-") as tmp:
        root = Path(tmp)
        made: dict[tuple[int, int], tuple[int, int]] = {}
        for kind in kinds(root, args.workers):
            figures = []
            for n in kind.sizes:
                out = root / f"{len(made)}-{n}"
                key = (id(kind.make), n)
                if key not in made:
                    kind.make(out, n)
                    made[key] = usage(out, kind.skip)
                figures.append(made[key])
            (a1, p1), (a2, p2) = figures
            n1, n2 = (n * kind.per for n in kind.sizes)
            slope, slope_apparent = (a2 - a1) / (n2 - n1), (p2 - p1) / (n2 - n1)
            overhead = a1 - slope * n1
            print(f"{kind.name:<42} {f'{kind.sizes[0]}/{kind.sizes[1]}':>11} {human(slope):>10} "
                  f"{human(slope_apparent):>10} {human(overhead):>10} {human(kind.estimate):>10} "
                  f"{kind.estimate / slope:>8.2f}")
    print(f"{time.perf_counter() - start:.0f} s, load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
