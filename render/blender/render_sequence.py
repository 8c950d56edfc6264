# Blender's side of `odyssey render` (render/blender_render.h): imports a shot's scene.glb, puts a
# camera of its own at every frame's pose and intrinsics from the sequence's anno.npz, and renders
# the frames with Cycles on the CPU as rgb_%05d.jpg into a folder the caller stages.
#
#   blender -b --factory-startup --python render_sequence.py -- --sequence SEQ --glb scene.glb \
#       --out FOLDER --first A --end B --samples N --width W --height H
#
# Frame k is the annotations' frame k: the glTF importer keys time t at frame t * render.fps (an
# integer), so frame k (time k / fps) is Blender frame k * render.fps / fps, set with a subframe
# when fps is not an integer.
#
# The camera (the maths; tests/python/blender_passes.py renders through the same function).
# anno.npz holds per frame the world -> camera transform E = [R | t] in OpenCV axes (x right, y
# down, z forward) and K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] in pixels of the sequence's
# image (scene_info.json's camera size). An image of W' x H' pixels scales K by sx = W' / W,
# sy = H' / H (pixel edges at integers, so u -> sx u). A Blender camera looks along its local -Z
# with +Y up: p_cv = D p_blender, D = diag(1, -1, -1), so its world matrix is [R^T D | -R^T t].
# Blender's view plane with sensor_fit HORIZONTAL (BKE_camera_params_compute_viewplane, and
# Cycles' blender_camera_viewplane likewise) spans W' pixel widths across the sensor width:
# fx = W' lens / sensor_width; a pixel is ycor = aspect_y / aspect_x widths tall, so
# fy = fx / ycor; the shift moves the view plane by shift_x W' widths and shift_y W' widths
# (= shift_y W' / ycor rows), so the principal point sits at cx = W' / 2 - shift_x W' and
# cy = H' / 2 + shift_y W' / ycor (rows counted from the top).
import math
import os
import sys
import traceback

import numpy

numpy.bool = bool  # Blender 3.4's glTF importer uses numpy.bool, an alias numpy 1.24 removed

import bpy
from mathutils import Matrix

CAMERA_NAME = "odyssey_render_camera"
SENSOR_WIDTH_MM = 36.0


def parse_args(argv):
    args = {}
    argv = argv[argv.index("--") + 1:] if "--" in argv else []
    for i in range(0, len(argv) - 1, 2):
        args[argv[i].lstrip("-")] = argv[i + 1]
    return args


def load_sequence(sequence):
    """The sequence's per-frame intrinsics [T,3,3], extrinsics [T,4,4] and scene_info.json."""
    import json
    with open(os.path.join(sequence, "scene_info.json")) as f:
        info = json.load(f)
    anno = numpy.load(os.path.join(sequence, "anno.npz"))
    return anno["intrinsics"].astype(numpy.float64), anno["extrinsics"].astype(numpy.float64), info


def shade_with_area_weighted_normals(scene):
    """Every mesh smooth-shaded with the area-weighted vertex normals of its deformed triangles,
    sum over the triangles at a vertex of (b - a) x (c - a), made unit length: the normals the
    toolkit's maps interpolate (dense_maps.h). The importer keeps the GLB's NORMAL as custom
    normals, which Blender carries through the armature in each corner's own frame and which then
    drift from the deformed mesh's wherever skinning bends it; a Weighted Normal modifier after the armature, face-area mode at weight 50 (each
    face counts its area, no more), recomputes them every frame."""
    for obj in scene.objects:
        if obj.type == "MESH":
            modifier = obj.modifiers.new("odyssey_area_normals", "WEIGHTED_NORMAL")
            modifier.mode = "FACE_AREA"
            modifier.weight = 50
            modifier.keep_sharp = False
            obj.data.use_auto_smooth = True  # the modifier writes custom normals, which need it


