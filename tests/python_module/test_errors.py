"""Bad values into every bound function: wrong numpy dtypes and shapes raise ValueError naming the
argument and both shapes; bad files raise InputError with the command's own line; bad options
UsageError; nothing crashes the interpreter."""

import json
import os

import numpy as np
import pytest

import odyssey
from conftest import FIGURE, WALK, run_cli


def test_exception_classes():
    assert issubclass(odyssey.Error, RuntimeError)
    assert issubclass(odyssey.InputError, odyssey.Error) and issubclass(odyssey.UsageError, odyssey.Error)


@pytest.mark.parametrize("arguments,call", [
    (["inspect", "{path}"], lambda path: odyssey.inspect(path)),
    (["pose", "--motion", "{path}", "--out", "{out}"], lambda path: odyssey.load_bvh(path)),
    (["retarget", "--motion", "{path}", "--character", FIGURE, "--out", "{out}"], lambda path: odyssey.retarget(path, FIGURE)),
])
def test_a_missing_file_raises_the_commands_line(tmp_path, arguments, call):
    missing = str(tmp_path / "missing.bvh")
    code, _, err = run_cli(*[a.format(path=missing, out=str(tmp_path / "out")) for a in arguments])
    assert code == 1
    with pytest.raises(odyssey.InputError) as raised:
        call(missing)
    assert err.strip().splitlines()[-1] == "odyssey %s: %s" % (arguments[0], raised.value)
    assert raised.value.file == missing


def test_a_corrupt_file_raises_input_error_everywhere(tmp_path):
    junk = tmp_path / "junk.glb"
    junk.write_bytes(b"glTF\x02\x00\x00\x00" + b"\xff" * 40)
    code, _, err = run_cli("inspect", str(junk))
    with pytest.raises(odyssey.InputError) as raised:
        odyssey.inspect(junk)
    assert code == 1 and err.strip() == "odyssey inspect: " + str(raised.value)
    with pytest.raises(odyssey.InputError):
        odyssey.Character(junk)
    with pytest.raises(odyssey.InputError):
        odyssey.retarget(WALK, junk)
    npz = tmp_path / "junk.npz"
    npz.write_bytes(b"PK\x03\x04" + b"\x00" * 20)
    for call in (odyssey.load_amass, odyssey.BodyModel, odyssey.inspect):
        with pytest.raises(odyssey.InputError):
            call(npz)
    with pytest.raises(odyssey.InputError):
        odyssey.run_scene(str(tmp_path / "none.json"), tmp_path / "out")
    with pytest.raises(odyssey.InputError):
        odyssey.run_batch(tmp_path / "batch", motions=[str(tmp_path / "nothing")], characters=[FIGURE])


def test_wrong_arrays_name_the_argument_and_both_shapes():
    model = odyssey.BodyModel.synthetic()
    good = np.zeros((2, model.pose_size))
    with pytest.raises(ValueError, match=r"poses: expected shape \(any, 165\), got shape \(2, 164\)"):
        model.forward(np.zeros((2, 164)))
    with pytest.raises(ValueError, match=r"poses: expected shape \(any, 165\), got shape \(165,\)"):
        model.forward(np.zeros(165))
    with pytest.raises(ValueError, match=r"poses: expected dtype float64, got dtype float32 \(shape \(2, 165\)"):
        model.forward(good.astype(np.float32))
    with pytest.raises(ValueError, match=r"trans: expected shape \(2, 3\), got shape \(3, 3\)"):
        model.forward(good, np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"betas: expected at most 300 values, got shape \(301,\)"):
        model.forward(good, betas=np.zeros(301))
    with pytest.raises(ValueError, match=r"expression: expected shape \(any,\), got shape \(2, 5\)"):
        model.forward(good, expression=np.zeros((2, 5)))
    with pytest.raises(ValueError, match="poses: expected a numpy array"):
        model.forward([[0.0] * 165])
    # A strided view is accepted (copied into C order), its values used.
    wide = np.zeros((2, 2 * model.pose_size))
    joints, _ = model.forward(wide[:, ::2], vertices=False)
    assert joints.shape == (2, 55, 3)


