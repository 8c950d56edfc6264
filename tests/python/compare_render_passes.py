"""Compares a sequence's exact maps (depths/depth_%05d.npy, normals/normal_%05d.npy,
masks/mask_%05d.png) with Blender's Cycles passes of the same frames (tests/python/blender_passes.py),
pixel by pixel, on the pixels where both see a surface:
  depth     |z_blender - z| <= 1e-3 z (both the distance along the optical axis)
  normal    the angle between the two world normals <= 1 degree, Blender's turned to face the
            camera as the toolkit's are (n . ray <= 0, ray = R^T K^-1 (x + 0.5, y + 0.5, 1))
  instance  Blender's object index (pass_index = scene_info.json's id) = the mask's id
and the share of pixels where exactly one of the two sees a surface (silhouettes). Prints one JSON
line of shares; exits non-zero naming the first file that is missing or malformed.

Usage: compare_render_passes.py SEQUENCE_DIR PASSES_DIR FRAME[,FRAME...]
"""
import json
import os
import sys

import numpy as np
from PIL import Image

DEPTH_RELATIVE = 1e-3
NORMAL_DEGREES = 1.0


def fail(message):
    print("FAIL " + message)
    sys.exit(1)


def load(path):
    if not os.path.exists(path):
        fail(path + ": missing")
    return np.array(Image.open(path)) if path.endswith(".png") else np.load(path)


seq, passes, frames = sys.argv[1], sys.argv[2], [int(f) for f in sys.argv[3].split(",")]
anno = np.load(os.path.join(seq, "anno.npz"))
counts = {"both": 0, "depth": 0, "normal": 0, "instance": 0, "all": 0, "one_only": 0, "pixels": 0}
median_depth = 0.0  # the largest over the frames of a frame's median relative difference
for k in frames:
    depth = load(os.path.join(seq, "depths", "depth_%05d.npy" % k)).astype(np.float64)
    normal = load(os.path.join(seq, "normals", "normal_%05d.npy" % k)).astype(np.float64)
    mask = load(os.path.join(seq, "masks", "mask_%05d.png" % k))
    b_depth = load(os.path.join(passes, "depth_%05d.npy" % k)).astype(np.float64)
    b_normal = load(os.path.join(passes, "normal_%05d.npy" % k)).astype(np.float64)
    b_index = load(os.path.join(passes, "index_%05d.npy" % k))
    h, w = depth.shape
    for name, array, shape in (("normal", normal, (h, w, 3)), ("mask", mask, (h, w)), ("Blender depth", b_depth, (h, w)),
                               ("Blender normal", b_normal, (h, w, 3)), ("Blender index", b_index, (h, w))):
        if array.shape != shape:
            fail("frame %d: %s has shape %s, the depth map %s" % (k, name, array.shape, (h, w)))

    K = anno["intrinsics"][k].astype(np.float64)
    R = anno["extrinsics"][k][:3, :3].astype(np.float64)
    xs, ys = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    rays = np.stack([(xs - K[0, 2]) / K[0, 0], (ys - K[1, 2]) / K[1, 1], np.ones_like(xs)], axis=-1) @ R  # R^T d

    seen, b_seen = np.isfinite(depth), np.isfinite(b_depth)
    both = seen & b_seen
    with np.errstate(invalid="ignore"):  # inf - inf where neither sees a surface
        depth_ok = both & (np.abs(b_depth - depth) <= DEPTH_RELATIVE * depth)
    facing = np.where((np.sum(b_normal * rays, axis=-1) > 0)[..., None], -b_normal, b_normal)
    unit = facing / np.maximum(np.linalg.norm(facing, axis=-1, keepdims=True), 1e-12)
    cosine = np.sum(unit * normal, axis=-1) / np.maximum(np.linalg.norm(normal, axis=-1), 1e-12)
    normal_ok = cosine >= np.cos(np.radians(NORMAL_DEGREES))
    instance_ok = b_index == mask

    counts["pixels"] += h * w
    counts["both"] += int(both.sum())
    counts["one_only"] += int((seen != b_seen).sum())
    counts["depth"] += int((both & depth_ok).sum())
    counts["normal"] += int((both & normal_ok).sum())
    counts["instance"] += int((both & instance_ok).sum())
    counts["all"] += int((both & depth_ok & normal_ok & instance_ok).sum())
    if both.any():
        median_depth = max(median_depth, float(np.median(np.abs(b_depth[both] - depth[both]) / depth[both])))

both = max(counts["both"], 1)
print(json.dumps({"frames": len(frames), "pixels_both": counts["both"],
                  "depth_share": counts["depth"] / both, "normal_share": counts["normal"] / both,
                  "instance_share": counts["instance"] / both, "all_share": counts["all"] / both,
                  "one_only_share": counts["one_only"] / max(counts["pixels"], 1),
                  "median_depth_relative": median_depth}))
