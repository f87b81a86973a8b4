"""Every object-set, evaluation and config file a command reads, damaged, is named in its error (issue 35).

Each case copies a small good folder made once for the module (an object set, a finished tiny evaluation,
or an empty one for a ``--config`` file), damages one file of the copy and runs the command on it in this
process (:func:`test_cli_bad_inputs.run_cli`). The command must exit nonzero with one clear line on
stderr that names the damaged file, print no traceback, and write nothing: every file of the copy is
byte for byte what it was, and ``@out`` does not exist afterwards.

Two files are not refused, by design, and their cases say so (``recovers``): an evaluation's job record
is moved aside as ``*.corrupt`` and its job runs again (one warning names it), and ``results.json`` is
never read (it is written again from the records). Then the command succeeds and loses nothing: the
records, settings and objects already written are byte for byte what they were.

Not covered: an object's ``object.xml``. No command reads it (the simulator builds the object from the
catalog and its meshes); it is for loading one object in MuJoCo by hand, and copied to cluster nodes.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shlex
import shutil
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from test_cli_bad_inputs import problems, run_cli

OBJ = "primitive-train-000000"
TEST_OBJ = "primitive-test-000000"
EVAL = ("evaluate --task hammering --episodes 1 --category pg-primitive --methods Antipodal+Random "
        "--test-objects 1 --workers 0 --no-animations --no-progress --out @set")


# --- the damage done to a file ----------------------------------------------------------------------------
def _json(change: Callable[[Any], None]) -> Callable[[bytes], bytes]:
    def damage(good: bytes) -> bytes:
        data = json.loads(good)
        change(data)
        return json.dumps(data).encode()

    return damage


def _pop(key: str) -> Callable[[Any], None]:
    return lambda data: data.pop(key)


DAMAGE: dict[str, Callable[[bytes], bytes]] = {
    "garbage": lambda good: b"this is not what it should be {[<\n",
    "empty": lambda good: b"",
    "binary": lambda good: bytes(range(256)) * 4,
    "truncated": lambda good: good[: len(good) // 2],
    "list": lambda good: b"[1, 2]",
    "number": lambda good: b"42",
    "empty-object": lambda good: b"{}",
    "unknown-field": _json(lambda data: data.update(no_such_field=1)),
    "objects-not-list": _json(lambda data: data.update(objects={})),
    "entry-not-object": _json(lambda data: data["objects"].__setitem__(0, OBJ)),
    "entry-missing-field": _json(lambda data: data["objects"][0].pop("mass")),
    "missing-field": _json(_pop("methods")),
}


@dataclass(frozen=True)
class Case:
    base: str  # the folder copied to @set: "objs" (training set), "eval" (finished evaluation), "" (empty)
    file: str  # the file damaged, in @set
    damage: str  # a key of DAMAGE
    args: str  # @set: the copy; @out: a fresh path that must not exist afterwards; @name: a file of ws
    recovers: bool = False  # the command recovers from the damage by design (see the module docstring)

    @property
    def expect(self) -> str:
        """The piece the error line must hold: the damaged file's name."""
        return Path(self.file).name

    def argv(self, ws: Path, copy: Path, out: Path) -> list[str]:
        names = {"set": str(copy), "out": str(out)}

        def fill(match: re.Match[str]) -> str:
            return names.get(match.group(1), str(ws / match.group(1)))

        return [re.sub(r"@(\w+)", fill, a) for a in shlex.split(self.args)]


# --- the cases ------------------------------------------------------------------------------------------
SET_COMMANDS = {
    "list": "objects list @set",
    "stats": "objects stats @set",
    "sheet": "objects sheet @set --out @out/s.png",
    "collect": "collect --task hammering --objects @set --out @out --episodes 1 --workers 0 --no-progress",
    "sim": f"sim --task hammering --objects @set --object {OBJ}",
    "generate": "objects generate --kind primitive --count 1 --start 2 --out @set",
}
CATALOG_DAMAGE = ("garbage", "empty", "binary", "truncated", "list", "empty-object", "objects-not-list",
                  "entry-not-object", "entry-missing-field")
#: Which commands read which mesh (the sheet draws the visual meshes only).
MESHES = {"collision_00.obj": ("stats", "collect", "sim"), "visual.obj": ("stats", "sheet", "collect", "sim")}
MESH_DAMAGE = ("garbage", "empty", "binary", "truncated")

