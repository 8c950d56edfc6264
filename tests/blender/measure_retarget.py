# Blender as the independent judge of a retargeted GLB (tests/test_retarget_blender.cpp): imports
# each file with Blender's own glTF importer, plays its animation frame by frame, reads the joints'
# world positions (pose bone heads), and scores them against the source performer's world joints
# (an `odyssey pose` npz of the same clip at the same rate) with the metric definitions of
# ARCHITECTURE.md, written here from those definitions alone (no odyssey code):
#
#   limb direction error   per limb, the mean over its bones and frames of the angle between the
#                          target bone (parent joint -> child joint) and the source's mapped bone;
#   foot skate ratio       the share of (foot joint, frame transition) pairs in which the joint is
#                          within h of the ground in both frames and moves faster than v
#                          horizontally; heights from the clip's lowest foot-joint height (GMD).
#                          "scaled": h = 5 cm * s, v = 0.5 m/s * s (s = the character's size over the
#                          performer's); "gmd": 5 cm and 0.5 m/s; the source's at s = 1;
#                          "shared floor": scaled, with heights from the lowest foot-joint
#                          height of all the jobs of one "floor_group" (the same character and
#                          clip at every quality), so that a file whose feet sink below the
#                          floor does not lower its own floor and hide its sliding;
#   jitter                 the mean over joints and frames of |x[t+1] - 2 x[t] + x[t-1]| * fps^2 over
#                          the mapped joints (m/s^2), the target's, and the source's times s (the
#                          performer at the character's size, so the ratio compares like with like).
#
#   blender -b --factory-startup --python measure_retarget.py -- --jobs jobs.json --out out.json
#
# jobs.json: [{"glb", "source_npz", "fps", "scale", "levelling_wxyz", "map": [{"canonical", "source", "target"}],
# "limbs": {limb: [[parent canonical, child canonical], ...]}, "feet": [canonical, ...],
# "floor_group"}].
# Output: one entry per job: {"frames", "limbs": {limb: mean deg}, "limbs_raw", "skate_scaled",
# "skate_gmd", "skate_shared_floor", "source_skate", "jitter", "source_jitter"}. Both worlds are
# Z up (Blender converts glTF's Y up). The source is compared levelled by the report's rotation
# (limbs, skate, jitter), and as recorded (limbs_raw).
import json
import sys
import traceback

import numpy

numpy.bool = bool  # Blender 3.4's glTF importer uses numpy.bool, an alias numpy 1.24 removed

import bpy


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    return dict(zip([a.lstrip("-") for a in argv[0::2]], argv[1::2]))


def clear_scene():
    for collection in (bpy.data.objects, bpy.data.meshes, bpy.data.armatures, bpy.data.actions, bpy.data.cameras):
        for block in list(collection):
            collection.remove(block)


def target_positions(glb, fps, joint_names):
    """[frames, joints, 3] world positions of the named joints, played at `fps`."""
    clear_scene()
    bpy.context.scene.render.fps = int(round(fps))  # before the import, or it keys at 24 fps
    bpy.context.scene.render.fps_base = 1.0
    bpy.ops.import_scene.gltf(filepath=glb)
    armatures = [o for o in bpy.context.scene.objects if o.type == "ARMATURE"]
    assert len(armatures) == 1, "expected one armature, found %d" % len(armatures)
    armature = armatures[0]
    action = armature.animation_data.action
    first, last = (int(round(f)) for f in action.frame_range)
    # odyssey names an unnamed joint node "joint_<node index>" in its reports; Blender names it
    # "Node_<node index>".
    def bone(name):
        if name in armature.pose.bones:
            return armature.pose.bones[name]
        if name.startswith("joint_") and name[6:].isdigit():
            return armature.pose.bones["Node_" + name[6:]]
        raise KeyError("no bone %s in %s" % (name, glb))

    bones = [bone(name) for name in joint_names]
    positions = numpy.zeros((last - first + 1, len(bones), 3))
    for k, frame in enumerate(range(first, last + 1)):
        bpy.context.scene.frame_set(frame)
        world = armature.matrix_world
        for j, bone in enumerate(bones):
            positions[k, j] = tuple(world @ bone.head)
    return positions


