"""No leak over 1,000 calls: resident memory (/proc/self/statm) stays flat across repeated calls
of the bound functions, their arrays dropped each time, errors included."""

import numpy as np
import pytest

import odyssey
from conftest import FIGURE, WALK, rss_bytes, small_scene


def growth(call, calls=1000, warmup=100):
    for _ in range(warmup):
        call()
    before = rss_bytes()
    for _ in range(calls):
        call()
    return rss_bytes() - before


def test_retarget_and_arrays_do_not_leak():
    def call():
        result = odyssey.retarget(WALK, FIGURE)
        result.rotations.sum()
        result.world_joints.sum()
        result.report
    # One retargeting (the C++ result, its arrays, the report) holds over 0.1 MB: a leak of it would be
    # over 100 MB over the calls.
    assert growth(call) < 8 * 2**20


def test_forward_pass_does_not_leak():
    model = odyssey.BodyModel.synthetic()
    poses = np.zeros((4, model.pose_size))
    # Four frames of vertices are 0.5 MB a call.
    assert growth(lambda: model.forward(poses)) < 8 * 2**20


def test_errors_do_not_leak(tmp_path):
    missing = str(tmp_path / "missing.bvh")

    def call():
        with pytest.raises(odyssey.InputError):
            odyssey.load_bvh(missing)
        with pytest.raises(ValueError):
            odyssey.BodyModel.forward(model, np.zeros((2, 3)))
    model = odyssey.BodyModel.synthetic()
    assert growth(call) < 4 * 2**20


def test_in_memory_scenes_do_not_leak():
    scene = small_scene(seconds=0.2)
    scene["props"] = scene["props"][:1]
    # Each run's arrays are about 0.2 MB: a leak of them would be 200 MB over the calls.
    assert growth(lambda: odyssey.scene_arrays(scene)) < 8 * 2**20