CONFIG_COMMANDS = {
    "generate": "objects generate --kind primitive --count 1 --out @out",
    "sim": "sim --task hammering",
    "collect": "collect --task hammering --objects @objs --out @out --episodes 1 --workers 0",
    "evaluate": "evaluate --task hammering --episodes 1 --category pg-primitive --out @out",
    "train": "train --data @data --task sweeping --out @out",
    "plan": "plan --depth @d.png --intrinsics @d.intrinsics.json --camera-pose @d.pose.json --task hammering",
    "grasps": "grasps --depth @depth.npy --camera @camera.json --out @out/o.png",
}
CONFIG_DAMAGE = ("binary", "empty", "list", "number", "unknown-field")
#: Already in test_cli_bad_inputs.CASES (train-config-binary, collect-config-binary, gen-config-empty,
#: sim-config-list; sim-config-typo is an unknown key).
CONFIG_DONE = {("train", "binary"), ("collect", "binary"), ("generate", "empty"), ("sim", "list"),
               ("sim", "unknown-field")}


def _cases() -> dict[str, Case]:
    cases: dict[str, Case] = {}
    for cmd, args in SET_COMMANDS.items():
        for damage in CATALOG_DAMAGE:
            cases[f"{cmd}-catalog-{damage}"] = Case("objs", "catalog.json", damage, args)
    for damage in ("garbage", "empty", "binary", "list", "unknown-field"):
        cases[f"generate-generator-config-{damage}"] = Case("objs", "generator_config.json", damage,
                                                            SET_COMMANDS["generate"])
    for mesh, commands in MESHES.items():
        for cmd in commands:
            for damage in MESH_DAMAGE:
                cases[f"{cmd}-{mesh.split('.')[0]}-{damage}"] = Case("objs", f"{OBJ}/{mesh}", damage,
                                                                     SET_COMMANDS[cmd])
    resume = f"{EVAL} --resume"
    for damage in ("garbage", "empty", "binary", "truncated", "list", "empty-object", "missing-field"):
        cases[f"resume-evaluation-{damage}"] = Case("eval", "evaluation.json", damage, resume)
    for damage in ("garbage", "empty", "binary", "list", "empty-object"):
        cases[f"resume-meta-{damage}"] = Case("eval", "hammering/pg-primitive/meta.json", damage, resume)
    for damage in ("garbage", "empty", "binary", "list", "truncated"):
        cases[f"resume-catalog-{damage}"] = Case("eval", "objects/primitive-test/catalog.json", damage,
                                                 resume)
    for damage in ("garbage", "empty", "binary", "truncated", "list", "empty-object"):
        cases[f"resume-job-{damage}"] = Case("eval", "hammering/pg-primitive/job-000000.json", damage, resume,
                                             recovers=True)
    for damage in ("garbage", "binary"):
        cases[f"resume-results-{damage}"] = Case("eval", "results.json", damage, resume, recovers=True)
    for cmd, args in CONFIG_COMMANDS.items():
        for damage in CONFIG_DAMAGE:
            if (cmd, damage) not in CONFIG_DONE:
                cases[f"{cmd}-config-{damage}"] = Case("", "config.json", damage,
                                                       f"{args} --config @set/config.json")
    return cases


CASES = _cases()


# --- the good inputs --------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def ws(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Good inputs: a two-object training set, a finished tiny evaluation, a dataset and a depth image."""
    import numpy as np

    from tognet.data.synthetic import write_synthetic_dataset
    from tognet.geometry import Camera, CameraIntrinsics
    from tognet.grasping.synthetic import render_depth, t_shape
    from tognet.objects import generate_set
    from tognet.planning.camera import save_camera_pose, save_depth_png, save_intrinsics

    root = tmp_path_factory.mktemp("bad-files")
    generate_set("primitive", "train", 2, root / "objs")
    result = run_cli(Case("", "", "", EVAL).argv(root, root / "eval", root / "unused"))
    assert result.code == 0 and result.crash is None, result
    write_synthetic_dataset(root / "data", task="sweeping", n=40, shard_size=20, n_objects=4)
    k = CameraIntrinsics.kinect2()
    camera = Camera.looking_down(k, [0.0, 0.0, 0.7])
    depth = render_depth(camera, t_shape(0.0, 0.0, yaw=0.3))
    np.save(root / "depth.npy", depth)
    camera.save(root / "camera.json")
    save_depth_png(root / "d.png", depth)
    save_intrinsics(root / "d.intrinsics.json", k)
    save_camera_pose(root / "d.pose.json", camera.pose)
    return root


def _digests(root: Path) -> dict[str, str]:
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir"
            for p in root.rglob("*")}