def rotation(wxyz):
    w, x, y, z = wxyz
    return numpy.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def directions(positions, pairs):
    vectors = positions[:, [c for _, c in pairs]] - positions[:, [p for p, _ in pairs]]
    return vectors / numpy.linalg.norm(vectors, axis=2, keepdims=True)


def skate_ratio(feet, fps, height_m, speed_m_s, floor=None):
    heights = feet[:, :, 2] - (feet[:, :, 2].min() if floor is None else floor)
    low = (heights[1:] < height_m) & (heights[:-1] < height_m)
    speed = numpy.linalg.norm(feet[1:, :, :2] - feet[:-1, :, :2], axis=2) * fps
    return float(numpy.mean(low & (speed > speed_m_s)))


def jitter(positions, fps):
    second = positions[2:] - 2 * positions[1:-1] + positions[:-2]
    return float(numpy.mean(numpy.linalg.norm(second, axis=2)) * fps * fps)


def measure(job):
    fps, scale = job["fps"], job["scale"]
    source = numpy.load(job["source_npz"])
    source_index = {str(name): i for i, name in enumerate(source["joint_names"])}
    mapped = [entry for entry in job["map"] if entry["source"] in source_index]
    canonical = {entry["canonical"]: k for k, entry in enumerate(mapped)}
    target = target_positions(job["glb"], fps, [entry["target"] for entry in mapped])
    raw = source["joints"][:, [source_index[entry["source"]] for entry in mapped]].astype(float)
    frames = min(len(target), len(raw))
    target, raw = target[:frames], raw[:frames]
    # The retargeting levels the performer's floor (the report's source.levelling, world ->
    # levelled): compare with the levelled source, and also with the raw one.
    src = raw @ rotation(job["levelling_wxyz"]).T
    result = {"frames": frames, "limbs": {}, "limbs_raw": {}}
    for limb, bones in job["limbs"].items():
        pairs = [(canonical[p], canonical[c]) for p, c in bones if p in canonical and c in canonical]
        if not pairs:
            continue
        for key, performer in (("limbs", src), ("limbs_raw", raw)):
            cosines = numpy.clip(numpy.sum(directions(target, pairs) * directions(performer, pairs), axis=2), -1.0, 1.0)
            result[key][limb] = float(numpy.degrees(numpy.arccos(cosines)).mean())
    feet = [canonical[name] for name in job["feet"] if name in canonical]
    result["skate_scaled"] = skate_ratio(target[:, feet], fps, 0.05 * scale, 0.5 * scale)
    result["skate_gmd"] = skate_ratio(target[:, feet], fps, 0.05, 0.5)
    result["feet"] = target[:, feet]  # for the shared floor, once every job is measured
    result["source_skate"] = skate_ratio(src[:, feet], fps, 0.05, 0.5)
    result["jitter"] = jitter(target, fps)
    result["source_jitter"] = jitter(src, fps) * scale  # the performer at the character's size
    return result


def main():
    args = parse_args()
    jobs = json.load(open(args["jobs"]))
    results = []
    for job in jobs:
        try:
            results.append(measure(job))
        except Exception:
            results.append({"error": traceback.format_exc()})
    floors = {}
    for job, result in zip(jobs, results):
        if "feet" in result:
            group = job["floor_group"]
            floors[group] = min(floors.get(group, numpy.inf), float(result["feet"][:, :, 2].min()))
    for job, result in zip(jobs, results):
        if "feet" in result:
            feet, scale = result.pop("feet"), job["scale"]
            result["skate_shared_floor"] = skate_ratio(feet, job["fps"], 0.05 * scale, 0.5 * scale, floors[job["floor_group"]])
    with open(args["out"], "w") as out:
        json.dump(results, out)


try:
    main()
except Exception:
    traceback.print_exc()
    sys.exit(1)
sys.exit(0)
