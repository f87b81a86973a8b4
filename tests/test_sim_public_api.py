"""The simulator's public views for other modules: the scene layout, the object's vertices, the recorder."""

import numpy as np
import pytest

from tognet.sim import SimConfig, Simulator


def test_scene_and_vertices_are_public_and_read_only(tools):
    sim = Simulator(SimConfig(), "hammering", tools["t_hammer"])
    assert sim.scene is None  # no scene before the first reset
    obs = sim.reset(2)
    scene = sim.scene
    assert scene is not None and scene["seed"] == 2
    np.testing.assert_array_equal(scene["reference"], obs.reference)
    assert scene["layout"] == obs.info["layout"]
    with pytest.raises(TypeError):
        scene["seed"] = 3  # type: ignore[index]
    assert sim.vertices.shape[1] == 3 and len(sim.vertices) >= 8
    # The T hammer's collision pieces (handle and head at least), each a convex hull of its own vertices.
    pieces = np.split(sim.vertices, np.cumsum(sim.vertex_pieces)[:-1])
    assert sum(sim.vertex_pieces) == len(sim.vertices) and len(pieces) >= 2
    assert all(len(p) >= 4 for p in pieces)
    extents = [np.ptp(p, axis=0) for p in pieces]
    assert max(e.max() for e in extents) < np.ptp(sim.vertices, axis=0).max() + 1e-9
    assert min(e.max() for e in extents) < np.ptp(sim.vertices, axis=0).max()  # no piece is the whole tool


def test_recording_attaches_the_recorder_for_a_block_only(tools):
    sim = Simulator(SimConfig(), "hammering", tools["t_hammer"])
    sim.reset(0)
    calls: list[float] = []
    assert sim.recorder is None
    with pytest.raises(RuntimeError), sim.recording(lambda s: calls.append(float(s.data.time))):
        sim.execute(sim.default_grasp(), np.zeros(4), seed=0)
        raise RuntimeError("detached on an error too")
    assert sim.recorder is None and len(calls) > 10
    n = len(calls)
    sim.execute(sim.default_grasp(), np.zeros(4), seed=0)
    assert len(calls) == n