def _damaged_copy(ws: Path, case: Case, copy: Path) -> Path:
    """``case.base`` copied to ``copy`` with ``case.file`` damaged; the damaged file's path."""
    if case.base:
        shutil.copytree(ws / case.base, copy)
    else:
        copy.mkdir()
    target = copy / case.file
    good = target.read_bytes() if target.is_file() else b"{}"
    target.write_bytes(DAMAGE[case.damage](good))
    return target


@pytest.mark.parametrize("name", list(CASES))
def test_a_damaged_file_is_named_in_one_line(ws: Path, name: str, tmp_path: Path) -> None:
    case = CASES[name]
    copy, out = tmp_path / "set", tmp_path / "out"
    target = _damaged_copy(ws, case, copy)
    damaged = target.read_bytes()
    before, here, ws_before = _digests(copy), set(os.listdir(".")), _digests(ws)
    with warnings.catch_warnings(record=True) as caught:  # what the command warns of, as pytest sees it
        warnings.simplefilter("always")
        result = run_cli(case.argv(ws, copy, out))
    shown = f"\nstdout: {result.stdout[-2000:]}\nstderr: {result.stderr[-2000:]}"
    assert set(os.listdir(".")) == here, f"{name}: left {set(os.listdir('.')) - here} in the working folder"
    assert _digests(ws) == ws_before, f"{name}: changed the module's good inputs"
    if case.recovers:
        _check_recovered(copy, target, damaged, before, result, [str(w.message) for w in caught])
        return
    found = problems(result)
    assert not found, f"{name}: {found}{shown}"
    line = next(s for s in result.stderr.splitlines() if s.startswith(("error:", "failed ")))
    assert case.expect.lower() in line.lower(), f"{name}: expected '{case.expect}' in: {line}"
    assert not result.stdout.strip(), f"{name}: refused only after some work: {result.stdout}"
    after = _digests(copy)
    changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    assert not changed, f"{name}: changed {changed}"
    assert not out.exists(), f"{name}: wrote {out}"


def _check_recovered(copy: Path, target: Path, damaged: bytes, before: dict[str, str], result: Any,
                     warned: list[str]) -> None:
    """A job record moved aside and run again, or results.json written again: exit 0, nothing lost."""
    assert result.code == 0 and result.crash is None, result
    assert "Traceback" not in result.stdout + result.stderr, result.stderr
    assert json.loads(target.read_text()), f"{target} is not whole again"
    after = _digests(copy)
    assert set(before) <= set(after), f"lost {sorted(set(before) - set(after))}"
    if target.name.startswith("job-"):
        aside = target.with_name(target.name + ".corrupt")
        assert aside.read_bytes() == damaged, "the damaged record was not kept aside"
        named = [w for w in warned if target.name in w]
        assert len(named) == 1 and "\n" not in named[0], f"not one warning naming {target.name}: {warned}"
        untouched = {k for k in before if not k.endswith((target.name, "results.json", "report.html",
                                                          "report.md", ".png"))}
    else:
        untouched = {k for k in before if k.startswith(("hammering", "objects", "evaluation.json"))}
    assert {k: after[k] for k in untouched} == {k: before[k] for k in untouched}, "changed what was written"


# --- controls: the checks can fail ------------------------------------------------------------------------
def test_the_table_covers_every_file_kind_and_command() -> None:
    files = {Path(c.file).name for c in CASES.values()}
    assert files >= {"catalog.json", "generator_config.json", "collision_00.obj", "visual.obj",
                     "evaluation.json", "meta.json", "job-000000.json", "results.json", "config.json"}
    commands = {" ".join(c.args.split()[:2]) if c.args.startswith("objects") else c.args.split()[0]
                for c in CASES.values()}
    assert commands == {"objects list", "objects stats", "objects sheet", "objects generate", "sim",
                        "collect", "evaluate", "train", "plan", "grasps"}, commands
    assert len(CASES) >= 100


def test_control_a_good_copy_passes_and_a_damaged_one_is_caught(ws: Path, tmp_path: Path) -> None:
    good = run_cli(["objects", "stats", str(ws / "objs")])
    assert good.code == 0 and "0 error lines" in problems(good), good  # it succeeds
    case = Case("objs", f"{OBJ}/visual.obj", "garbage", "objects stats @set")
    _damaged_copy(ws, case, tmp_path / "set")
    bad = run_cli(case.argv(ws, tmp_path / "set", tmp_path / "out"))
    assert not problems(bad) and "visual.obj" in bad.stderr, bad
