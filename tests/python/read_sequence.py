"""Reads a PointOdyssey-layout sequence the way the trackers' loaders do (numpy and PIL), checks
every file name, key, dtype and shape, decodes depth as value / 65535 * 1000, and measures how
many points visible in each frame land on a mask pixel of their own instance (the pixel holding
them, and within one pixel of it: a pixel is sampled at its centre, up to 0.7 px from the point,
so on a silhouette it may show what lies behind) at the depth the depth map holds there. Prints one JSON line of figures; exits non-zero naming the first problem.

Usage: read_sequence.py SEQUENCE_DIR
"""
import json
import os
import sys

import numpy as np
from PIL import Image


def fail(message):
    print("FAIL " + message)
    sys.exit(1)


seq = sys.argv[1]
anno = np.load(os.path.join(seq, "anno.npz"))
want = {"trajs_2d": np.float32, "trajs_3d": np.float32, "visibs": np.bool_, "valids": np.bool_,
        "intrinsics": np.float32, "extrinsics": np.float32, "visibilities": np.uint8}
for key, dtype in want.items():
    if key not in anno:
        fail("anno.npz has no " + key)
    if anno[key].dtype != dtype:
        fail("anno.npz %s is %s, not %s" % (key, anno[key].dtype, np.dtype(dtype)))
T, N = anno["trajs_2d"].shape[:2]
shapes = {"trajs_2d": (T, N, 2), "trajs_3d": (T, N, 3), "visibs": (T, N), "valids": (T, N),
          "intrinsics": (T, 3, 3), "extrinsics": (T, 4, 4), "visibilities": (T, N)}
for key, shape in shapes.items():
    if anno[key].shape != shape:
        fail("anno.npz %s has shape %s, not %s" % (key, anno[key].shape, shape))
info = np.load(os.path.join(seq, "info.npz"))
if tuple(info["trajs_3d"]) != (T, N, 3):
    fail("info.npz trajs_3d is %s, not %s" % (tuple(info["trajs_3d"]), (T, N, 3)))
visibs, visibilities = anno["visibs"], anno["visibilities"]
if not np.array_equal(visibs, visibilities == 1):
    fail("visibilities == 1 is not visibs")
scene_info = json.load(open(os.path.join(seq, "scene_info.json")))
instances = {i["id"]: i for i in scene_info["instances"]}
actors = sum(1 for i in scene_info["instances"] if i["kind"] == "actor")
owner = anno["point_actor_ids"]
instance_of_point = np.where(owner >= 0, owner + 1, actors + 1 + (-1 - owner))

hits = near = checked = depth_ok = 0
for k in range(T):
    depth_png = Image.open(os.path.join(seq, "depths", "depth_%05d.png" % k))
    mask_png = Image.open(os.path.join(seq, "masks", "mask_%05d.png" % k))
    normal_jpg = Image.open(os.path.join(seq, "normals", "normal_%05d.jpg" % k))
    if mask_png.mode != "L":
        fail("mask %d has mode %s, not L (8-bit single channel)" % (k, mask_png.mode))
    if depth_png.mode not in ("I;16", "I"):
        fail("depth %d has mode %s, not 16-bit" % (k, depth_png.mode))
    if normal_jpg.mode != "RGB":
        fail("normal %d has mode %s" % (k, normal_jpg.mode))
    depth = np.array(depth_png).astype(np.float32) / 65535.0 * 1000.0
    mask = np.array(mask_png)
    H, W = mask.shape
    if depth.shape != (H, W) or np.array(normal_jpg).shape != (H, W, 3):
        fail("frame %d: the maps' sizes differ" % k)
    if (W, H) != (scene_info["camera"]["width"], scene_info["camera"]["height"]):
        fail("frame %d: the maps are %dx%d, scene_info.json's camera is %dx%d"
             % (k, W, H, scene_info["camera"]["width"], scene_info["camera"]["height"]))
    if set(np.unique(mask)) - set([0]) - set(instances):
        fail("frame %d: mask ids %s not in scene_info.json" % (k, sorted(set(np.unique(mask)) - set(instances))))
    uv = anno["trajs_2d"][k]
    fx = float(anno["intrinsics"][k][0, 0])
    E = anno["extrinsics"][k]
    cam = (E[:3, :3] @ anno["trajs_3d"][k].T).T + E[:3, 3]
    for i in np.nonzero(visibs[k])[0]:
        x, y = int(uv[i, 0]), int(uv[i, 1])
        checked += 1
        hits += mask[y, x] == instance_of_point[i]
        window = (slice(max(y - 1, 0), y + 2), slice(max(x - 1, 0), x + 2))
        own = mask[window] == instance_of_point[i]
        near += bool(own.any())
        # Its own surface around it spans its depth: within the range the window's pixels of its
        # instance hold (a slanted surface changes depth across the window), give or take the
        # PNG's half step and a pixel's footprint (z / fx metres).
        if own.any():
            spread = depth[window][own]
            tolerance = 0.008 + cam[i, 2] / fx
            depth_ok += spread.min() - tolerance <= cam[i, 2] <= spread.max() + tolerance

if checked == 0:
    fail("no visible points")
print(json.dumps({"frames": int(T), "points": int(N), "visible_point_frames": checked,
                  "on_own_mask": hits / checked, "near_own_mask": near / checked, "depth_agrees": depth_ok / checked}))
