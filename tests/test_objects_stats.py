"""Tool-likeness statistics of a set, on hand-made objects whose answers are known."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from typer.testing import CliRunner

from tognet.cli import app
from tognet.objects import assemble_object, write_catalog
from tognet.objects.stats import min_width, object_stats, rests_flat, summary_lines


def _box(extents, centre=(0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    box = trimesh.creation.box(extents=extents)
    box.apply_translation(centre)
    return box


@pytest.fixture(scope="module")
def hand_made(tmp_path_factory):
    folder = tmp_path_factory.mktemp("stats") / "set"
    handle = _box((0.24, 0.03, 0.02), (-0.01, 0.0, 0.0))  # overlaps the head by 1 cm
    head = _box((0.04, 0.12, 0.02), (0.12, 0.0, 0.0))
    hammer = trimesh.boolean.union([handle, head], engine="manifold")
    tetra = trimesh.convex.convex_hull([[0, 0, 0], [0.1, 0.02, 0.05], [-0.1, 0.03, 0.06], [0.0, -0.06, 0.07]])
    tetra.apply_translation(-tetra.bounds.mean(axis=0))
    items = {
        "bar": ("T", _box((0.30, 0.03, 0.02)), [_box((0.30, 0.03, 0.02))]),
        "cube": ("none", _box((0.1, 0.1, 0.1)), [_box((0.1, 0.1, 0.1))]),
        "hammer": ("T", hammer, [handle, head]),
        "spike": ("none", tetra, [tetra]),
    }
    records = [
        assemble_object(
            folder, object_id=name, kind="primitive" if rule == "T" else "imported", split="test",
            shape_rule=rule, part_types=["cuboid"], visual=visual, collision_pieces=pieces, density=800.0,
            friction=0.7,
        )  # fmt: skip
        for name, (rule, visual, pieces) in items.items()
    ]
    write_catalog(folder, records)
    return folder, {r.object_id: object_stats(r) for r in records}


def test_measures_of_known_objects(hand_made):
    _folder, stats = hand_made
    bar, cube, hammer, spike = stats["bar"], stats["cube"], stats["hammer"], stats["spike"]
    assert bar.length == pytest.approx(0.30) and bar.height == pytest.approx(0.02)
    assert bar.narrowest == pytest.approx(0.03, rel=1e-3) and bar.graspable and bar.rests_flat
    assert bar.head_fraction is None  # one piece: no head
    assert cube.narrowest == pytest.approx(0.1, rel=1e-3) and not cube.graspable and cube.rests_flat
    assert hammer.length == pytest.approx(0.27)
    head, handle = 0.04 * 0.12 * 0.02, 0.24 * 0.03 * 0.02
    assert hammer.head_fraction == pytest.approx(head / (head + handle), rel=1e-6)
    assert hammer.mass == pytest.approx(800.0 * (head + handle - 0.01 * 0.03 * 0.02), rel=1e-6)
    assert not spike.rests_flat  # stands on one vertex


def test_rests_flat_and_min_width_by_hand():
    square = np.array([[x, y, 0.0] for x in (0, 0.1) for y in (0, 0.1)] + [[0.05, 0.05, 0.05]])
    assert rests_flat(square, np.array([0.05, 0.05, 0.01]))
    assert not rests_flat(square, np.array([0.099, 0.05, 0.01]))  # within the 2 mm margin of the edge
    assert not rests_flat(square, np.array([0.2, 0.05, 0.01]))
    diamond = np.array([[0.05, 0], [0, 0.02], [-0.05, 0], [0, -0.02]])
    assert min_width(diamond, 360) == pytest.approx(2 * 0.05 * 0.02 / np.hypot(0.05, 0.02), rel=5e-3)


def test_summary_and_cli(hand_made):
    folder, stats = hand_made
    lines = summary_lines(list(stats.values()))
    text = "\n".join(lines)
    assert "primitive: 2 objects (rules: T 2)" in text and "imported: 2 objects" in text
    assert "graspable (a part <= 7 cm wide): 100 %; rests in its generated pose: 100 %" in text
    assert "graspable (a part <= 7 cm wide): 0 %; rests in its generated pose: 50 %" in text
    result = CliRunner().invoke(app, ["objects", "stats", str(folder)])
    assert result.exit_code == 0, result.output
    assert "part B share (T)" in result.output
    result = CliRunner().invoke(app, ["objects", "stats", str(folder / "nope")])
    assert result.exit_code == 2 and "no such folder" in result.output
