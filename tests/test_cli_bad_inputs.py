"""Every subcommand against a catalogue of bad inputs (issue 24): each must exit nonzero with one clear line
on stderr, no traceback, and leave nothing written.

The commands run in this process through :func:`tognet.cli.main` with an argv list (as the console script
does), their stdout and stderr captured; an exception other than SystemExit, a printed traceback, a zero
exit status, no error line or more than one, or a file left behind fails the case. The control cases at the
end show that each of those is caught.

Placeholders ``@name`` in a case's arguments are files and folders made once for the module (see
:func:`ws`); ``@out`` is a fresh path of the case's own that must not exist afterwards.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import json
import os
import re
import shlex
import signal
import traceback
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from tognet.cli import main

MODELS = Path(__file__).resolve().parent.parent / "tognet" / "models"
#: The robot extra (robosuite's arm models, mink): without it `plan --robot` says how to install it.
HAVE_ROBOT = all(importlib.util.find_spec(name) is not None for name in ("robosuite", "mink"))

#: A tqdm progress bar's text (what may accompany the error line on stderr).
_BAR = re.compile(r"\d+%\||\|\s*\d+/\d+|\d+/\d+ \[|\?\w+/s\]|it/s\]")


@dataclass
class Outcome:
    code: int | None
    stdout: str
    stderr: str
    crash: str | None  # the traceback of an exception other than SystemExit


class TookTooLong(Exception):
    """A bad input was not refused within the time limit (it started the long work)."""


def _alarm(signum: int, frame: object) -> None:
    raise TookTooLong("still running after the time limit")


def run_cli(argv: list[str], limit: int = 60) -> Outcome:
    """``tognet ARGV`` in this process: exit status, captured output and any escaped exception (a run
    longer than ``limit`` seconds is stopped and counts as one)."""
    out, err = io.StringIO(), io.StringIO()
    code: int | None = None
    crash = None
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(limit)
    pid = os.getpid()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            main(argv)
            code = 0
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        except BaseException:  # noqa: BLE001 (any escaped exception is what the table looks for)
            crash = traceback.format_exc()
        finally:
            if os.getpid() != pid:  # a forked child of the command must never go on running the tests
                os._exit(70)
            signal.alarm(0)
            signal.signal(signal.SIGALRM, previous)
    return Outcome(code, out.getvalue(), err.getvalue(), crash)


def problems(result: Outcome) -> list[str]:
    """What is wrong with a bad input's outcome (empty when it is one clear line and a nonzero exit)."""
    found = []
    if result.crash is not None:
        found.append(f"escaped exception:\n{result.crash}")
    if "Traceback" in result.stdout + result.stderr:
        found.append("a traceback was printed")
    if result.code == 0:
        found.append("exit status 0")
    lines = [seg.strip() for line in result.stderr.split("\n") for seg in line.split("\r")]
    lines = [s for s in lines if s and not _BAR.search(s)]
    errors = [s for s in lines if s.startswith(("error:", "failed "))]
    if len(errors) != 1:
        found.append(f"{len(errors)} error lines")
    others = [s for s in lines if s not in errors]
    if others:
        found.append(f"other lines on stderr: {others[:3]}")
    if errors and len(errors[0]) < 20:
        found.append("the error line says too little")
    return found


