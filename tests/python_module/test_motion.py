"""Motions, characters and the body model from Python: inspect's dict against the command's
lines, BVH clips against `odyssey pose`, AMASS sequences, the forward pass against the smplx
package's numbers."""

import os

import numpy as np
import pytest

import odyssey
from conftest import CESIUM, FIGURE, SMPLX_FIXTURE, WALK, run_cli


def cli_fields(text):
    """'key: value' lines of `odyssey inspect` as a dict of strings."""
    fields = {}
    for line in text.splitlines():
        if ": " in line and not line.startswith(" "):
            key, value = line.split(": ", 1)
            fields.setdefault(key, value)
    return fields


def test_inspect_bvh_matches_the_command():
    summary = odyssey.inspect(WALK)
    code, out, _ = run_cli("inspect", WALK)
    assert code == 0
    fields = cli_fields(out)
    assert summary["kind"] == "bvh"
    assert summary["frames"] == int(fields["frames"])
    assert summary["fps"] == pytest.approx(float(fields["fps"]), rel=1e-6)
    assert summary["units"] == fields["units"]
    assert len(summary["joints"]) == int(fields["joints"])
    assert summary["joints"][0]["parent"] is None


def test_inspect_character_matches_the_command():
    summary = odyssey.inspect(FIGURE)
    code, out, _ = run_cli("inspect", FIGURE)
    assert code == 0
    fields = cli_fields(out)
    assert summary["kind"] == "character"
    assert summary["rest_height_m"] == pytest.approx(float(fields["rest height"].split()[0]), abs=1e-4)
    assert fields["rest pose"].startswith(summary["rest_pose"]["kind"] + "-pose")
    assert fields["bone map"].startswith(summary["bone_map"]["origin"] + ",")
    assert len(summary["joints"]) == int(fields["joints"])
    assert len(summary["unmapped_joints"]) == int(fields["unmapped joints"])
    assert summary["meshes"] and summary["vertices"] == sum(m["vertices"] for m in summary["meshes"])
    assert odyssey.Character(FIGURE).summary() == summary


def test_inspect_npz_and_amass(tmp_path):
    amass = write_amass(tmp_path / "walk.npz", frames=12)
    summary = odyssey.inspect(amass)
    assert summary["kind"] == "amass" and summary["frames"] == 12 and summary["fps"] == 60
    assert summary["gender"] == "neutral" and summary["betas"] == 10
    other = tmp_path / "other.npz"
    np.savez(other, a=np.zeros((2, 3), np.float32))
    assert odyssey.inspect(other)["arrays"]["a"] == {"dtype": "float32", "shape": [2, 3], "loaded": True}


def write_amass(path, frames, fps=60):
    rng = np.random.default_rng(4)
    poses = rng.normal(0, 0.2, (frames, 165))
    poses[:, :3] = [np.pi / 2, 0, 0]  # Y-up body stood in AMASS's Z-up world
    np.savez(path, poses=poses, trans=np.cumsum(np.full((frames, 3), [0.01, 0, 0]), axis=0),
             betas=np.zeros(10), gender="neutral", mocap_frame_rate=np.float64(fps))
    return str(path)


def test_load_amass_gives_the_file_arrays(tmp_path):
    path = write_amass(tmp_path / "seq.npz", frames=9)
    with np.load(path) as raw:
        sequence = odyssey.load_amass(path)
        assert sequence["model"] == "SMPL-X" and sequence["fps"] == 60
        assert np.array_equal(sequence["poses"], raw["poses"]) and np.array_equal(sequence["trans"], raw["trans"])
        assert sequence["betas"].shape == (10,)


def test_bvh_motion_world_joints_match_odyssey_pose(tmp_path):
    motion = odyssey.load_bvh(WALK)
    T, J = motion.frame_count, len(motion.joint_names)
    assert motion.rotations.shape == (T, J, 4) and motion.rotations.dtype == np.float64
    assert np.allclose(np.linalg.norm(motion.rotations, axis=2), 1, atol=1e-12)
    assert not motion.rotations.flags.writeable  # a view of the C++ clip
    joints = motion.world_joints()
    out = tmp_path / "pose.npz"
    code, _, err = run_cli("pose", "--motion", WALK, "--out", str(out))
    assert code == 0, err
    with np.load(out) as cli:
        assert list(cli["joint_names"]) == motion.joint_names
        # The command writes float32: agreement to float32 rounding of metres.
        assert np.abs(cli["joints"] - joints).max() < 1e-5
    assert motion.resampled(30).frame_count == pytest.approx(T * 30 / motion.fps, abs=1)


def test_body_model_forward_matches_the_smplx_package():
    reference = np.load(os.path.join(SMPLX_FIXTURE, "reference_flat.npz"))
    model = odyssey.BodyModel(os.path.join(SMPLX_FIXTURE, "SMPLX_FIXTURE.npz"))
    assert model.kind == "SMPL-X" and model.pose_size == 165 and len(model.joint_names) == 55
    for k in range(len(reference["case"])):
        joints, vertices = model.forward(reference["full_pose"][k:k + 1], reference["transl"][k:k + 1],
                                         reference["betas"][k], reference["expression"][k])
        # The reference computes in float64 from float32 model values (README: 1e-6 m needs doubles);
        # vertices come back float32.
        assert np.abs(joints[0] - reference["joints"][k]).max() < 1e-6
        assert np.abs(vertices[0] - reference["vertices"][k]).max() < 2e-6


def test_body_model_batches_equal_single_frames():
    model = odyssey.BodyModel.synthetic(seed=0)
    rng = np.random.default_rng(1)
    poses = rng.normal(0, 0.3, (70, model.pose_size))
    trans = rng.normal(0, 1, (70, 3))
    joints, vertices = model.forward(poses, trans)
    assert joints.shape == (70, 55, 3) and vertices.shape == (70, model.vertex_count, 3) and vertices.dtype == np.float32
    one_joints, one_vertices = model.forward(poses[65:66], trans[65:66])
    assert np.abs(one_joints[0] - joints[65]).max() < 1e-12
    assert np.abs(one_vertices[0] - vertices[65]).max() < 1e-6
    only_joints, none = model.forward(poses, trans, vertices=False)
    assert none is None and np.array_equal(only_joints, joints)
    assert model.faces.shape[1] == 3 and model.faces.max() < model.vertex_count


def test_character_arrays():
    character = odyssey.Character(CESIUM)
    vertices, triangles = character.rest_vertices, character.triangles
    assert vertices.shape == (character.vertex_count, 3) and vertices.dtype == np.float32
    assert triangles.dtype == np.uint32 and triangles.max() < character.vertex_count
    assert len(character.parents) == len(character.joint_names) and character.parents[0] == -1