def test_bad_options_raise_usage_error(tmp_path):
    with pytest.raises(odyssey.UsageError, match="quality expects fast, balanced or accurate, got 'slow'"):
        odyssey.retarget(WALK, FIGURE, "slow")
    with pytest.raises(odyssey.UsageError, match="parts expects"):
        odyssey.retarget(WALK, FIGURE, parts="legs")
    with pytest.raises(odyssey.UsageError, match="fps must be positive"):
        odyssey.retarget(WALK, FIGURE, fps=-1)
    with pytest.raises(odyssey.UsageError, match="bvh_units expects"):
        odyssey.load_bvh(WALK, bvh_units="furlongs")
    with pytest.raises(odyssey.UsageError, match="model is for AMASS sequences"):
        odyssey.retarget(WALK, FIGURE, model=FIGURE)
    with pytest.raises(odyssey.UsageError, match="path: expected a path"):
        odyssey.inspect(42)
    with pytest.raises(odyssey.UsageError, match="layout expects files or pointodyssey"):
        odyssey.run_scene({"version": 1}, tmp_path / "o", layout="zip")
    with pytest.raises(odyssey.UsageError, match="is not a JSON value"):
        odyssey.scene_arrays({"version": object()})
    with pytest.raises(odyssey.UsageError, match="workers expects"):
        odyssey.run_batch(tmp_path / "b", [WALK], [FIGURE], workers=0)
    with pytest.raises(odyssey.UsageError, match="outputs expects"):
        odyssey.run_batch(tmp_path / "b", [WALK], [FIGURE], outputs="movies")
    with pytest.raises(odyssey.UsageError, match="unknown gate"):
        odyssey.run_batch(tmp_path / "b", [WALK], [FIGURE], gates={"max_speed": 1})
    result = odyssey.retarget(WALK, FIGURE)
    with pytest.raises(ValueError, match=r"frames: frame 100000 is outside \[0, "):
        result.skin(frames=[100000])
    with pytest.raises(ValueError, match="frames: expected frame numbers"):
        result.skin(frames="abc")
    with pytest.raises(ValueError, match="frames: expected an integer, got float"):
        result.skin(frames=[1.5])
    assert result.skin(frames=np.array([3], np.int64)).shape[0] == 1
    with pytest.raises(odyssey.UsageError, match="weights: pose: expected a number, got str"):
        odyssey.retarget(WALK, FIGURE, "balanced", weights={"pose": "x"})
    with pytest.raises(odyssey.UsageError, match="contact_lift: expected a number, got list"):
        odyssey.retarget(WALK, FIGURE, "balanced", contact_lift=[1])
    with pytest.raises(odyssey.UsageError, match="layout: expected a str, got int"):
        odyssey.run_scene({"version": 1}, tmp_path / "o", layout=3)
    with pytest.raises(odyssey.UsageError, match="gates: max_skate: expected a number, got NoneType"):
        odyssey.run_batch(tmp_path / "b", [WALK], [FIGURE], gates={"max_skate": None})
    with pytest.raises(odyssey.UsageError, match="threads expects"):
        result.skin(threads=0)
    with pytest.raises(odyssey.UsageError, match="fps must be positive"):
        result.motion.resampled(0)


def test_library_errors_are_odyssey_errors(tmp_path):
    actors = [{"name": name, "motion": WALK, "character": FIGURE, "placement": {"x": x, "y": 0, "yaw": 0}}
              for name, x in (("a", 0.0), ("b", 0.1))]
    scene = {"version": 1, "name": "s", "actors": actors, "cameras": [{"name": "c", "type": "static"}]}
    path = tmp_path / "s.json"
    path.write_text(json.dumps(scene))
    code, _, err = run_cli("scene", str(path), "--out", str(tmp_path / "out"))
    with pytest.raises(odyssey.Error) as raised:
        odyssey.scene_arrays(scene)
    assert type(raised.value) is odyssey.Error
    # From a file the command also names it and the JSON path; the problem's words are the same.
    assert code == 1 and err.strip().splitlines()[-1] == "odyssey scene: " + str(path) + ": actors[1].placement: " + str(raised.value)
    assert "actors 'a' and 'b' overlap at frame 0" in str(raised.value)


BAD_VALUES = [None, 0, -1, 42, -1.5, float("nan"), float("inf"), "", "missing.file", [], [None], {}, {"a": object()},
              np.zeros(3), np.zeros((2, 2), np.float32), np.zeros((0, 165)), object(), b"bytes"]


