# Blender as the real consumer of a scene GLB (mocap_io/scene_glb.h): imports the GLB with
# Blender's own glTF importer and checks, at a few frames, that
#   - Blender's evaluated (armature-deformed) meshes put every tracked point of the trajectory
#     files where trajs_3d says (3D error, metres), and
#   - Blender's imported cameras project trajs_3d onto trajs_2d (2D error, pixels, valid points).
# It only measures; the C++ test (tests/test_scene_blender.cpp) holds the tolerances.
#
#   blender -b --factory-startup --python check_scene_glb.py -- \
#       --glb scene.glb --fps 30 --frames 0,10,30 --report out.json \
#       --camera NAME=trajectories_NAME.npz [--camera ...]
#
# Vertex order. Blender's importer (3.4, io_scene_gltf2/blender/imp/gltf2_blender_mesh.py) builds
# a mesh's vertices primitive by primitive from np.unique(indices): the vertices some triangle
# uses, in increasing glTF order; unused ones are dropped, and nothing is merged unless the
# import asks for merge_vertices (off here, explicitly). The scene GLB writes each character mesh
# as one primitive in the character's own vertex order, and each mesh node's extras give its actor
# (or prop), its mesh and the number of its first vertex in the character's numbering (which the
# trajectory files' point_vertex_ids use). So the Blender vertex of character vertex n in mesh m
# is the rank of n - first_vertex among that primitive's used indices, computed here from the
# GLB's own index accessor. Mapping by nearest rest position was rejected: characters have
# coincident vertices (seams), which would make it ambiguous. The mapping is checked: the vertex
# count of each Blender mesh must equal the number of used glTF vertices, and every tracked
# point's corners must be used ones.
import sys
import json
import struct
import traceback

import numpy

numpy.bool = bool  # Blender 3.4's glTF importer uses numpy.bool, an alias numpy 1.24 removed

import bpy
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    args = {"cameras": []}
    i = 0
    while i < len(argv):
        key, value = argv[i], argv[i + 1]
        if key == "--camera":
            name, path = value.split("=", 1)
            args["cameras"].append((name, path))
        else:
            args[key.lstrip("-")] = value
        i += 2
    args["fps"] = float(args["fps"])
    args["frames"] = [int(f) for f in args["frames"].split(",")]
    return args


COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}
DTYPES = {5121: numpy.uint8, 5123: numpy.uint16, 5125: numpy.uint32, 5126: numpy.float32}


def read_glb(path):
    data = open(path, "rb").read()
    magic, version, length = struct.unpack_from("<III", data, 0)
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
    offset = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    values = numpy.frombuffer(binary, dtype=dtype, count=a["count"] * n, offset=offset)
    return values.reshape(a["count"], n)


