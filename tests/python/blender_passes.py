# Blender's Cycles passes of a sequence's frames, for tests/python/compare_render_passes.py: runs
# inside Blender, imports the shot's scene.glb and places the camera exactly as `odyssey render`
# does (render/blender/render_sequence.py, imported from --render-dir), renders each asked frame
# with one sample through each pixel's centre and writes per frame
#   depth_%05d.npy   float32 [H,W]: the Z pass, +inf where the ray meets nothing
#   normal_%05d.npy  float32 [H,W,3]: the Normal pass (world, the toolkit's Z-up world), 0 where nothing
#   index_%05d.npy   uint8 [H,W]: the IndexOB pass, each mesh object's pass_index set to its
#                    instance id in scene_info.json, 0 where nothing
# rows from the top, as the toolkit's maps.
#
#   blender -b --factory-startup --python blender_passes.py -- --render-dir render/blender \
#       --sequence SEQ --glb scene.glb --out DIR --frames 0,15,30
#
# Instances. scene.glb's mesh nodes carry extras the importer keeps as custom properties:
# {"odyssey_actor": a, ...} on actor a's meshes (node "<actor>/<mesh>"), {"odyssey_prop": k} on
# prop mesh k (node named as the prop). scene_info.json numbers the actors 1 ... A and the props
# A + 1 ... in the same orders, so actor a is id a + 1 and prop k id A + 1 + k; the names are
# checked against scene_info.json's so a change of either numbering fails here, loudly.
#
# Centre rays. Cycles places a pixel's sample at its corner plus an offset drawn from the pixel
# filter; a box filter 0.01 px wide keeps every sample within 0.005 px of the pixel's centre (the
# filter is centred there), and one sample without adaptive sampling or denoising makes each
# pass value that one ray's.
import glob
import json
import os
import sys
import traceback

import numpy


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    return {argv[i].lstrip("-"): argv[i + 1] for i in range(0, len(argv) - 1, 2)}


def instance_of_object(obj, info):
    actors = [i for i in info["instances"] if i["kind"] == "actor"]
    props = [i for i in info["instances"] if i["kind"] == "prop"]
    if obj.get("odyssey_actor") is not None:
        actor = actors[int(obj["odyssey_actor"])]
        if not obj.name.startswith(actor["name"] + "/"):
            raise RuntimeError("object '%s' is actor %d, named '%s' in scene_info.json" %
                               (obj.name, obj["odyssey_actor"], actor["name"]))
        return actor["id"]
    if obj.get("odyssey_prop") is not None:
        prop = props[int(obj["odyssey_prop"])]
        if obj.name.split(".")[0] != prop["name"]:
            raise RuntimeError("object '%s' is prop %d, named '%s' in scene_info.json" %
                               (obj.name, obj["odyssey_prop"], prop["name"]))
        return prop["id"]
    raise RuntimeError("mesh object '%s' carries neither odyssey_actor nor odyssey_prop" % obj.name)


def main():
    args = parse_args()
    sys.path.insert(0, args["render-dir"])
    import bpy
    import render_sequence as rs

    intrinsics, extrinsics, info = rs.load_sequence(args["sequence"])
    fps = float(info["fps"])
    width, height = int(info["camera"]["width"]), int(info["camera"]["height"])
    scene, camera = rs.import_scene(args["glb"], fps)
    rs.drop_what_the_camera_does_not_see(info["camera"]["name"])
    rs.use_cycles_cpu(scene, 1)
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 0.01
    scene.cycles.max_bounces = 0
    for obj in scene.objects:
        if obj.type == "MESH":
            obj.pass_index = instance_of_object(obj, info)

    layer = scene.view_layers[0]
    layer.use_pass_z = True
    layer.use_pass_normal = True
    layer.use_pass_object_index = True
    scene.use_nodes = True
    scene.render.use_compositing = True
    tree = scene.node_tree
    tree.nodes.clear()
    layers = tree.nodes.new("CompositorNodeRLayers")
    output = tree.nodes.new("CompositorNodeOutputFile")
    staging = os.path.join(args["out"], "exr")
    output.base_path = staging
    output.format.file_format = "OPEN_EXR"
    output.format.color_depth = "32"
    output.format.color_mode = "RGB"
    output.format.exr_codec = "ZIP"
    output.file_slots.clear()
    for socket, name in (("Depth", "depth_"), ("Normal", "normal_"), ("IndexOB", "index_")):
        output.file_slots.new(name)
        tree.links.new(layers.outputs[socket], output.inputs[name])

    for k in [int(f) for f in args["frames"].split(",")]:
        rs.go_to_frame(scene, k, fps)
        rs.place_camera(scene, camera, intrinsics[k], extrinsics[k], width, height, width, height)
        bpy.ops.render.render(write_still=False)
        passes = {}
        for name in ("depth_", "normal_", "index_"):
            files = glob.glob(os.path.join(staging, name + "*.exr"))
            if len(files) != 1:
                raise RuntimeError("frame %d: %d %s EXR files written" % (k, len(files), name))
            image = bpy.data.images.load(files[0])
            image.colorspace_settings.name = "Non-Color"
            pixels = numpy.empty(width * height * 4, dtype=numpy.float32)
            image.pixels.foreach_get(pixels)
            if image.size[0] != width or image.size[1] != height:
                raise RuntimeError("frame %d: %s is %dx%d" % (k, files[0], image.size[0], image.size[1]))
            passes[name] = pixels.reshape(height, width, 4)[::-1, :, :3]  # Blender's rows go up
            bpy.data.images.remove(image)
            os.remove(files[0])
        depth = passes["depth_"][:, :, 0].copy()
        # Cycles writes 1e10 where the ray leaves the scene.
        empty = ~(depth < 1e9)
        depth[empty] = numpy.inf
        normal = passes["normal_"].copy()
        normal[empty] = 0
        index = numpy.rint(passes["index_"][:, :, 0]).astype(numpy.uint8)
        numpy.save(os.path.join(args["out"], "depth_%05d.npy" % k), depth.astype(numpy.float32))
        numpy.save(os.path.join(args["out"], "normal_%05d.npy" % k), normal.astype(numpy.float32))
        numpy.save(os.path.join(args["out"], "index_%05d.npy" % k), index)
        print("blender_passes: frame %d" % k, flush=True)


try:
    main()
except Exception:
    traceback.print_exc()
    sys.exit(1)
sys.exit(0)