def _tree(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


# --- the files the cases use ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    """The workspace: good inputs of every kind, and broken ones."""
    from tognet.data.synthetic import write_synthetic_dataset
    from tognet.geometry import Camera, CameraIntrinsics
    from tognet.grasping.synthetic import render_depth, t_shape
    from tognet.objects import generate_set
    from tognet.planning.camera import save_camera_pose, save_depth_png, save_intrinsics

    root = tmp_path_factory.mktemp("bad-inputs")
    rng = np.random.default_rng(0)
    (root / "afile.txt").write_text("an ordinary file\n")
    for name in ("empty.txt", "empty.npy", "empty.json", "empty.pt", "empty.png"):
        (root / name).write_bytes(b"")
    (root / "adir").mkdir()
    (root / "junkdir").mkdir()
    (root / "junkdir" / "notes.txt").write_text("not a run\n")
    (root / "bad.json").write_text("{not json")
    (root / "binary.json").write_bytes(bytes(range(256)) * 4)  # e.g. a checkpoint given as --config
    (root / "list.json").write_text("[1, 2]")
    for name in ("garbage.pt", "garbage.npy", "garbage.png", "garbage.npz"):
        (root / name).write_bytes(rng.bytes(3000))
    generate_set("primitive", "train", 1, root / "objs_train")
    generate_set("primitive", "test", 1, root / "objs_test")
    (root / "bad_catalog").mkdir()
    (root / "bad_catalog" / "catalog.json").write_text("{oops")
    write_synthetic_dataset(root / "data", task="sweeping", n=40, shard_size=20, n_objects=4)
    (root / "bad_manifest").mkdir()
    (root / "bad_manifest" / "manifest.json").write_text("garbage")

    k = CameraIntrinsics.kinect2()
    camera = Camera.looking_down(k, [0.0, 0.0, 0.7])
    depth = render_depth(camera, t_shape(0.0, 0.0, yaw=0.3))
    np.save(root / "depth.npy", depth)
    np.save(root / "depth_mm.npy", (1000 * np.nan_to_num(depth)).astype(np.float32))  # millimetres as floats
    np.save(root / "depth_3d.npy", np.stack([depth, depth]))
    np.save(root / "depth_small.npy", depth[:100, :100])
    camera.save(root / "camera.json")
    save_depth_png(root / "d.png", depth)
    from PIL import Image

    for name, per_metre in (("d_cm.png", 100), ("d_tenth_mm.png", 10_000)):  # 16-bit PNGs in other units
        Image.fromarray(np.rint(per_metre * np.nan_to_num(depth)).astype(np.uint16)).save(root / name)
    np.save(root / "depth_cm.npy", (100 * np.nan_to_num(depth)).astype(np.float32))  # centimetres as floats
    save_intrinsics(root / "d.intrinsics.json", k)
    save_camera_pose(root / "d.pose.json", camera.pose)
    base = json.loads((root / "d.intrinsics.json").read_text())
    for name, change in (("f1", {"fx": 1.0, "fy": 1.0}), ("f1e9", {"fx": 1e9, "fy": 1e9}),
                         ("neg", {"fx": -365.0}), ("wide", {"width": 640, "height": 480, "cx": 320.0,
                                                            "cy": 240.0})):
        (root / f"intr_{name}.json").write_text(json.dumps({**base, **change}))
    bad_camera = {**json.loads((root / "camera.json").read_text()), "fx": 1.0, "fy": 1.0}
    (root / "camera_f1.json").write_text(json.dumps(bad_camera))
    (root / "pose_bad.json").write_text(json.dumps({"world_from_camera": [[2, 0, 0, 0], [0, 1, 0, 0],
                                                                          [0, 0, 1, 0], [0, 0, 0, 1]]}))

    def config(name, data):
        (root / name).write_text(json.dumps(data))

    config("base_far.json", {"position": [0.0, -3.0, 0.0], "yaw": 1.57})
    config("base_fields.json", {"pos": [0.0, -0.6, 0.0], "yaw": 1.57})
    config("base_short.json", {"position": [0.0, -0.6], "yaw": 1.57})
    config("base_mm.json", {"position": [0.0, -600.0, 0.0], "yaw": 1.57})
    config("base_degrees.json", {"position": [-0.2, 0.6, 0.0], "yaw": -90})
    (root / "base_nan.json").write_text('{"position": [0.0, NaN, 0.0], "yaw": 1.57}')
    config("sim_dt.json", {"physics": {"timestep": -0.01}})
    config("sim_dt0.json", {"physics": {"timestep": 0.0}})
    config("sim_opening.json", {"gripper": {"max_opening": -0.08}})
    config("sim_fx1.json", {"camera": {"fx": 1.0, "fy": 1.0}})
    config("sim_fx1e9.json", {"camera": {"fx": 1e9, "fy": 1e9}})
    config("sim_size.json", {"camera": {"width": 0}})
    config("sim_gravity.json", {"physics": {"gravity": -9.81}})
    config("sim_typo.json", {"physics": {"timestpe": 0.002}})
    config("gen_variant.json", {"primitive": {"ranges": {"variants": [{"name": "x", "part": "C",
                                                                        "probability": 0.5}]}}})
    config("gen_variant_sum.json", {"primitive": {"ranges": {"variants": [
        {"name": "a", "part": "B", "probability": 0.7}, {"name": "b", "part": "B", "probability": 0.6}]}}})
    config("train_lr.json", {"lr": -0.001})
    config("train_batch.json", {"batch_size": 0})
    config("train_val.json", {"val_fraction": 1.5})
    config("train_seed.json", {"seed": -3})
    config("train_rank.json", {"loss": {"weight_rank": -1.0}})
    config("train_tilt.json", {"loss": {"max_lift_tilt": -0.2}})
    config("collect_trials.json", {"trials_per_scene": 0})
    config("collect_seed.json", {"seed": -1})
    config("eval_scenes.json", {"scenes_per_job": 0})
    config("gen_cfg.json", {"config_type": "SimConfig"})
    config("plan_cfg.json", {"top": -1})
    config("preset_huge.json", {"name": "huge", "rounds": [{"episodes": 1_000_000_000}]})
    config("preset_objects.json", {"name": "neg", "objects": {"primitive": -5, "complex": 0}})
    config("preset_epochs.json", {"name": "neg", "rounds": [{"episodes": 10, "epochs": 0}]})

    src = root / "meshes_garbage"
    src.mkdir()
    (src / "tool.stl").write_bytes(rng.bytes(3000))
    (root / "meshes_empty").mkdir()
    (root / "meshes_txt").mkdir()
    (root / "meshes_txt" / "readme.txt").write_text("no meshes here")
    import trimesh

    (root / "meshes_mm").mkdir()
    trimesh.creation.box((100.0, 30.0, 20.0)).export(root / "meshes_mm" / "box.obj")  # millimetres
    trimesh.creation.box((0.1, 0.03, 0.02)).export(root / "box.obj")
    (root / "empty.obj").write_bytes(b"")
    return root


@dataclass(frozen=True)
class Case:
    args: str
    expect: str = ""  # a piece of the error line (lower case compared), when known
    report: bool = False  # the command prints its per-file report on stdout (objects import)

    def argv(self, ws: Path, out: Path) -> list[str]:
        names = {"out": str(out), "ws": str(ws), "models": str(MODELS)}

        def fill(match: re.Match[str]) -> str:
            name = match.group(1)
            return names.get(name, str(ws / name))

        return [re.sub(r"@([\w.]+)", fill, a) for a in shlex.split(self.args)]


G = "grasps --depth @depth.npy --camera @camera.json"
P = "plan --depth @d.png --intrinsics @d.intrinsics.json --task hammering"
PP = f"{P} --camera-pose @d.pose.json"
T = "train --data @data --task sweeping"
C = "collect --task hammering --objects @objs_train --out @out"
CE = f"{C} --policy epsilon_greedy --task-model"
E = "evaluate --task hammering --episodes 1 --category pg-primitive --out @out"
S = "sim --task hammering"
BIG = "1000000000"

CASES: dict[str, Case] = {
    # the top level
    "no-such-command": Case("bogus", "no such command"),
    "no-such-option": Case("--bogus", "no such option"),
    "subcommand-typo": Case("objects genrate", "no such command"),

    # objects generate
    "gen-out-under-file": Case("objects generate --kind primitive --count 1 --out @afile.txt/o",
                               "is a file, not a folder"),
    "gen-out-sys": Case("objects generate --kind primitive --count 1 --out /sys/tognet-o", "/sys"),
    "gen-out-proc": Case("objects generate --kind primitive --count 1 --out /proc/tognet-o", "/proc"),
    "gen-out-file": Case("objects generate --kind primitive --count 1 --out @afile.txt", "not a folder"),
    "gen-count-0": Case("objects generate --kind primitive --count 0 --out @out", "--count"),
    "gen-count-huge": Case(f"objects generate --kind primitive --count {BIG} --out @out", "--count"),
    "gen-kind": Case("objects generate --kind spoon --count 1 --out @out", "--kind"),
    "gen-kind-missing": Case("objects generate --count 1 --out @out", "--kind"),
    "gen-split": Case("objects generate --kind primitive --split val --count 1 --out @out", "--split"),
    "gen-realistic-train": Case("objects generate --kind realistic --split train --count 1 --out @out",
                                "realistic"),
    "gen-config-missing": Case("objects generate --kind primitive --count 1 --out @out --config @nope.json",
                               "not found"),
    "gen-config-bad": Case("objects generate --kind primitive --count 1 --out @out --config @bad.json",
                           "not valid json"),
    "gen-config-empty": Case("objects generate --kind primitive --count 1 --out @out --config @empty.json",
                             "empty.json"),
    "gen-profile-typo": Case("objects generate --kind primitive --count 1 --out @out --config wdie",
                             "unknown generator profile 'wdie'"),
    "gen-variant-part": Case("objects generate --kind primitive --count 1 --out @out --config "
                             "@gen_variant.json", "part"),
    "gen-variant-sum": Case("objects generate --kind primitive --count 1 --out @out --config "
                            "@gen_variant_sum.json", "more than 1"),
    "gen-config-dir": Case("objects generate --kind primitive --count 1 --out @out --config @adir", "adir"),
    "gen-config-other": Case("objects generate --kind primitive --count 1 --out @out --config @gen_cfg.json",
                             "simconfig"),
    "gen-start-neg": Case("objects generate --kind primitive --count 1 --out @out --start -1", "--start"),
    "gen-workers-0": Case("objects generate --kind primitive --count 1 --out @out --workers 0", "--workers"),
    "gen-count-text": Case("objects generate --kind primitive --count many --out @out", "--count"),

    # objects import
    "imp-src-missing": Case("objects import @nope --out @out", "not found"),
    "imp-src-empty-dir": Case("objects import @meshes_empty --out @out", "meshes_empty"),
    "imp-src-no-meshes": Case("objects import @meshes_txt --out @out", "meshes_txt"),
    "imp-src-txt": Case("objects import @afile.txt --out @out", "afile.txt"),
    "imp-src-empty-file": Case("objects import @empty.obj --out @out", "empty", report=True),
    "imp-src-garbage": Case("objects import @meshes_garbage --out @out", "tool.stl", report=True),
    "imp-mm-units": Case("objects import @meshes_mm --out @out", "--scale", report=True),
    "imp-out-proc": Case("objects import @box.obj --out /proc/tognet-x", "/proc/tognet-x"),
    "imp-out-sys": Case("objects import @box.obj --out /sys/tognet-x", "/sys/tognet-x"),
    "imp-out-under-file": Case("objects import @box.obj --out @afile.txt/x", "is a file, not a folder"),
    "imp-out-file": Case("objects import @box.obj --out @afile.txt", "not a folder"),
    "imp-scale-0": Case("objects import @box.obj --out @out --scale 0", "--scale"),
    "imp-scale-neg": Case("objects import @box.obj --out @out --scale -1", "--scale"),
    "imp-density-0": Case("objects import @box.obj --out @out --density 0", "--density"),
    "imp-friction-neg": Case("objects import @box.obj --out @out --friction -1", "--friction"),
    "imp-out-missing": Case("objects import @box.obj", "--out"),

    # objects sheet / list / stats
    "sheet-missing": Case("objects sheet @nope --out @out/s.png", "nope"),
    "sheet-file": Case("objects sheet @afile.txt --out @out/s.png", "afile.txt"),
    "sheet-empty-dir": Case("objects sheet @adir --out @out/s.png", "catalog"),
    "sheet-bad-catalog": Case("objects sheet @bad_catalog --out @out/s.png", "catalog.json"),
    "sheet-out-under-file": Case("objects sheet @objs_train --out @afile.txt/s.png",
                                 "is a file, not a folder"),
    "sheet-out-sys": Case("objects sheet @objs_train --out /sys/tognet-s.png", "/sys"),
    "sheet-out-dir": Case("objects sheet @objs_train --out @adir", "folder"),
    "sheet-out-suffix": Case("objects sheet @objs_train --out @out/s.txt", ".png"),
    "sheet-max-0": Case("objects sheet @objs_train --out @out/s.png --max 0", "--max"),
    "list-missing": Case("objects list @nope", "nope"),
    "list-file": Case("objects list @afile.txt", "afile.txt"),
    "list-empty-dir": Case("objects list @adir", "catalog"),
    "list-bad-catalog": Case("objects list @bad_catalog", "catalog.json"),
    "list-dataset": Case("objects list @data", "catalog"),
    "stats-missing": Case("objects stats @nope", "nope"),
    "stats-empty-dir": Case("objects stats @adir", "catalog"),
    "stats-bad-catalog": Case("objects stats @bad_catalog", "catalog.json"),
    "stats-opening-0": Case("objects stats @objs_train --opening 0", "--opening"),
    "stats-opening-cm": Case("objects stats @objs_train --opening 8", "--opening"),

    # sim
    "sim-task": Case("sim --task juggling", "juggling"),
    "sim-robot-unknown": Case(f"{S} --robot ur5", "floating, sawyer, panda"),
    "sim-robot-capitalised": Case(f"{S} --robot Sawyer", "'sawyer'"),
    "sim-object": Case(f"{S} --object spoon", "spoon"),
    "sim-objects-missing": Case(f"{S} --objects @nope --object x", "nope"),
    "sim-objects-file": Case(f"{S} --objects @afile.txt --object x", "afile.txt"),
    "sim-objects-no-id": Case(f"{S} --objects @objs_train", "--object"),
    "sim-objects-bad-id": Case(f"{S} --objects @objs_train --object spoon", "spoon"),
    "sim-objects-bad-catalog": Case(f"{S} --objects @bad_catalog --object x", "catalog.json"),
    "sim-grasp-nan": Case(f"{S} --grasp nan 0 0 0", "--grasp"),
    "sim-action-inf": Case(f"{S} --action inf 0 0 0", "--action"),
    "sim-grasp-short": Case(f"{S} --grasp 1 2", "--grasp"),
    "sim-grasping-action": Case("sim --task grasping --action 0 0 0 0", "--action"),
    "sim-gif-under-file": Case(f"{S} --gif @afile.txt/x.gif", "is a file, not a folder"),
    "sim-gif-sys": Case(f"{S} --gif /sys/tognet-x.gif", "/sys"),
    "sim-gif-suffix": Case(f"{S} --gif @out/x.png", ".gif"),
    "sim-gif-dir": Case(f"{S} --gif @adir", "--gif"),
    "sim-depth-under-file": Case(f"{S} --depth-png @afile.txt/d.png", "is a file, not a folder"),
    "sim-depth-sys": Case(f"{S} --depth-png /sys/tognet-d.png", "/sys"),
    "sim-depth-suffix": Case(f"{S} --depth-png @out/d.jpg", ".png"),
    "sim-config-missing": Case(f"{S} --config @nope.json", "not found"),
    "sim-config-bad": Case(f"{S} --config @bad.json", "not valid json"),
    "sim-config-list": Case(f"{S} --config @list.json", "list.json"),
    "sim-config-typo": Case(f"{S} --config @sim_typo.json", "timestpe"),
    "sim-timestep-neg": Case(f"{S} --config @sim_dt.json", "physics.timestep"),
    "sim-timestep-0": Case(f"{S} --config @sim_dt0.json", "physics.timestep"),
    "sim-opening-neg": Case(f"{S} --config @sim_opening.json", "gripper.max_opening"),
    "sim-focal-1": Case(f"{S} --config @sim_fx1.json", "camera.fx"),
    "sim-focal-1e9": Case(f"{S} --config @sim_fx1e9.json", "camera.fx"),
    "sim-width-0": Case(f"{S} --config @sim_size.json", "camera.width"),
    "sim-gravity-neg": Case(f"{S} --config @sim_gravity.json", "physics.gravity"),
    "sim-seed-neg": Case(f"{S} --seed -1", "--seed"),
    "sim-trial-seed-neg": Case(f"{S} --trial-seed -5", "--trial-seed"),

    # grasps
    "grasps-depth-missing": Case("grasps --depth @nope.npy --camera @camera.json --out @out/o.png",
                                 "nope.npy"),
    "grasps-depth-dir": Case("grasps --depth @adir --camera @camera.json --out @out/o.png", "adir"),
    "grasps-depth-empty": Case("grasps --depth @empty.npy --camera @camera.json --out @out/o.png", "empty"),
    "grasps-depth-garbage": Case("grasps --depth @garbage.npy --camera @camera.json --out @out/o.png",
                                 "garbage.npy"),
    "grasps-depth-png-garbage": Case("grasps --depth @garbage.png --camera @camera.json --out @out/o.png",
                                     "garbage.png"),
    "grasps-depth-txt": Case("grasps --depth @afile.txt --camera @camera.json --out @out/o.png", "afile.txt"),
    "grasps-depth-mm": Case("grasps --depth @depth_mm.npy --camera @camera.json --out @out/o.png",
                            "millimetres"),
    "grasps-depth-3d": Case("grasps --depth @depth_3d.npy --camera @camera.json --out @out/o.png",
                            "depth_3d.npy"),
    "grasps-depth-size": Case("grasps --depth @depth_small.npy --camera @camera.json --out @out/o.png",
                              "depth_small.npy"),
    "grasps-camera-missing": Case("grasps --depth @depth.npy --camera @nope.json --out @out/o.png",
                                  "nope.json"),
    "grasps-camera-bad": Case("grasps --depth @depth.npy --camera @bad.json --out @out/o.png", "bad.json"),
    "grasps-camera-empty": Case("grasps --depth @depth.npy --camera @empty.json --out @out/o.png",
                                "empty.json"),
    "grasps-camera-focal-1": Case("grasps --depth @depth.npy --camera @camera_f1.json --out @out/o.png",
                                  "fx"),
    "grasps-intrinsics-no-pose": Case("grasps --depth @d.png --camera @d.intrinsics.json --out @out/o.png",
                                      "--camera-pose"),
    "grasps-pose-bad": Case("grasps --depth @d.png --camera @d.intrinsics.json --camera-pose @pose_bad.json "
                            "--out @out/o.png", "pose_bad.json"),
    "grasps-out-under-file": Case(f"{G} --out @afile.txt/o.png", "is a file, not a folder"),
    "grasps-out-sys": Case(f"{G} --out /sys/tognet-o.png", "/sys"),
    "grasps-out-dir": Case(f"{G} --out @adir", "folder"),
    "grasps-out-suffix": Case(f"{G} --out @out/o.jpg", ".png"),
    "grasps-max-0": Case(f"{G} --out @out/o.png --max 0", "--max"),
    "grasps-seed-neg": Case(f"{G} --out @out/o.png --seed -1", "--seed"),
    "grasps-checkpoint-missing": Case(f"{G} --out @out/o.png --checkpoint @nope.pt", "nope.pt"),
    "grasps-checkpoint-garbage": Case(f"{G} --out @out/o.png --checkpoint @garbage.pt", "garbage.pt"),
    "grasps-checkpoint-empty": Case(f"{G} --out @out/o.png --checkpoint @empty.pt", "empty.pt"),
    "grasps-checkpoint-dir": Case(f"{G} --out @out/o.png --checkpoint @adir", "adir"),
    "grasps-checkpoint-json": Case(f"{G} --out @out/o.png --checkpoint @models/grasping.json",
                                   "grasping.json"),
    "grasps-cem-no-model": Case(f"{G} --out @out/o.png --cem", "--cem"),
    "grasps-config-range": Case(f"{G} --out @out/o.png --config '{{\"max_width\": -1}}'", "max_width"),
    "grasps-config-typo": Case(f"{G} --out @out/o.png --config '{{\"max_widht\": 0.06}}'", "max_widht"),
    "grasps-config-json": Case(f"{G} --out @out/o.png --config '{{oops'", "json"),
    "grasps-config-missing": Case(f"{G} --out @out/o.png --config @nope.json", "nope.json"),
    "grasps-config-mm": Case(f"{G} --out @out/o.png --config '{{\"max_width\": 80}}'", "max_width"),

    # train
    "train-data-missing": Case("train --data @nope --task sweeping --out @out", "nope"),
    "train-data-file": Case("train --data @afile.txt --task sweeping --out @out", "afile.txt"),
    "train-data-empty-dir": Case("train --data @adir --task sweeping --out @out", "adir"),
    "train-data-bad-manifest": Case("train --data @bad_manifest --task sweeping --out @out", "manifest"),
    "train-task-mismatch": Case("train --data @data --task hammering --out @out", "sweeping"),
    "train-data-twice": Case("train --data @data --data @data --task sweeping --out @out", "twice"),
    "train-task-unknown": Case("train --data @data --task juggling --out @out", "juggling"),
    "train-out-file": Case(f"{T} --out @afile.txt", "not a folder"),
    "train-out-under-file": Case(f"{T} --out @afile.txt/t", "is a file, not a folder"),
    "train-out-sys": Case(f"{T} --out /sys/tognet-t", "/sys"),
    "train-config-missing": Case(f"{T} --out @out --config @nope.json", "not found"),
    "train-config-bad": Case(f"{T} --out @out --config @bad.json", "not valid json"),
    "train-config-binary": Case(f"{T} --out @out --config @binary.json", "binary.json: not a text file"),
    "collect-config-binary": Case(f"{C} --config @binary.json", "binary.json: not a text file"),
    "train-lr-neg": Case(f"{T} --out @out --config @train_lr.json", "lr must be 0 or more"),
    "train-batch-0": Case(f"{T} --out @out --config @train_batch.json", "batch_size"),
    "train-val-fraction": Case(f"{T} --out @out --config @train_val.json", "val_fraction"),
    "train-config-seed-neg": Case(f"{T} --out @out --config @train_seed.json", "seed"),
    "train-config-rank-neg": Case(f"{T} --out @out --config @train_rank.json", "weight_rank"),
    "train-config-tilt-neg": Case(f"{T} --out @out --config @train_tilt.json", "max_lift_tilt"),
    "train-epochs-0": Case(f"{T} --out @out --epochs 0", "--epochs"),
    "train-seed-neg": Case(f"{T} --out @out --seed -1", "--seed"),
    "train-device": Case(f"{T} --out @out --device tpu", "tpu"),
    "train-resume-nothing": Case(f"{T} --out @out --resume", "resume"),
    "train-resume-junk": Case(f"{T} --out @junkdir --resume", "resume"),
    "train-init-missing": Case(f"{T} --out @out --init-from @nope.pt", "nope.pt"),
    "train-init-garbage": Case(f"{T} --out @out --init-from @garbage.pt", "garbage.pt"),
    "train-init-wrong-task": Case(f"{T} --out @out --init-from @models/hammering.pt", "hammering"),
    "train-init-grasp-only": Case(f"{T} --out @out --init-from @models/grasping.pt", "grasping"),

    # collect
    "collect-task": Case("collect --task juggling --objects @objs_train --out @out", "juggling"),
    "collect-robot-unknown": Case("collect --task hammering --objects @objs_train --out @out --robot ur5",
                                  "--robot"),
    "collect-objects-missing": Case("collect --task hammering --objects @nope --out @out", "nope"),
    "collect-objects-file": Case("collect --task hammering --objects @afile.txt --out @out", "afile.txt"),
    "collect-objects-empty": Case("collect --task hammering --objects @adir --out @out", "catalog"),
    "collect-objects-bad": Case("collect --task hammering --objects @bad_catalog --out @out", "catalog.json"),
    "collect-out-file": Case("collect --task hammering --objects @objs_train --out @afile.txt",
                             "not a folder"),
    "collect-out-under-file": Case("collect --task hammering --objects @objs_train --out @afile.txt/c",
                                   "is a file, not a folder"),
    "collect-out-sys": Case("collect --task hammering --objects @objs_train --out /sys/tognet-c", "/sys"),
    "collect-out-dataset-other-task": Case("collect --task hammering --objects @objs_train --out @data",
                                           "sweeping"),
    "collect-episodes-0": Case(f"{C} --episodes 0", "--episodes"),
    "collect-episodes-huge": Case(f"{C} --episodes {BIG}", "--episodes"),
    "collect-policy": Case(f"{C} --policy greedy", "greedy"),
    "collect-eps-no-model": Case(f"{C} --policy epsilon_greedy", "--task-model"),
    "collect-candidates-no-model": Case(f"{C} --policy search_candidates", "--task-model"),
    "collect-candidates-not-search": Case(f"{C} --policy search_candidates --task-model @models/hammering.pt",
                                          "does not see the action"),
    "collect-model-missing": Case(f"{CE} @nope.pt", "nope.pt"),
    "collect-model-garbage": Case(f"{CE} @garbage.pt", "garbage.pt"),
    "collect-model-wrong-task": Case(f"{CE} @models/sweeping.pt", "sweeping"),
    "collect-model-grasp-only": Case(f"{CE} @models/grasping.pt", "grasp"),
    "collect-model-search-wrong-task": Case(f"{CE} @models/pulling_search.pt", "pulling"),
    "collect-grasp-model-task": Case(f"{C} --grasp-model @models/hammering.pt", "--grasp-model"),
    "collect-grasp-model-garbage": Case(f"{C} --grasp-model @garbage.pt", "garbage.pt"),
    "collect-grasping-task-model": Case("collect --task grasping --objects @objs_train --out @out --policy "
                                        "epsilon_greedy --task-model @models/hammering.pt", "hammering"),
    "collect-config-missing": Case(f"{C} --config @nope.json", "not found"),
    "collect-config-trials": Case(f"{C} --config @collect_trials.json", "trials_per_scene"),
    "collect-config-seed": Case(f"{C} --config @collect_seed.json", "seed"),
    "collect-round-neg": Case(f"{C} --round -1", "--round"),
    "collect-workers-neg": Case(f"{C} --workers -1", "--workers"),

    # pipeline
    "pipe-task": Case("pipeline --task juggling --out @out", "juggling"),
    "pipe-preset": Case("pipeline --task hammering --preset fast --out @out", "fast"),
    "pipe-preset-typo": Case("pipeline --task hammering --preset medium-wdie --out @out", "medium-wide"),
    "pipe-preset-bad": Case("pipeline --task hammering --preset @bad.json --out @out", "bad.json"),
    "pipe-preset-missing": Case("pipeline --task hammering --preset @nope.json --out @out", "nope.json"),
    "pipe-preset-huge": Case("pipeline --task hammering --preset @preset_huge.json --out @out", "trials"),
    "pipe-preset-objects-neg": Case("pipeline --task hammering --preset @preset_objects.json --out @out",
                                    "objects"),
    "pipe-preset-epochs-0": Case("pipeline --task hammering --preset @preset_epochs.json --out @out",
                                 "epochs"),
    "pipe-out-file": Case("pipeline --task hammering --preset ci --out @afile.txt", "not a folder"),
    "pipe-out-under-file": Case("pipeline --task hammering --preset ci --out @afile.txt/r",
                                "is a file, not a folder"),
    "pipe-out-sys": Case("pipeline --task hammering --preset ci --out /sys/tognet-r", "/sys"),
    "pipe-resume-nothing": Case("pipeline --task hammering --preset ci --out @out --resume", "resume"),
    "pipe-resume-junk": Case("pipeline --task hammering --preset ci --out @junkdir --resume", "resume"),
    "pipe-workers-neg": Case("pipeline --task hammering --preset ci --out @out --workers -1", "--workers"),

    # export-models
    "export-run-missing": Case("export-models @nope --out @out", "nope"),
    "export-run-file": Case("export-models @afile.txt --out @out", "afile.txt"),
    "export-run-empty": Case("export-models @adir --out @out", "summary.json"),
    "export-out-file": Case("export-models @adir --out @afile.txt", "not a folder"),
    "export-out-under-file": Case("export-models @adir --out @afile.txt/m", "is a file, not a folder"),
    "export-out-sys": Case("export-models @adir --out /sys/tognet-m", "/sys"),

    # plan
    "plan-depth-missing": Case("plan --depth @nope.png --intrinsics @d.intrinsics.json --task hammering",
                               "nope.png"),
    "plan-depth-dir": Case("plan --depth @adir --intrinsics @d.intrinsics.json --task hammering", "adir"),
    "plan-depth-empty": Case("plan --depth @empty.png --intrinsics @d.intrinsics.json --task hammering",
                             "empty.png"),
    "plan-depth-garbage": Case("plan --depth @garbage.png --intrinsics @d.intrinsics.json --task hammering",
                               "garbage.png"),
    "plan-depth-txt": Case("plan --depth @afile.txt --intrinsics @d.intrinsics.json --task hammering",
                           "afile.txt"),
    "plan-depth-npz-garbage": Case("plan --depth @garbage.npz --intrinsics @d.intrinsics.json --task "
                                   "hammering", "garbage.npz"),
    "plan-depth-mm": Case("plan --depth @depth_mm.npy --intrinsics @d.intrinsics.json --task hammering",
                          "look like millimetres (the table would be 0.70 m away): divide by 1000 to metres"),
    "plan-depth-cm-float": Case("plan --depth @depth_cm.npy --intrinsics @d.intrinsics.json --task "
                                "hammering", "look like centimetres (the table would be 0.70 m away): divide "
                                "by 100 to metres"),
    "plan-depth-cm-png": Case("plan --depth @d_cm.png --intrinsics @d.intrinsics.json --task hammering",
                              "look like centimetres (the table would be 0.70 m away): multiply by 10 to "
                              "millimetres"),
    "plan-depth-tenth-mm-png": Case("plan --depth @d_tenth_mm.png --intrinsics @d.intrinsics.json --task "
                                    "hammering", "look like 0.1 mm (the table would be 0.70 m away): divide "
                                    "by 10 to millimetres"),
    "plan-intrinsics-missing": Case("plan --depth @d.png --intrinsics @nope.json --task hammering",
                                    "nope.json"),
    "plan-intrinsics-bad": Case("plan --depth @d.png --intrinsics @bad.json --task hammering", "bad.json"),
    "plan-intrinsics-empty": Case("plan --depth @d.png --intrinsics @empty.json --task hammering",
                                  "empty.json"),
    "plan-focal-1": Case("plan --depth @d.png --intrinsics @intr_f1.json --task hammering", "fx"),
    "plan-focal-1e9": Case("plan --depth @d.png --intrinsics @intr_f1e9.json --task hammering", "fx"),
    "plan-focal-neg": Case("plan --depth @d.png --intrinsics @intr_neg.json --task hammering", "fx"),
    "plan-size-mismatch": Case("plan --depth @d.png --intrinsics @intr_wide.json --task hammering", "640"),
    "plan-pose-bad": Case(f"{P} --camera-pose @pose_bad.json", "pose_bad.json"),
    "plan-pose-missing": Case(f"{P} --camera-pose @nope.json", "nope.json"),
    "plan-task": Case("plan --depth @d.png --intrinsics @d.intrinsics.json --task juggling", "juggling"),
    "plan-checkpoint-wrong-task": Case(f"{PP} --checkpoint @models/sweeping.pt", "sweeping"),
    "plan-checkpoint-grasp-only": Case(f"{PP} --checkpoint @models/grasping.pt", "grasping"),
    "plan-checkpoint-garbage": Case(f"{PP} --checkpoint @garbage.pt", "garbage.pt"),
    "plan-checkpoint-missing": Case(f"{PP} --checkpoint @nope.pt", "nope.pt"),
    "plan-out-under-file": Case(f"{PP} --out @afile.txt/p.json", "is a file, not a folder"),
    "plan-out-sys": Case(f"{PP} --out /sys/tognet-p.json", "/sys"),
    "plan-out-suffix": Case(f"{PP} --out @out/p.txt", ".json"),
    "plan-out-dir": Case(f"{PP} --out @adir", "folder"),
    "plan-overlay-sys": Case(f"{PP} --overlay /sys/tognet-o.png", "/sys"),
    "plan-overlay-suffix": Case(f"{PP} --overlay @out/o.jpg", ".png"),
    "plan-reference-nan": Case(f"{PP} --reference nan 0 0", "--reference"),
    "plan-reference-far": Case(f"{PP} --reference 100 0 0.05",
                               "reference point 100 0 0.05 m (world frame) is 99.5"),
    "plan-reference-far-table": Case(f"{P} --reference 0 -100 0.05",
                                     "(table frame) is 99.60 m from the table"),
    "plan-reference-under-table": Case(f"{PP} --reference 0.2 0 -0.5", "0 -0.5 m (world frame) is 0.500 m "
                                       "below the table top"),
    "plan-reference-high": Case(f"{PP} --reference 0.2 0 3", "3.000 m above the table top"),
    "plan-reference-out-of-reach": Case(f"{PP} --robot sawyer --reference 1.5 0 0.05",
                                        "beyond the sawyer's reach" if HAVE_ROBOT else "tognet[robot]"),
    "plan-robot-unknown": Case(f"{PP} --robot ur5", "ur5"),
    "plan-base-pose-without-robot": Case(f"{PP} --base-pose @base_far.json", "--robot"),
    "plan-base-pose-missing": Case(f"{PP} --robot sawyer --base-pose @nope.json", "nope.json"),
    "plan-base-pose-dir": Case(f"{PP} --robot sawyer --base-pose @adir", "adir"),
    "plan-base-pose-not-json": Case(f"{PP} --robot sawyer --base-pose @bad.json", "not valid json"),
    "plan-base-pose-empty": Case(f"{PP} --robot sawyer --base-pose @empty.json", "empty.json"),
    "plan-base-pose-list": Case(f"{PP} --robot sawyer --base-pose @list.json", "json object"),
    "plan-base-pose-fields": Case(f"{PP} --robot sawyer --base-pose @base_fields.json", "missing position"),
    "plan-base-pose-short": Case(f"{PP} --robot panda --base-pose @base_short.json", "3 numbers"),
    "plan-base-pose-nan": Case(f"{PP} --robot sawyer --base-pose @base_nan.json", "finite"),
    "plan-base-pose-mm": Case(f"{PP} --robot sawyer --base-pose @base_mm.json", "metres"),
    "plan-base-pose-degrees": Case(f"{PP} --robot sawyer --base-pose @base_degrees.json", "degrees?"),
    "plan-base-pose-floating": Case(f"{PP} --robot floating --base-pose @base_far.json", "--robot"),
    "plan-robot-out-of-reach": Case(f"{PP} --robot sawyer --base-pose @base_far.json",
                                    "no grasp within the sawyer's reach" if HAVE_ROBOT else "tognet[robot]"),
    "plan-top-neg": Case(f"{PP} --top -1", "--top"),
    "plan-seed-neg": Case(f"{PP} --seed -1", "--seed"),
    "plan-config-missing": Case(f"{PP} --config @nope.json", "nope.json"),
    "plan-config-bad": Case(f"{PP} --config @bad.json", "bad.json"),
    "plan-config-range": Case(f"{PP} --config @plan_cfg.json", "top"),
    "plan-method-oracle": Case(f"{PP} --method Oracle", "needs the simulator"),
    "plan-method-unknown": Case(f"{PP} --method TOG-Nett", "tog-nett"),
    "plan-method-wrong-model": Case(f"{PP} --method TOG-Net --checkpoint @models/hammering_search.pt",
                                    "tog-net needs a task's tog-net model"),
    "plan-depth-and-bag": Case(f"{PP} --bag @d.png --depth-topic /d", "one of them"),
    "plan-bag-no-topic": Case("plan --bag @adir --task hammering", "--depth-topic"),
    "plan-bag-missing": Case("plan --bag @nope.bag --depth-topic /d --info-topic /i --task hammering",
                             "nope.bag"),
    "plan-bag-not-a-bag": Case("plan --bag @afile.txt --depth-topic /d --info-topic /i --task hammering",
                               "afile.txt"),
    "plan-topic-without-bag": Case(f"{PP} --depth-topic /d", "--bag"),
    "plan-rerun-suffix": Case(f"{PP} --rerun @out/p.txt", ".rrd"),

    # serve
    "serve-port": Case("serve --port 70000", "--port"),
    "serve-threads": Case("serve --threads -1", "--threads"),
    "serve-preload": Case("serve --preload juggling", "juggling"),

    # evaluate
    "eval-task": Case("evaluate --task juggling --episodes 1 --out @out", "juggling"),
    "eval-methods": Case(f"{E} --methods TOG-Nett", "tog-nett"),
    "eval-robot-unknown": Case(f"{E} --robot kuka", "kuka"),
    "eval-task-model-other-task": Case(f"{E} --task-model sweeping=tognet/models/sweeping.pt",
                                       "not sweeping"),
    "eval-task-model-twice": Case(f"{E} --task-model hammering=tognet/models/hammering.pt "
                                  "--task-model hammering=tognet/models/hammering.pt", "given twice"),
    "eval-category": Case("evaluate --task hammering --episodes 1 --category pg-fancy --out @out",
                          "pg-fancy"),
    "eval-objects-missing": Case("evaluate --task hammering --episodes 1 --objects @nope --out @out", "nope"),
    "eval-objects-train": Case("evaluate --task hammering --episodes 1 --objects @objs_train --out @out",
                               "training objects"),
    "eval-objects-file": Case("evaluate --task hammering --episodes 1 --objects @afile.txt --out @out",
                              "afile.txt"),
    "eval-episodes-0": Case("evaluate --task hammering --episodes 0 --out @out", "--episodes"),
    "eval-episodes-huge": Case(f"evaluate --task hammering --episodes {BIG} --out @out", "--episodes"),
    "eval-out-file": Case("evaluate --task hammering --episodes 1 --out @afile.txt", "not a folder"),
    "eval-out-under-file": Case("evaluate --task hammering --episodes 1 --out @afile.txt/e",
                                "is a file, not a folder"),
    "eval-out-sys": Case("evaluate --task hammering --episodes 1 --out /sys/tognet-e", "/sys"),
    "eval-grasp-model-missing": Case(f"{E} --grasp-model @nope.pt", "nope.pt"),
    "eval-grasp-model-task": Case(f"{E} --grasp-model @models/hammering.pt", "hammering"),
    "eval-hammering-model-sweeping": Case(f"{E} --task-model hammering=@models/sweeping.pt", "sweeping"),
    "eval-task-model-search-head": Case(f"{E} --task-model hammering=@models/hammering_search.pt",
                                        "hammering_search="),
    "eval-task-model-syntax": Case(f"{E} --task-model hammering", "name=path"),
    "eval-task-model-task": Case(f"{E} --task-model juggling=@models/hammering.pt", "juggling"),
    "eval-task-model-grasp": Case(f"{E} --task-model hammering=@models/grasping.pt", "grasping"),
    "eval-task-model-garbage": Case(f"{E} --task-model hammering=@garbage.pt", "garbage.pt"),
    "eval-test-objects-0": Case(f"{E} --test-objects 0", "--test-objects"),
    "eval-scenes-0": Case(f"{E} --scenes-per-job 0", "--scenes-per-job"),
    "eval-config-bad": Case(f"{E} --config @bad.json", "bad.json"),
    "eval-config-range": Case(f"{E} --config @eval_scenes.json", "scenes_per_job"),
    "eval-run-missing": Case(f"{E} --run @nope", "--run"),
    "eval-run-file": Case(f"{E} --run @afile.txt", "--run"),
    "eval-resume-nothing": Case(f"{E} --resume", "resume"),
    "eval-resume-junk": Case("evaluate --task hammering --episodes 1 --out @junkdir --resume", "resume"),
    "eval-workers-neg": Case(f"{E} --workers -1", "--workers"),

    # model info / eval
    "info-missing": Case("model info @nope.pt", "nope.pt"),
    "info-dir": Case("model info @adir", "adir"),
    "info-empty": Case("model info @empty.pt", "empty.pt"),
    "info-garbage": Case("model info @garbage.pt", "garbage.pt"),
    "info-json": Case("model info @models/grasping.json", "grasping.json"),
    "meval-missing": Case("model eval @nope.pt --data @data", "nope.pt"),
    "meval-garbage": Case("model eval @garbage.pt --data @data", "garbage.pt"),
    "meval-data-missing": Case("model eval @models/sweeping.pt --data @nope", "nope"),
    "meval-data-empty": Case("model eval @models/sweeping.pt --data @adir", "adir"),
    "meval-data-wrong-task": Case("model eval @models/hammering.pt --data @data", "sweeping"),
    "meval-out-dir": Case("model eval @models/sweeping.pt --data @data --out @adir", "folder"),
    "meval-out-under-file": Case("model eval @models/sweeping.pt --data @data --out @afile.txt/m.json",
                                 "is a file, not a folder"),
    "meval-out-sys": Case("model eval @models/sweeping.pt --data @data --out /sys/tognet-m.json", "/sys"),

    # data info / synthetic
    "dinfo-missing": Case("data info @nope", "nope"),
    "dinfo-file": Case("data info @afile.txt", "afile.txt"),
    "dinfo-empty-dir": Case("data info @adir", "adir"),
    "dinfo-bad-manifest": Case("data info @bad_manifest", "manifest"),
    "dinfo-objects": Case("data info @objs_train", "objs_train"),
    "dsyn-out-file": Case("data synthetic @afile.txt --episodes 4", "not a folder"),
    "dsyn-out-under-file": Case("data synthetic @afile.txt/d --episodes 4", "is a file, not a folder"),
    "dsyn-out-sys": Case("data synthetic /sys/tognet-d --episodes 4", "/sys"),
    "dsyn-out-proc": Case("data synthetic /proc/tognet-d --episodes 4", "/proc"),
    "dsyn-episodes-0": Case("data synthetic @out --episodes 0", "--episodes"),
    "dsyn-episodes-huge": Case(f"data synthetic @out --episodes {BIG} --shard-size 1", "--episodes"),
    "dsyn-shards-huge": Case("data synthetic @out --episodes 2000000 --shard-size 1", "--shard-size"),
    "dsyn-objects-0": Case("data synthetic @out --episodes 4 --objects 0", "--objects"),
    "dsyn-shard-0": Case("data synthetic @out --episodes 4 --shard-size 0", "--shard-size"),
    "dsyn-seed-neg": Case("data synthetic @out --episodes 4 --seed -1", "--seed"),
    "dsyn-other-task": Case("data synthetic @data --episodes 4 --task hammering", "sweeping"),
    "dsyn-task-empty": Case("data synthetic @out --episodes 4 --task ''", "--task"),

    # demo
    "demo-out-file": Case("demo --out @afile.txt", "not a folder"),
    "demo-out-under-file": Case("demo --out @afile.txt/d", "is a file, not a folder"),
    "demo-out-sys": Case("demo --out /sys/tognet-demo", "/sys"),
    "demo-count-0": Case("demo --out @out --count 0", "--count"),
    "demo-count-huge": Case(f"demo --out @out --count {BIG}", "--count"),
    "demo-realistic-0": Case("demo --out @out --realistic 0", "--realistic"),
    "demo-seeds-0": Case("demo --out @out --seeds 0", "--seeds"),
    "demo-seeds-huge": Case(f"demo --out @out --seeds {BIG}", "--seeds"),
}


@pytest.mark.parametrize("name", list(CASES))
def test_a_bad_input_is_one_clear_line(ws, name, tmp_path):
    case = CASES[name]
    out = tmp_path / "out"
    before, here = _tree(ws), set(os.listdir("."))
    result = run_cli(case.argv(ws, out))
    found = problems(result)
    assert not found, f"{name}: {found}\nstdout: {result.stdout[-2000:]}\nstderr: {result.stderr[-2000:]}"
    line = next(s for s in result.stderr.splitlines() if s.startswith(("error:", "failed ")))
    assert case.expect.lower() in line.lower(), f"{name}: expected '{case.expect}' in: {line}"
    assert case.report or not result.stdout.strip(), f"{name}: refused only after some work: {result.stdout}"
    after = _tree(ws)
    assert after == before, f"{name}: left {sorted(after - before)} (removed {sorted(before - after)})"
    assert not out.exists(), f"{name}: wrote {out}"
    assert set(os.listdir(".")) == here, f"{name}: left {set(os.listdir('.')) - here} in the working folder"


def test_the_table_covers_every_subcommand():
    names = _subcommands()
    assert len(names) == 19, names
    args = [c.args for c in CASES.values()]
    missing = [n for n in names if not any(a == n or a.startswith(n + " ") for a in args)]
    assert not missing, f"no bad-input case for: {missing}"
    assert len(CASES) >= 150


# --- controls: the checks above can fail ------------------------------------------------------------------
def test_control_an_escaped_exception_is_a_failure(ws, monkeypatch):
    import tognet.objects.record as record

    def broken(*args, **kwargs):
        raise KeyError("a bug")

    monkeypatch.setattr(record, "load_catalog", broken)
    result = run_cli(["objects", "list", str(ws / "objs_train")])
    assert result.crash is not None and "KeyError" in result.crash
    assert any("escaped exception" in p for p in problems(result))


def test_control_a_printed_traceback_a_zero_exit_and_extra_lines_are_failures():
    printed = Outcome(2, "", "Traceback (most recent call last):\nerror: something went wrong here\n", None)
    assert "a traceback was printed" in problems(printed)
    quiet = Outcome(0, "all fine", "", None)
    assert "exit status 0" in problems(quiet) and "0 error lines" in problems(quiet)
    two = Outcome(2, "", "error: the first thing is wrong\nerror: the second thing is wrong\n", None)
    assert "2 error lines" in problems(two)
    chatty = Outcome(2, "", "some warning\nerror: the first thing is wrong\n", None)
    assert any("other lines" in p for p in problems(chatty))
    good = Outcome(2, "", "error: --out x: permission denied\n", None)
    assert problems(good) == []


def test_control_a_good_input_passes_through_main(ws, tmp_path):
    result = run_cli(["objects", "list", str(ws / "objs_train")])
    assert result.code == 0 and result.crash is None, result
    assert "1 objects in" in result.stdout


# --- what the table cannot show in one process ------------------------------------------------------------
def test_an_unusable_mujoco_gl_stops_only_the_animation_before_the_episode(tmp_path):
    """MUJOCO_GL is read when MuJoCo is imported, so this runs the command in a fresh interpreter."""
    import subprocess
    import sys

    env = {**os.environ, "MUJOCO_GL": "nonsense"}
    code = "import sys; from tognet.cli import main; main(sys.argv[1:])"
    help_run = subprocess.run([sys.executable, "-c", code, "--help"], env=env, capture_output=True, text=True,
                              timeout=120)
    assert help_run.returncode == 0 and "Traceback" not in help_run.stderr, help_run.stderr
    gif = tmp_path / "episode.gif"
    run = subprocess.run([sys.executable, "-c", code, "sim", "--task", "hammering", "--gif", str(gif)],
                         env=env, capture_output=True, text=True, timeout=120)
    assert run.returncode == 2, run.stderr
    assert run.stderr.strip().splitlines() == [
        "error: cannot animate: MUJOCO_GL=nonsense is not a rendering backend MuJoCo knows here (egl, "
        "osmesa, glx, glfw, or disable); unset it or set MUJOCO_GL=egl"]
    assert run.stdout == "" and not gif.exists()  # refused before the episode ran


def test_plan_robot_without_the_robot_extra_is_one_line_with_the_install_hint(ws, monkeypatch):
    import tognet.robot.arms as arms

    find_spec = importlib.util.find_spec
    monkeypatch.setattr(arms.importlib.util, "find_spec",
                        lambda name, *rest: None if name in ("robosuite", "mink") else find_spec(name, *rest))
    result = run_cli(Case(f"{PP} --robot panda").argv(ws, ws / "unused"))
    assert not problems(result), result
    assert "the robot arms need the optional extra: pip install 'tognet[robot]'" in result.stderr
    assert not result.stdout.strip()


def test_synthetic_data_is_written_a_chunk_at_a_time_in_flat_memory(tmp_path, monkeypatch):
    import tracemalloc

    import tognet.data.synthetic as synthetic
    from tognet.data.episodes import read_dataset

    monkeypatch.setattr(synthetic, "CHUNK", 50)
    peaks, seen = [], []
    for n in (200, 800):
        tracemalloc.start()
        synthetic.write_synthetic_dataset(tmp_path / f"d{n}", n=n, shard_size=50, progress=seen.append)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    assert seen == [50] * 20  # progress after every chunk
    assert peaks[1] < 1.5 * peaks[0], peaks  # four times the episodes, not four times the memory
    episodes = read_dataset(tmp_path / "d800")
    assert len(episodes) == 800 and len(set(episodes.scene_seed.tolist())) == 800
    first = synthetic.synthetic_episodes(50, seed=0)  # the first chunk is what one call makes
    assert np.array_equal(episodes.crop[:50], first.crop)


def test_grasps_colour_by_q_g_for_the_grasp_only_model_and_read_the_sims_camera_files(ws, tmp_path):
    args = ["grasps", "--depth", str(ws / "d.png"), "--camera", str(ws / "d.intrinsics.json"),
            "--camera-pose", str(ws / "d.pose.json"), "--max", "20", "--out", str(tmp_path / "g.png")]
    grasp_only = run_cli([*args, "--checkpoint", str(MODELS / "grasping.pt")])
    assert grasp_only.code == 0, grasp_only.stderr
    low, high = map(float, re.search(r"Q_G (\S+) to (\S+)\)", grasp_only.stdout).groups())
    assert 0.5 < low <= high <= 1.0, grasp_only.stdout  # Q_G means something, Q_T of this model does not
    task = run_cli([*args, "--checkpoint", str(MODELS / "hammering.pt")])
    assert task.code == 0 and "Q_T " in task.stdout, task.stderr
    assert (tmp_path / "g.png").is_file()


def test_a_config_out_of_range_names_the_field_made_directly_or_loaded(tmp_path):
    from tognet.config import ConfigError
    from tognet.sim.config import PhysicsConfig, SimConfig

    message = r"^PhysicsConfig.timestep must be > 0 and <= 0.05 \(s\), got -0.01$"
    with pytest.raises(ConfigError, match=message):
        PhysicsConfig(timestep=-0.01)
    with pytest.raises(ConfigError, match=r"SimConfig.camera.fy = 1e\+09 px gives"):
        SimConfig().replace(camera={**SimConfig().camera.to_dict(), "fy": 1e9})
    path = tmp_path / "sim.json"
    path.write_text(json.dumps({"episode": {"check_every": 0}, "world": {"table_size": [1.2, float("nan")]}}))
    with pytest.raises(ConfigError, match=r"sim.json.episode.check_every must be >= 1, got 0"):
        SimConfig.load(path)
    path.write_text(json.dumps({"world": {"table_size": [1.2, float("nan")]}}))
    with pytest.raises(ConfigError, match=r"world.table_size must be a finite number, got \(1.2, nan\)"):
        SimConfig.load(path)
    path.write_text(json.dumps({"world": {"table_size": [1.2, -0.7]}}))
    with pytest.raises(ConfigError, match=r"table_size must be positive \(m\), got \(1.2, -0.7\)"):
        SimConfig.load(path)


def _subcommands() -> list[str]:
    import typer

    from tognet.cli import app

    group = typer.main.get_command(app)
    names = []
    for name, command in group.commands.items():  # type: ignore[attr-defined]
        sub = getattr(command, "commands", None)
        names += [f"{name} {s}" for s in sub] if sub else [name]
    return names


def test_every_help_says_what_the_command_does():
    texts = {}
    for name in _subcommands():
        result = run_cli([*name.split(), "--help"])
        assert result.code == 0 and result.crash is None, (name, result)
        texts[name] = " ".join(result.stdout.split())
    assert "hand-computed" in texts["sim"] and "Default: zeros" not in texts["sim"]
    assert "--camera-pose" in texts["grasps"] and "Q_G" in texts["grasps"]
    for name in ("train", "pipeline", "evaluate"):
        assert "--resume" in texts[name] and "refused" in texts[name], name
    for name, layout in (("pipeline", "round<k>/data/"), ("evaluate", "evaluation.json"),
                         ("collect", "manifest.json"), ("train", "best.pt"), ("export-models", "<task>.pt")):
        assert layout in texts[name], name
