"""Datasets from Python (where the build has the dataset library): a recipe run into a dataset
folder as `odyssey dataset` makes it, with progress, read back by odyssey.data."""

import json
import os

import numpy as np
import pytest

import odyssey
import odyssey.data as data
from conftest import run_cli

pytestmark = pytest.mark.skipif(not hasattr(odyssey, "run_dataset"), reason="the build has no dataset library")

RECIPE = {
    "version": 1, "name": "tiny", "seed": 2, "count": 2,
    "libraries": {"characters": ["data:characters/RiggedFigure.glb"],
                  "motions": [{"path": "data:mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu"}]},
    "shots": {"seconds": 1, "actors": 1, "quality": {"fast": 1}},
    "cameras": {"count": 1, "kinds": {"static": 1}, "width": 160, "height": 90, "handheld": 0},
    "points": {"per_actor": 200},
}


def test_a_recipe_makes_the_commands_dataset(tmp_path):
    events = []
    summary = odyssey.run_dataset(RECIPE, tmp_path / "py", progress=events.append)
    assert summary["total"] == 2 and summary["done"] == 2 and summary["failed"] == 0
    assert any(os.path.basename(p) == "dataset.json" for p in summary["reports"])
    assert events and events[-1]["done"] == 2
    dataset = data.Dataset(tmp_path / "py")
    assert len(dataset.sequences) == 2 and dataset[0]["trajs_2d"].shape[1:] == (200, 2)
    # The command on the same recipe: the same sequences, byte for byte.
    recipe = tmp_path / "recipe.json"
    recipe.write_text(json.dumps(RECIPE))
    code, _, err = run_cli("dataset", str(recipe), "--out", str(tmp_path / "cli"), "--quiet")
    if code != 0 and "unknown command" in err:
        pytest.skip("this odyssey command has no dataset subcommand")
    assert code == 0, err
    for sequence in dataset.sequences:
        other = os.path.join(tmp_path / "cli", os.path.relpath(sequence.path, tmp_path / "py"))
        with np.load(os.path.join(other, "anno.npz")) as cli:
            for key in cli.files:
                assert np.array_equal(sequence.anno[key], cli[key]), key


def test_bad_recipes_and_options(tmp_path):
    with pytest.raises(odyssey.InputError, match=r"^recipe: "):
        odyssey.run_dataset({"version": 1, "nope": 1}, tmp_path / "out")
    with pytest.raises(odyssey.UsageError, match="count expects"):
        odyssey.run_dataset(RECIPE, tmp_path / "out", count=0)
    with pytest.raises(odyssey.InputError):
        odyssey.run_dataset(tmp_path / "missing.json", tmp_path / "out")
