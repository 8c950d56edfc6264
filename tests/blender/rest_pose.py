# Blender as the oracle of a glTF character's rest pose (mocap_io/gltf_character.h, "The bind
# pose"): imports the file with Blender's own glTF importer at its defaults (which guess the
# original bind pose from the inverse bind matrices), puts every armature in its rest position,
# and writes where each bone's head rests and the bounds of the evaluated meshes, for the C++ test
# (tests/test_any_humanoid_blender.cpp) to compare with odyssey's rest pose.
#
#   blender -b --factory-startup --python rest_pose.py -- --file character.glb --out rest.json
#
# Output JSON: {"bones": {name: [x, y, z]}, "bounds": [min x, y, z, max x, y, z]}, Blender's world
# (Z up, as odyssey's). Bones are named after their nodes.
import json
import sys
import traceback

import numpy

numpy.bool = bool  # Blender 3.4's glTF importer uses numpy.bool, an alias numpy 1.24 removed

import bpy


def main():
    argv = sys.argv[sys.argv.index("--") + 1:]
    path = argv[argv.index("--file") + 1]
    out = argv[argv.index("--out") + 1]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=path)
    bones = {}
    for obj in bpy.context.scene.objects:
        if obj.type == "ARMATURE":
            obj.data.pose_position = "REST"
            for bone in obj.data.bones:
                head = obj.matrix_world @ bone.head_local
                bones[bone.name] = [head.x, head.y, head.z]
    bpy.context.view_layer.update()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    low = [float("inf")] * 3
    high = [float("-inf")] * 3
    for obj in bpy.context.scene.objects:
        if obj.type != "MESH":
            continue
        evaluated = obj.evaluated_get(depsgraph)
        mesh = evaluated.to_mesh()
        for vertex in mesh.vertices:
            p = evaluated.matrix_world @ vertex.co
            for k in range(3):
                low[k] = min(low[k], p[k])
                high[k] = max(high[k], p[k])
        evaluated.to_mesh_clear()
    with open(out, "w") as f:
        json.dump({"bones": bones, "bounds": low + high}, f)


try:
    main()
except Exception:
    traceback.print_exc()
    sys.exit(1)
