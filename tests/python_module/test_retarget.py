"""Retargeting from Python at each quality: arrays that view the C++ result, the same report and
the same skinned vertices as `odyssey retarget` and `odyssey point-cache`."""

import json

import numpy as np
import pytest

import odyssey
from conftest import FIGURE, WALK, run_cli


def read_pc2(path):
    """A PC2 point cache: 32-byte header (magic, version, vertices, start, rate, frames), float32 frames."""
    raw = open(path, "rb").read()
    vertices, frames = np.frombuffer(raw[16:20], np.int32)[0], np.frombuffer(raw[28:32], np.int32)[0]
    return np.frombuffer(raw[32:], np.float32).reshape(frames, vertices, 3)


@pytest.mark.parametrize("quality", ["fast", "balanced", "accurate"])
def test_each_quality_gives_the_commands_report(tmp_path, quality):
    result = odyssey.retarget(WALK, FIGURE, quality)
    T, J = result.frame_count, len(result.joint_names)
    assert result.rotations.shape == (T, J, 4) and result.root_translation.shape == (T, 3)
    assert np.allclose(np.linalg.norm(result.rotations, axis=2), 1, atol=1e-9)
    world = result.world_joints
    assert world.shape == (T, J, 3) and world is result.world_joints  # computed once
    # The character stands on the floor: its lowest joint over the clip is near z = 0.
    assert -0.02 < world[:, :, 2].min() < 0.15
    report = result.report
    code, _, err = run_cli("retarget", "--motion", WALK, "--character", FIGURE, "--quality", quality,
                           "--out", str(tmp_path / "out.glb"), "--report", str(tmp_path / "report.json"))
    assert code == 0, err
    cli = json.load(open(tmp_path / "report.json"))
    # Same inputs, same numbers: scale and every metric agree exactly; only timings differ.
    assert report["scale"] == cli["scale"]
    assert report["metrics"] == cli["metrics"]


def test_arrays_are_views_of_the_result():
    result = odyssey.retarget(WALK, FIGURE)
    rotations = result.rotations
    assert np.shares_memory(rotations, result.motion.rotations)
    assert not rotations.flags.writeable
    del result  # the arrays keep the C++ result alive
    assert np.isfinite(rotations).all()


def test_skinning_matches_the_point_cache(tmp_path):
    result = odyssey.retarget(WALK, FIGURE)
    vertices = result.skin()
    assert vertices.shape == (result.frame_count, result.character.vertex_count, 3) and vertices.dtype == np.float32
    some = result.skin(frames=[0, 5, 5])
    assert np.array_equal(some[1], vertices[5]) and np.array_equal(some[2], vertices[5])
    code, _, err = run_cli("point-cache", "--motion", WALK, "--character", FIGURE, "--out", str(tmp_path / "m.pc2"))
    assert code == 0, err
    cache = read_pc2(tmp_path / "m.pc2")
    assert cache.shape == vertices.shape
    # The same skinning kernel on the same clip; a micrometre allows for the scene's timeline resampling.
    assert np.abs(cache - vertices).max() < 1e-6


def test_refinement_options_reach_the_solver():
    plain = odyssey.retarget(WALK, FIGURE, "balanced")
    heavy = odyssey.retarget(WALK, FIGURE, "balanced", weights={"pose": 50.0}, contact_lift="off")
    assert heavy.report["settings"] != plain.report["settings"]
    with pytest.raises(odyssey.UsageError, match="unknown weight 'nope'"):
        odyssey.retarget(WALK, FIGURE, "balanced", weights={"nope": 1.0})
    with pytest.raises(odyssey.UsageError, match="quality fast does not run"):
        odyssey.retarget(WALK, FIGURE, "fast", weights={"pose": 1.0})
