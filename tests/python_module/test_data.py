"""odyssey.data: the reader of sequences round trip: a scene written in the PointOdyssey layout
reads back as the in-memory arrays, the maps decode as the loaders decode them, and a dataset
folder gives clips."""

import os

import numpy as np
import pytest

import odyssey
import odyssey.data as data
from conftest import small_scene


@pytest.fixture(scope="module")
def sequences(tmp_path_factory):
    root = tmp_path_factory.mktemp("dataset")
    scene = small_scene(name="walk", layout="pointodyssey",
                        outputs={"depth": True, "normals": True, "masks": True, "exact_maps": True})
    for camera in scene["cameras"]:
        camera.update({"width": 160, "height": 90})
    odyssey.run_scene(scene, root / "train")
    return root, scene


def test_a_sequence_reads_back_the_scenes_arrays(sequences):
    root, scene = sequences
    sequence = data.Sequence(root / "train" / "walk_front")
    memory = odyssey.scene_arrays(scene)["cameras"]["front"]
    assert (sequence.frames, sequence.points, sequence.fps) == (31, 500, 30.0)
    assert sorted(sequence.maps) == ["depths", "masks", "normals"]
    for key, values in memory.items():
        assert np.array_equal(sequence.anno[key], values), key
    assert np.array_equal(sequence.anno["visibilities"] == 1, memory["visibs"])
    clip = sequence.clip(3, 4, stride=2)
    assert list(clip["frames"]) == [3, 5, 7, 9]
    assert np.array_equal(clip["trajs_2d"], memory["trajs_2d"][3:10:2])
    assert clip["depths"].shape == (4, 90, 160) and clip["depths"].dtype == np.float32
    assert clip["normals"].shape == (4, 90, 160, 3) and clip["masks"].dtype == np.uint8


def test_maps_decode_as_the_loaders_do(sequences):
    root, _ = sequences
    sequence = data.Sequence(root / "train" / "walk_front")
    png, exact = sequence.depth(10), sequence.depth(10, exact=True)
    seen = np.isfinite(exact)
    assert seen.any() and np.array_equal(np.isfinite(png), seen)
    # 16-bit PNG over 1,000 m: steps of 1.53 cm, so half a step of rounding.
    assert np.abs(png[seen] - exact[seen]).max() <= 1000 / 65535 / 2 + 1e-6
    normals, exact_normals = sequence.normal(10), sequence.normal(10, exact=True)
    surface = np.linalg.norm(exact_normals, axis=2) > 0.5
    # 8-bit JPEG: about 2 steps of 2/255 at most on smooth surfaces; the mean well under one.
    assert np.abs(normals[surface] - exact_normals[surface]).mean() < 0.01
    mask = sequence.mask(10)
    ids = set(np.unique(mask)) - {0}
    assert ids <= set(sequence.instances) and 1 in ids  # the walker
    with pytest.raises(IndexError):
        sequence.depth(31)


def test_dataset_clips(sequences):
    root, _ = sequences
    dataset = data.Dataset(root, split="train", clip_length=8, stride=1, maps=["depths"], max_points=64, seed=1)
    assert [s.name for s in dataset.sequences] == ["walk_front", "walk_orbit"]
    assert len(dataset) == 2 * (31 // 8)
    sample = dataset[1]
    assert sample["trajs_2d"].shape == (8, 64, 2) and sample["depths"].shape == (8, 90, 160)
    assert sample["point_actor_ids"].shape == (64,) and "rgbs" not in sample
    assert np.array_equal(dataset[1]["trajs_3d"], sample["trajs_3d"])  # the same points every epoch
    whole = data.Dataset(root / "train" / "walk_orbit")
    assert len(whole) == 1 and whole[0]["trajs_2d"].shape == (31, 500, 2)
    try:
        import torch.utils.data
    except ImportError:
        assert data.Dataset.__mro__[1] is object
    else:
        assert isinstance(dataset, torch.utils.data.Dataset)
    with pytest.raises(FileNotFoundError):
        data.Dataset(root / "train" / "walk_front" / "depths")
