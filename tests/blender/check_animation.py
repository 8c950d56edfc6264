# Blender as the oracle of a glTF character's own animation (skeleton/node_animation.h): imports
# the file with Blender's own glTF importer, makes the named animation the only one playing, and
# writes the world positions of every mesh vertex at the given times, for the C++ test
# (tests/test_animation_blender.cpp) to compare with odyssey's point cache of the same animation.
#
#   blender -b --factory-startup --python check_animation.py -- \
#       --file character.glb --animation Walk --fps 24 --times 0,0.25,0.5 --out positions.json
#
# Which animation plays. The importer (3.4) makes one action per animation and animated object,
# named "<animation>_<object>", makes the first the active action and stashes every animation in
# an NLA track named after it. Here every animated object gets its track's action of the named
# animation as its active action (or none, when that animation does not move it) and its NLA
# tracks are removed, so nothing else is blended in.
#
# Time. The importer keys frame time * render.fps, so render.fps is set to --fps (an integer)
# before the import; time t is evaluated at frame t * fps, its fraction as the subframe.
#
# Vertex order. The importer builds a mesh object's vertices primitive by primitive from
# np.unique(indices) (unused vertices dropped, nothing merged with merge_vertices off), and names
# the object after its node. For each mesh node of the default scene, in node index order (the
# order odyssey's loader lists meshes), the output holds per primitive one row per glTF vertex,
# null where no triangle uses it. Output JSON: {"times": [...], "meshes": [{"node", "primitive",
# "positions": [time][vertex][3] }]}, Blender's world (Z up, as odyssey's).
import json
import struct
import sys
import traceback

import numpy

numpy.bool = bool  # Blender 3.4's glTF importer uses numpy.bool, an alias numpy 1.24 removed

import bpy

COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}
DTYPES = {5121: numpy.uint8, 5123: numpy.uint16, 5125: numpy.uint32, 5126: numpy.float32}


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    args = dict(zip([a.lstrip("-") for a in argv[0::2]], argv[1::2]))
    args["fps"] = float(args["fps"])
    args["times"] = [float(t) for t in args["times"].split(",")]
    return args


def read_glb(path):
    data = open(path, "rb").read()
    magic, version, _ = struct.unpack_from("<III", data, 0)
    assert magic == 0x46546C67 and version == 2, "not a GLB 2"
    json_length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + json_length])
    bin_at = 20 + json_length
    bin_length = struct.unpack_from("<I", data, bin_at)[0]
    return doc, data[bin_at + 8:bin_at + 8 + bin_length]


def accessor(doc, binary, index):
    a = doc["accessors"][index]
    view = doc["bufferViews"][a["bufferView"]]
    n = COMPONENTS[a["type"]]
    dtype = DTYPES[a["componentType"]]
    stride = view.get("byteStride", 0)
    offset = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    size = numpy.dtype(dtype).itemsize * n
    if stride and stride != size:
        rows = [numpy.frombuffer(binary, dtype=dtype, count=n, offset=offset + i * stride) for i in range(a["count"])]
        return numpy.array(rows)
    return numpy.frombuffer(binary, dtype=dtype, count=a["count"] * n, offset=offset).reshape(a["count"], n)


def scene_mesh_nodes(doc):
    scene = doc["scenes"][doc.get("scene", 0)]
    parent_children = {i: n.get("children", []) for i, n in enumerate(doc["nodes"])}
    shown, stack = set(), list(scene["nodes"])
    while stack:
        node = stack.pop()
        shown.add(node)
        stack.extend(parent_children[node])
    return [i for i in sorted(shown) if "mesh" in doc["nodes"][i]]


def play_only(animation):
    for obj in bpy.data.objects:
        data = obj.animation_data
        if data is None:
            continue
        chosen = None
        for track in data.nla_tracks:
            if track.name == animation and track.strips:
                chosen = track.strips[0].action
        for track in list(data.nla_tracks):
            data.nla_tracks.remove(track)
        data.action = chosen


def main():
    args = parse_args()
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    if args["fps"] != round(args["fps"]):
        raise RuntimeError("the importer keys frames at time * render.fps, an integer: %g fps cannot be used" % args["fps"])
    scene.render.fps = int(round(args["fps"]))
    scene.render.fps_base = 1.0
    bpy.ops.import_scene.gltf(filepath=args["file"], merge_vertices=False)
    scene = bpy.context.scene
    play_only(args["animation"])

    doc, binary = read_glb(args["file"])
    meshes = []
    for node_index in scene_mesh_nodes(doc):
        node = doc["nodes"][node_index]
        found = [o for o in bpy.data.objects if o.type == "MESH" and o.name == node["name"]]
        if len(found) != 1:
            raise RuntimeError("%d Blender objects named '%s'" % (len(found), node["name"]))
        first = 0
        for p, primitive in enumerate(doc["meshes"][node["mesh"]]["primitives"]):
            count = doc["accessors"][primitive["attributes"]["POSITION"]]["count"]
            used = numpy.unique(accessor(doc, binary, primitive["indices"]).ravel()) if "indices" in primitive \
                else numpy.arange(count)
            meshes.append({"node": node["name"], "primitive": p, "object": found[0], "first": first, "used": used,
                           "count": count, "positions": []})
            first += len(used)
        if first != len(found[0].data.vertices):
            raise RuntimeError("Blender mesh '%s' has %d vertices, the file's primitives use %d" %
                               (found[0].name, len(found[0].data.vertices), first))

    depsgraph = bpy.context.evaluated_depsgraph_get()
    for t in args["times"]:
        frame = t * scene.render.fps
        whole = int(numpy.floor(frame))
        scene.frame_set(whole, subframe=frame - whole)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        for mesh in meshes:
            evaluated = mesh["object"].evaluated_get(depsgraph)
            data = evaluated.to_mesh()
            world = evaluated.matrix_world
            rows = [None] * mesh["count"]
            for k, vertex in enumerate(mesh["used"]):
                co = world @ data.vertices[mesh["first"] + k].co
                rows[int(vertex)] = [co.x, co.y, co.z]
            evaluated.to_mesh_clear()
            mesh["positions"].append(rows)
    out = {"times": args["times"],
           "meshes": [{"node": m["node"], "primitive": m["primitive"], "positions": m["positions"]} for m in meshes]}
    with open(args["out"], "w") as f:
        json.dump(out, f)


try:
    main()
except Exception:
    traceback.print_exc()
    sys.exit(1)
