"""Objects generated per second for each kind (and meshes imported per second).

Usage: .venv/bin/python benchmarks/bench_objects.py [--count N]
Single process; CoACD may use a second thread. Prints one line per kind.
"""

from __future__ import annotations

import argparse
import platform
import tempfile
import time
from pathlib import Path

import trimesh

from tognet.objects import generate_set, import_meshes
from tognet.objects.generate import realistic_count


def bench_kind(kind: str, count: int, root: Path) -> tuple[float, float]:
    split = "test"
    count = min(count, realistic_count()) if kind == "realistic" else count
    start = time.perf_counter()
    records = generate_set(kind, split, count, root / kind)
    seconds = time.perf_counter() - start
    return len(records) / seconds, seconds


def bench_import(count: int, root: Path) -> tuple[float, float]:
    src = root / "src"
    src.mkdir()
    for i in range(count):
        ring = trimesh.creation.annulus(r_min=0.02 + 0.002 * i, r_max=0.05 + 0.002 * i, height=0.03)
        ring.export(src / f"ring_{i}.stl")
    start = time.perf_counter()
    report = import_meshes(src, root / "imported")
    seconds = time.perf_counter() - start
    assert not report.errors, report.errors
    return len(report.records) / seconds, seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--count", type=int, default=10, help="Objects per kind.")
    args = parser.parse_args()
    print(f"python {platform.python_version()}, {platform.machine()}, count {args.count} per kind")
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for kind in ("primitive", "complex", "realistic"):
            rate, seconds = bench_kind(kind, args.count, root)
            print(f"{kind:<10} {rate:7.2f} objects/s  ({seconds:.2f} s)")
        rate, seconds = bench_import(args.count, root)
        print(f"{'import':<10} {rate:7.2f} meshes/s   ({seconds:.2f} s, non-convex rings)")


if __name__ == "__main__":
    main()