def test_bad_values_into_every_bound_function_raise_and_never_crash(tmp_path):
    model = odyssey.BodyModel.synthetic()
    poses = np.zeros((2, model.pose_size))
    result = odyssey.retarget(WALK, FIGURE)
    missing = str(tmp_path / "missing.bvh")
    bad_scene = {"version": 1}
    calls = {
        "inspect": lambda v: odyssey.inspect(v),
        "inspect bvh_units": lambda v: odyssey.inspect(WALK, v),
        "load_bvh": lambda v: odyssey.load_bvh(v),
        "load_bvh bvh_units": lambda v: odyssey.load_bvh(WALK, v),
        "load_amass": lambda v: odyssey.load_amass(v),
        "Character": lambda v: odyssey.Character(v),
        "BodyModel": lambda v: odyssey.BodyModel(v),
        "forward poses": lambda v: model.forward(v),
        "forward trans": lambda v: model.forward(poses, v),
        "forward betas": lambda v: model.forward(poses, None, v),
        "forward expression": lambda v: model.forward(poses, None, None, v),
        "retarget motion": lambda v: odyssey.retarget(v, FIGURE),
        "retarget character": lambda v: odyssey.retarget(WALK, v),
        "retarget quality": lambda v: odyssey.retarget(WALK, FIGURE, v),
        "retarget fps": lambda v: odyssey.retarget(WALK, FIGURE, fps=v),
        "retarget parts": lambda v: odyssey.retarget(WALK, FIGURE, parts=v),
        "retarget map": lambda v: odyssey.retarget(WALK, FIGURE, map=v),
        "retarget model": lambda v: odyssey.retarget(WALK, FIGURE, model=v),
        "retarget bvh_units": lambda v: odyssey.retarget(WALK, FIGURE, bvh_units=v),
        "retarget weights": lambda v: odyssey.retarget(WALK, FIGURE, "balanced", weights=v),
        "retarget contact_lift": lambda v: odyssey.retarget(WALK, FIGURE, "balanced", contact_lift=v),
        "retarget threads": lambda v: odyssey.retarget(WALK, FIGURE, threads=v),
        "skin frames": lambda v: result.skin(frames=v),
        "skin threads": lambda v: result.skin(frames=[0], threads=v),
        "resampled": lambda v: result.motion.resampled(v),
        "run_scene scene": lambda v: odyssey.run_scene(v, tmp_path / "out"),
        "run_scene out": lambda v: odyssey.run_scene(bad_scene, v),
        "run_scene layout": lambda v: odyssey.run_scene(bad_scene, tmp_path / "out", layout=v),
        "run_scene progress": lambda v: odyssey.run_scene(bad_scene, tmp_path / "out", progress=v),
        "scene_arrays scene": lambda v: odyssey.scene_arrays(v),
        "scene_arrays base_dir": lambda v: odyssey.scene_arrays(bad_scene, base_dir=v),
        "run_batch out": lambda v: odyssey.run_batch(v, [missing], [FIGURE]),
        "run_batch motions": lambda v: odyssey.run_batch(tmp_path / "b", v, [FIGURE]),
        "run_batch characters": lambda v: odyssey.run_batch(tmp_path / "b", [missing], v),
        "run_batch manifest": lambda v: odyssey.run_batch(tmp_path / "b", manifest=v),
        "run_batch workers": lambda v: odyssey.run_batch(tmp_path / "b", [missing], [FIGURE], workers=v),
        "run_batch gates": lambda v: odyssey.run_batch(tmp_path / "b", [missing], [FIGURE], gates=v),
        "run_batch shard": lambda v: odyssey.run_batch(tmp_path / "b", [missing], [FIGURE], shard=v),
        "run_batch max_memory_gib": lambda v: odyssey.run_batch(tmp_path / "b", [missing], [FIGURE], max_memory_gib=v),
    }
    if hasattr(odyssey, "run_dataset"):
        calls["run_dataset recipe"] = lambda v: odyssey.run_dataset(v, tmp_path / "d")
        calls["run_dataset count"] = lambda v: odyssey.run_dataset({"version": 1}, tmp_path / "d", count=v)
    for name, call in calls.items():
        for value in BAD_VALUES:
            try:
                call(value)
            except (odyssey.Error, ValueError, TypeError):
                pass  # refused with a Python exception: what is asked
            except Exception as error:  # noqa: BLE001 - any other kind is a finding
                pytest.fail("%s(%r) raised %s: %s" % (name, value, type(error).__name__, error))