def main():
    args = parse_args()
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    # Before the import: the importer places keys at time * render.fps.
    if args["fps"] != round(args["fps"]):
        raise RuntimeError("the importer keys frames at time * render.fps, an integer: %g fps cannot be checked" % args["fps"])
    scene.render.fps = int(round(args["fps"]))
    scene.render.fps_base = 1.0
    bpy.ops.import_scene.gltf(filepath=args["glb"], merge_vertices=False)
    scene = bpy.context.scene

    doc, binary = read_glb(args["glb"])

    # Owners: ("actor", a) or ("props",); per owner its written meshes.
    owners = {}
    for node in doc["nodes"]:
        extras = node.get("extras", {})
        if "odyssey_actor" in extras:
            owner, mesh_id = ("actor", extras["odyssey_actor"]), extras["odyssey_mesh"]
        elif "odyssey_prop" in extras:
            owner, mesh_id = ("props",), extras["odyssey_prop"]
        else:
            continue
        primitive = doc["meshes"][node["mesh"]]["primitives"][0]
        used = numpy.unique(accessor(doc, binary, primitive["indices"]).ravel())
        count = doc["accessors"][primitive["attributes"]["POSITION"]]["count"]
        blender_of = numpy.full(count, -1, dtype=numpy.int64)
        blender_of[used] = numpy.arange(len(used))
        owners.setdefault(owner, []).append({"name": node["name"], "first": extras["odyssey_first_vertex"], "count": count,
                                             "blender_of": blender_of, "used": len(used),
                                             "key": "odyssey_actor" if owner[0] == "actor" else "odyssey_prop",
                                             "key_value": owner[1] if owner[0] == "actor" else mesh_id, "mesh_id": mesh_id})
    # Blender objects carry the node extras as custom properties.
    for meshes in owners.values():
        for mesh in meshes:
            found = [o for o in bpy.data.objects if o.type == "MESH" and o.get(mesh["key"]) == mesh["key_value"] and
                     (mesh["key"] == "odyssey_prop" or o.get("odyssey_mesh") == mesh["mesh_id"])]
            if not found:
                # A skinned node whose morph weights are animated (a vertex-animated actor) comes in
                # as a mesh object named after the node plus an empty that keeps the node's extras.
                found = [o for o in bpy.data.objects if o.type == "MESH" and o.name == mesh["name"]]
            if len(found) != 1:
                raise RuntimeError("%d Blender objects for GLB node '%s'" % (len(found), mesh["name"]))
            mesh["object"] = found[0]
            vertices = len(found[0].data.vertices)
            if vertices != mesh["used"]:
                raise RuntimeError("Blender mesh '%s' has %d vertices, the GLB's primitive uses %d" %
                                   (found[0].name, vertices, mesh["used"]))
    total = {owner: max(m["first"] + m["count"] for m in meshes) for owner, meshes in owners.items()}

    cameras = []
    for name, path in args["cameras"]:
        node = next(i for i, n in enumerate(doc["nodes"]) if n.get("name") == name and "camera" in n)
        index = doc["nodes"][node]["extras"]["odyssey_camera"]
        found = [o for o in bpy.data.objects if o.type == "CAMERA" and o.get("odyssey_camera") == index]
        if len(found) != 1:
            raise RuntimeError("%d Blender cameras for GLB camera '%s'" % (len(found), name))
        cameras.append((name, found[0], numpy.load(path)))
    if not cameras:
        raise RuntimeError("no trajectory file given")

    reference = cameras[0][2]
    vertex_ids = reference["point_vertex_ids"].astype(numpy.int64)
    barycentric = reference["point_barycentric"].astype(numpy.float64)
    owner_ids = reference["point_actor_ids"].astype(numpy.int64)
    point_owner = [("actor", int(o)) if o >= 0 else ("props",) for o in owner_ids]

    report = {"frames": args["frames"], "points": int(len(owner_ids)), "max_error_3d_m": 0.0,
              "max_error_3d_m_by_owner": {}, "cameras": {}}
    for name, _, _ in cameras:
        report["cameras"][name] = {"max_error_px": 0.0, "valid_point_frames": 0}

    depsgraph = bpy.context.evaluated_depsgraph_get()
    for frame in args["frames"]:
        scene.frame_set(frame)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        # Blender's world (Z up, the importer's Y-up -> Z-up conversion) is the toolkit's world.
        world = {owner: numpy.full((total[owner], 3), numpy.nan) for owner in owners}
        for owner, meshes in owners.items():
            for mesh in meshes:
                evaluated = mesh["object"].evaluated_get(depsgraph)
                data = evaluated.to_mesh()
                co = numpy.empty(len(data.vertices) * 3, dtype=numpy.float64)
                data.vertices.foreach_get("co", co)
                evaluated.to_mesh_clear()
                matrix = numpy.array(evaluated.matrix_world, dtype=numpy.float64)
                co = co.reshape(-1, 3) @ matrix[:3, :3].T + matrix[:3, 3]
                ids = numpy.nonzero(mesh["blender_of"] >= 0)[0]
                world[owner][mesh["first"] + ids] = co[mesh["blender_of"][ids]]
        blender_points = numpy.empty((len(owner_ids), 3))
        for i, owner in enumerate(point_owner):
            corners = world[owner][vertex_ids[i]]
            if numpy.isnan(corners).any():
                raise RuntimeError("point %d names a vertex no Blender mesh has" % i)
            blender_points[i] = barycentric[i] @ corners
        trajs_3d = reference["trajs_3d"][frame].astype(numpy.float64)
        error = numpy.linalg.norm(blender_points - trajs_3d, axis=1)
        report["max_error_3d_m"] = max(report["max_error_3d_m"], float(error.max()))
        for owner in owners:
            label = "actor %d" % owner[1] if owner[0] == "actor" else "props"
            mask = numpy.array([o == owner for o in point_owner])
            if mask.any():
                by_owner = report["max_error_3d_m_by_owner"]
                by_owner[label] = max(by_owner.get(label, 0.0), float(error[mask].max()))

        for name, camera, trajectories in cameras:
            k = trajectories["intrinsics"][frame]
            width, height = int(round(2 * k[0, 2])), int(round(2 * k[1, 2]))
            scene.render.resolution_x, scene.render.resolution_y = width, height
            scene.render.resolution_percentage = 100
            scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1
            scene.camera = camera
            points = trajectories["trajs_3d"][frame].astype(numpy.float64)
            pixels = trajectories["trajs_2d"][frame].astype(numpy.float64)
            valid = trajectories["valids"][frame]
            worst = report["cameras"][name]["max_error_px"]
            for i in numpy.nonzero(valid)[0]:
                ndc = world_to_camera_view(scene, camera, Vector(points[i]))
                u, v = ndc.x * width, (1.0 - ndc.y) * height
                worst = max(worst, float(numpy.hypot(u - pixels[i, 0], v - pixels[i, 1])))
            report["cameras"][name]["max_error_px"] = worst
            report["cameras"][name]["valid_point_frames"] += int(numpy.count_nonzero(valid))
    with open(args["report"], "w") as out:
        json.dump(report, out, indent=1)
    print("check_scene_glb:", json.dumps(report))


try:
    main()
except Exception:
    traceback.print_exc()
    sys.exit(1)
sys.exit(0)