def import_scene(glb, fps):
    """An empty scene with scene.glb imported at the shot's frame rate (the importer keys time t at
    frame t * render.fps), no vertices merged, and shaded as the toolkit's maps are (above)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = max(1, int(round(fps)))
    scene.render.fps_base = 1.0
    bpy.ops.import_scene.gltf(filepath=glb, merge_vertices=False, import_shading="NORMALS")
    scene = bpy.context.scene
    shade_with_area_weighted_normals(scene)
    camera = bpy.data.objects.new(CAMERA_NAME, bpy.data.cameras.new(CAMERA_NAME))
    scene.collection.objects.link(camera)
    camera.data.type = "PERSP"
    camera.data.sensor_fit = "HORIZONTAL"
    camera.data.sensor_width = SENSOR_WIDTH_MM
    camera.data.clip_start = 0.01
    camera.data.clip_end = 1.0e5
    scene.camera = camera
    return scene, camera


def drop_what_the_camera_does_not_see(camera_name):
    """An ego camera's view without its wearer's head, as the toolkit draws it (frame_loop.h): the
    GLB's camera says which actor carries it and whose joint's subtree it does not see (extras
    odyssey_rides_on, odyssey_hides_subtree_of, kept by the importer as custom properties); every
    triangle of that actor with a corner whose dominant joint (largest weight, the first listed on
    a tie) lies in the subtree is deleted from its mesh. Other cameras: nothing to do."""
    import bmesh
    found = [o for o in bpy.data.objects if o.type == "CAMERA" and o.data.name == camera_name and
             o.get("odyssey_camera") is not None]
    if len(found) != 1:
        raise ValueError("scene.glb has %d cameras named '%s'" % (len(found), camera_name))
    if found[0].get("odyssey_rides_on") is None:
        return
    actor, joint = int(found[0]["odyssey_rides_on"]), str(found[0]["odyssey_hides_subtree_of"])
    meshes = [o for o in bpy.data.objects if o.type == "MESH" and o.get("odyssey_actor") == actor]
    if not meshes:
        raise ValueError("scene.glb has no mesh of actor %d, which camera '%s' rides on" % (actor, camera_name))
    for obj in meshes:
        armatures = [m.object for m in obj.modifiers if m.type == "ARMATURE" and m.object is not None]
        bone = armatures[0].data.bones.get(joint) if armatures else None
        if bone is None:
            raise ValueError("mesh '%s' is not skinned to a joint '%s'" % (obj.name, joint))
        subtree = {bone.name} | {b.name for b in bone.children_recursive}
        in_subtree = {g.index for g in obj.vertex_groups if g.name in subtree}
        hidden = set()
        for v in obj.data.vertices:
            if v.groups:
                dominant = max(v.groups, key=lambda g: g.weight)  # max keeps the first of equal weights
                if dominant.group in in_subtree:
                    hidden.add(v.index)
        mesh = bmesh.new()
        mesh.from_mesh(obj.data)
        faces = [f for f in mesh.faces if any(v.index in hidden for v in f.verts)]
        bmesh.ops.delete(mesh, geom=faces, context="FACES_ONLY")  # vertices keep their indices
        mesh.to_mesh(obj.data)
        mesh.free()


def go_to_frame(scene, k, fps):
    """Annotation frame k (time k / fps) in Blender's timeline."""
    f = k * scene.render.fps / fps
    whole = math.floor(f + 1e-9)
    scene.frame_set(whole, subframe=max(0.0, f - whole))


def place_camera(scene, camera, K, E, width, height, image_width, image_height):
    """Blender's camera and image for one frame: K, E as anno.npz holds them (image_width x
    image_height pixels), rendered at width x height (the header's maths)."""
    sx, sy = width / image_width, height / image_height
    fx, fy = K[0, 0] * sx, K[1, 1] * sy
    cx, cy = K[0, 2] * sx, K[1, 2] * sy
    if not (fx > 0 and fy > 0 and numpy.isfinite([fx, fy, cx, cy]).all() and numpy.isfinite(E).all()):
        raise ValueError("intrinsics or extrinsics not finite and positive")
    render = scene.render
    render.resolution_x, render.resolution_y = width, height
    render.resolution_percentage = 100
    # Blender's pixel aspects are >= 1: the wider of the two pixel sides gets the ratio.
    ycor = fx / fy
    render.pixel_aspect_x, render.pixel_aspect_y = (1.0 / ycor, 1.0) if ycor < 1 else (1.0, ycor)
    data = camera.data
    data.lens = fx * SENSOR_WIDTH_MM / width
    data.shift_x = (width / 2.0 - cx) / width
    data.shift_y = (cy - height / 2.0) * ycor / width
    R, t = E[:3, :3], E[:3, 3]
    to_world = numpy.eye(4)
    to_world[:3, :3] = R.T @ numpy.diag([1.0, -1.0, -1.0])
    to_world[:3, 3] = -R.T @ t
    camera.matrix_world = Matrix(to_world.tolist())


def add_light(scene):
    """A sun from above and behind the default view, a sky-coloured world: plain, even light."""
    sun = bpy.data.objects.new("odyssey_sun", bpy.data.lights.new("odyssey_sun", "SUN"))
    sun.data.energy = 2.0
    sun.data.angle = math.radians(5.0)
    sun.rotation_euler = (math.radians(40.0), math.radians(10.0), math.radians(30.0))
    scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("odyssey_sky")
    world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.55, 0.7, 0.9, 1.0)
    background.inputs["Strength"].default_value = 0.8
    scene.world = world


def use_cycles_cpu(scene, samples):
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = False
    scene.cycles.seed = 0
    scene.render.use_persistent_data = True  # the scene is synced once, not per frame
    scene.view_settings.view_transform = "Standard"


def main():
    args = parse_args(sys.argv)
    intrinsics, extrinsics, info = load_sequence(args["sequence"])
    fps = float(info["fps"])
    image_width, image_height = int(info["camera"]["width"]), int(info["camera"]["height"])
    width, height = int(args["width"]), int(args["height"])
    first, end = int(args["first"]), int(args["end"])
    if not 0 <= first < end <= len(intrinsics) or len(extrinsics) != len(intrinsics):
        raise ValueError("frames %d:%d outside the sequence's %d" % (first, end, len(intrinsics)))

    scene, camera = import_scene(args["glb"], fps)
    drop_what_the_camera_does_not_see(info["camera"]["name"])
    add_light(scene)
    use_cycles_cpu(scene, int(args["samples"]))
    scene.render.image_settings.file_format = "JPEG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.image_settings.quality = 95
    for k in range(first, end):
        go_to_frame(scene, k, fps)
        place_camera(scene, camera, intrinsics[k], extrinsics[k], width, height, image_width, image_height)
        scene.render.filepath = os.path.join(args["out"], "rgb_%05d.jpg" % k)
        bpy.ops.render.render(write_still=True)
        print("render_sequence: frame %d" % k, flush=True)


if __name__ == "__main__":
    try:
        main()
    except Exception as error:
        traceback.print_exc()
        message = str(error).splitlines()[0] if str(error) else type(error).__name__
        print("render_sequence: error: " + message, flush=True)
        sys.exit(1)
    sys.exit(0)
