"""Scenes from Python: into files as `odyssey scene` writes them, and into numpy arrays equal, key
by key and bit by bit, to the trajectory files the command writes."""

import json
import os

import numpy as np
import pytest

import odyssey
from conftest import run_cli, small_scene


def test_in_memory_scene_equals_the_commands_files(tmp_path):
    scene = small_scene()
    path = tmp_path / "shot.json"
    path.write_text(json.dumps(scene))
    code, _, err = run_cli("scene", str(path), "--out", str(tmp_path / "cli"), "--layout", "files", "--quiet")
    assert code == 0, err
    events = []
    result = odyssey.scene_arrays(scene, progress=events.append)
    assert set(result["cameras"]) == {"front", "orbit"}
    for camera, arrays in result["cameras"].items():
        with np.load(tmp_path / "cli" / ("trajectories_%s.npz" % camera)) as files:
            assert set(arrays) == set(files.files)
            for key in files.files:
                assert arrays[key].dtype == files[key].dtype, key
                assert arrays[key].shape == files[key].shape, key
                assert np.array_equal(arrays[key], files[key]), key
    T, N = result["cameras"]["front"]["trajs_3d"].shape[:2]
    assert T == 31 and N == 400 + 100
    assert result["report"]["frames"] == T and result["report"]["points"] == N
    assert any(e["stage"] == "export" and e["done"] == e["total"] == T for e in events)
    # The arrays own their memory (a capsule), no copy: the base is not another array.
    assert not isinstance(result["cameras"]["front"]["trajs_3d"].base, np.ndarray)


def test_run_scene_into_files_as_the_command(tmp_path):
    scene = small_scene()
    report = odyssey.run_scene(scene, tmp_path / "py", layout="files")
    path = tmp_path / "shot.json"
    path.write_text(json.dumps(scene))
    code, _, err = run_cli("scene", str(path), "--out", str(tmp_path / "cli"), "--layout", "files", "--quiet")
    assert code == 0, err
    names = sorted(os.path.basename(p) for p in report["outputs"])
    assert names == sorted(os.listdir(tmp_path / "cli"))
    for camera in ("front", "orbit"):
        name = "trajectories_%s.npz" % camera
        assert open(tmp_path / "py" / name, "rb").read() == open(tmp_path / "cli" / name, "rb").read()
    # A scene file runs the same as its dict.
    again = odyssey.run_scene(path, tmp_path / "file", layout="files")
    assert again["points"] == report["points"]


def test_scene_dict_paths_are_relative_to_base_dir(tmp_path):
    scene = small_scene()
    scene["actors"][0]["motion"] = "walk.bvh"
    os.symlink(os.path.join(os.path.dirname(__file__), "..", "..", "data", "mocap", "cmu_walk_cgspeed.bvh"), tmp_path / "walk.bvh")
    with pytest.raises(odyssey.InputError):
        odyssey.scene_arrays(scene, base_dir="/")
    assert odyssey.scene_arrays(scene, base_dir=tmp_path)["report"]["frames"] == 31


def test_a_bad_scene_raises_the_commands_message(tmp_path):
    scene = small_scene()
    scene["actors"][0]["placement"] = {"x": "left"}
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(scene))
    code, _, err = run_cli("scene", str(path), "--out", str(tmp_path / "out"))
    assert code == 1
    with pytest.raises(odyssey.InputError) as raised:
        odyssey.run_scene(path, tmp_path / "out")
    assert err.strip() == "odyssey scene: " + str(raised.value)
    assert raised.value.file == str(path) and "actors[0].placement.x" in raised.value.problem
    assert not (tmp_path / "out" / "report.json").exists()
    with pytest.raises(odyssey.InputError, match=r"^scene: actors\[0\]\.placement\.x"):
        odyssey.scene_arrays(scene)


def test_an_error_in_the_progress_callback_stops_the_run_and_writes_nothing(tmp_path):
    class Stop(Exception):
        pass

    def progress(event):
        if event["stage"] == "export":
            raise Stop("enough")

    with pytest.raises(Stop):
        odyssey.run_scene(small_scene(), tmp_path / "out", layout="files", progress=progress)
    assert os.listdir(tmp_path / "out") == []
    with pytest.raises(odyssey.UsageError):
        odyssey.run_scene(small_scene(), tmp_path / "out", progress=3)


def test_example_scene_with_an_ego_camera_equals_the_commands_files(tmp_path):
    example = odyssey.example_scene()
    assert example["name"] == "indoor" and [c["type"] for c in example["cameras"]] == ["ego", "orbit", "static"]
    for actor in example["actors"]:
        actor["trim"] = [0.1, 0.8]  # balanced, as written; 0.7 s of it
    for key in ("layout", "depth", "normals", "masks", "previews", "glb"):
        example["outputs"].pop(key, None)
    path = tmp_path / "indoor.json"
    path.write_text(json.dumps(example))
    code, _, err = run_cli("scene", str(path), "--out", str(tmp_path / "cli"), "--quiet")
    assert code == 0, err
    result = odyssey.scene_arrays(example)
    assert list(result["cameras"]) == ["head", "orbit", "corner"]
    for camera, arrays in result["cameras"].items():
        with np.load(tmp_path / "cli" / ("trajectories_%s.npz" % camera)) as files:
            assert set(arrays) == set(files.files)
            for key in files.files:
                assert np.array_equal(arrays[key], files[key]), (camera, key)
        assert arrays["visibs"].any()


def test_long_calls_release_the_gil():
    import threading
    import time

    done = threading.Event()
    span = []

    def work():
        start = time.perf_counter()
        odyssey.scene_arrays(small_scene(seconds=2.0))
        span.append(time.perf_counter() - start)
        done.set()

    worker = threading.Thread(target=work)
    ticks = [time.perf_counter()]
    worker.start()
    while not done.is_set():  # Python bytecode: it runs only while the worker does not hold the GIL
        ticks.append(time.perf_counter())
    worker.join()
    longest_gap = max(b - a for a, b in zip(ticks, ticks[1:]))
    # Held through the call, the GIL would stop this loop for the whole run; released, only for the
    # Python around it and the interpreter's switch interval (5 ms).
    assert longest_gap < 0.5 * span[0], (longest_gap, span[0])
