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
#                          horizontally. "floor": heights from z = 0, the floor the character
#                          stands on in the exported scene, h = 5 cm * s, v = 0.5 m/s * s (s = the
#                          character's size over the performer's), the same floor at every
#                          quality, so that feet sinking below it do not lower the floor they are
#                          judged from; "gmd": GMD's, heights from the clip's own lowest foot joint,
#                          5 cm and 0.5 m/s, for comparison with published figures only;
#   spine bend             the mean over frames of |b_T - b_S|, b the angle between the spine's first
#                          segment and its last ("bend": [a, b, c, d] canonical: a -> b against
#                          c -> d);
#   proportions            "leg_ratio": the shorter of the target's thigh (hip -> knee) and shin
#                          (knee -> ankle), each over s times the performer's, both legs, first
#                          frame (the bones are rigid);
#                          "swing_clearance": per foot, the highest its lowest joint gets above
#                          z = 0 while the performer's foot is in the swing (the performer's
#                          lowest foot joint more than 5 cm above its own lowest), over 5 cm * s;
#                          the smaller of the two feet. Under 1: the foot never clears its own
#                          skate threshold in the swing;
#   jitter                 the mean over joints and frames of |x[t+1] - 2 x[t] + x[t-1]| * fps^2 over
#                          the mapped joints (m/s^2), the target's, and the source's times s (the
#                          performer at the character's size, so the ratio compares like with like).
#
#   blender -b --factory-startup --python measure_retarget.py -- --jobs jobs.json --out out.json
#
# jobs.json: [{"glb", "source_npz", "fps", "scale", "levelling_wxyz", "map": [{"canonical", "source", "target"}],
# "limbs": {limb: [[parent canonical, child canonical], ...]}, "feet": [canonical, ...],
# "legs": [[hip, knee, ankle] canonical, per side], "bend": [a, b, c, d]}].
# Output: one entry per job: {"frames", "limbs": {limb: mean deg}, "limbs_raw", "spine_bend",
# "skate_floor", "skate_gmd", "leg_ratio", "swing_clearance", "jitter", "source_jitter"}. Both worlds are
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
    a, b, c, d = (canonical[name] for name in job["bend"])
    def bend(positions):
        return numpy.degrees(numpy.arccos(numpy.clip(numpy.sum(directions(positions, [(a, b)]) * directions(positions, [(c, d)]), axis=2), -1, 1)))
    result["spine_bend"] = float(numpy.abs(bend(target) - bend(src)).mean())
    feet = [canonical[name] for name in job["feet"] if name in canonical]
    result["skate_floor"] = skate_ratio(target[:, feet], fps, 0.05 * scale, 0.5 * scale, floor=0.0)
    result["skate_gmd"] = skate_ratio(target[:, feet], fps, 0.05, 0.5)
    legs = [[canonical[name] for name in leg] for leg in job["legs"]]
    def leg_length(positions, leg):
        return sum(numpy.linalg.norm(positions[0, b] - positions[0, a]) for a, b in zip(leg, leg[1:]))
    # The shorter of the thigh and the shin, each against the scaled performer's, both sides.
    def bone_ratio(a, b):
        return sum(leg_length(target, [leg[a], leg[b]]) for leg in legs) / (scale * sum(leg_length(src, [leg[a], leg[b]]) for leg in legs))
    result["leg_ratio"] = min(bone_ratio(0, 1), bone_ratio(1, 2))
    clearances = []
    for prefix in ("left_", "right_"):
        side = [canonical[name] for name in job["feet"] if name.startswith(prefix) and name in canonical]
        source_low = src[:, side, 2].min(axis=1)
        swing = source_low - source_low.min() > 0.05
        if swing.any():
            clearances.append(float(target[swing][:, side, 2].min(axis=1).max()) / (0.05 * scale))
    result["swing_clearance"] = min(clearances) if clearances else None
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
    with open(args["out"], "w") as out:
        json.dump(results, out)


try:
    main()
except Exception:
    traceback.print_exc()
    sys.exit(1)
sys.exit(0)
