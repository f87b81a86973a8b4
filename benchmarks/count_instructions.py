"""Instructions per full simulated episode, counted by valgrind (callgrind): a speed figure that does
not depend on how busy or how fast the (virtual) machine is.

    .venv/bin/python benchmarks/count_instructions.py [--episodes 12] [--tasks sweeping hammering]
        [--config SIM.json]

Wall-clock rates on the development VM swing by +-30-50 % within minutes, which hides a 10-20 %
change; an instruction count is the same on every run of the same code and inputs. Each task runs
twice under callgrind, once with no episodes and once with ``--episodes`` (the same mix as
``bench_episodes.py``: the hand-made tool with a lifting grasp twice, then 4 PG-Primitive objects with
the default grasp and a random action), and the difference, divided by the episodes, is printed: the
cost of an episode without start-up, object generation and model building. Needs ``valgrind`` (Debian
package); under it an episode runs ~50x slower, so keep ``--episodes`` small.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

from tognet.tasks import TASK_NAMES


def _worker(task: str, episodes: int, config: Path | None) -> None:
    """Build the simulators, then run ``episodes`` episodes (the part the parent counts)."""
    sys.path.insert(0, str(Path(__file__).parent))
    from bench_episodes import _plan, episode_records

    from tognet.objects.generate import generate_set
    from tognet.objects.handmade import make_test_tools
    from tognet.sim import SimConfig, Simulator

    cfg = SimConfig.load(config) if config else SimConfig()
    with tempfile.TemporaryDirectory() as tmp:
        tools = make_test_tools(tmp + "/tools")
        prims = generate_set("primitive", "train", 4, tmp + "/prim")
        sims = [Simulator(cfg, task, rec) for rec in episode_records(task, tools, prims)]
        for i in range(episodes):
            sim = sims[i % len(sims)]
            sim.reset(i)
            grasp, action = _plan(sim, i)
            sim.execute(grasp, action, i)


def _count(task: str, episodes: int, config: Path | None) -> int:
    """Instructions of one worker run under callgrind."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "callgrind.out"
        cmd = [
            "valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
            sys.executable, __file__, "--worker", task, "--episodes", str(episodes),
        ]  # fmt: skip
        if config:
            cmd += ["--config", str(config)]
        env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONHASHSEED": "0"}
        subprocess.run(cmd, check=True, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        text = out.read_text(errors="replace")
    match = re.search(r"^(?:summary|totals):\s*(\d+)", text, re.MULTILINE)
    if match is None:
        raise RuntimeError(f"no instruction total in callgrind's output for {task}")
    return int(match.group(1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=12, help="episodes counted per task")
    parser.add_argument(
        "--tasks", nargs="+", default=list(TASK_NAMES), choices=TASK_NAMES,
        help="tasks to count",
    )  # fmt: skip
    parser.add_argument("--config", type=Path, help="SimConfig JSON to count instead of the defaults")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        _worker(args.worker, args.episodes, args.config)
        return
    if args.episodes < 1:
        parser.error("--episodes must be at least 1")
    if args.config is not None:
        from tognet.config import ConfigError
        from tognet.sim import SimConfig

        try:
            SimConfig.load(args.config)
        except ConfigError as exc:
            parser.error(str(exc))
    try:
        subprocess.run(["valgrind", "--version"], check=True, capture_output=True)
    except (OSError, subprocess.CalledProcessError):
        parser.error("valgrind not found: install it (Debian: apt-get install valgrind)")
    for task in args.tasks:
        base = _count(task, 0, args.config)
        full = _count(task, args.episodes, args.config)
        per = (full - base) / args.episodes
        print(f"{task:<10} {per / 1e6:8.1f} M instructions per full episode ({args.episodes} episodes)")


if __name__ == "__main__":
    main()
