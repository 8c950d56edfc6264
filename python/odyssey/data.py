"""Reading what odyssey writes: PointOdyssey-layout sequences and datasets of them, as numpy arrays
with the point trackers' loaders' conventions. Pure Python (numpy; PIL for the images); a
torch.utils.data.Dataset when torch imports, a plain sequence of samples when it does not.

A sequence is one folder per camera, <scene>_<camera>/ (docs/sequences.md):

    anno.npz                  trajs_2d float32 [T, N, 2] pixels; trajs_3d float32 [T, N, 3] world metres
                              (Z up); visibs, valids bool [T, N]; intrinsics float32 [T, 3, 3];
                              extrinsics float32 [T, 4, 4] world -> camera, OpenCV axes; visibilities
                              uint8 [T, N]; visibility_codes, point_vertex_ids, point_barycentric,
                              point_actor_ids, fps
    depths/depth_%05d.png     16-bit: metres = value / 65535 * 1000 (65535: no surface)
    normals/normal_%05d.jpg   8-bit RGB: n = value / 255 * 2 - 1, world unit normals
    masks/mask_%05d.png       8-bit instance ids (0: nothing; scene_info.json names them)
    rgbs/rgb_%05d.jpg         8-bit RGB frames (written by `odyssey render`)
    scene_info.json           instances, camera, fps, counts

A dataset is a folder of splits holding sequences, <root>/<split>/<seq>_<camera>/; any folder whose
subfolders (at any depth) hold anno.npz is read as one.

Conventions of what is returned (those of the PointOdyssey and CoTracker loaders): images frame
first and channels last, rgbs uint8 [S, H, W, 3]; depths float32 [S, H, W] in metres (decoded from
the PNG, or the exact .npy where written and exact=True), with +inf where no surface; normals
float32 [S, H, W, 3] in [-1, 1] (0 where no surface in the exact maps; (128, 128, 128) decodes to
about 0.004 in the JPEGs); masks uint8 [S, H, W]; trajectories as in anno.npz, sliced to the clip's
frames. A loader that wants [S, 3, H, W] tensors transposes: torch.from_numpy(rgbs).permute(0, 3, 1, 2).
"""

import json
import os

import numpy as np

try:  # torch is optional: with it the dataset plugs into DataLoader, without it it is still indexable
    import torch.utils.data as _torch_data

    _DatasetBase = _torch_data.Dataset
except ImportError:  # pragma: no cover - depends on the machine
    _DatasetBase = object

__all__ = ["Sequence", "Dataset", "find_sequences", "MAPS", "TRACK_KEYS"]

# The maps a sequence may hold: the folder, the file pattern and the exact file's pattern.
MAPS = {
    "rgbs": ("rgbs", "rgb_%05d.jpg", None),
    "depths": ("depths", "depth_%05d.png", "depth_%05d.npy"),
    "normals": ("normals", "normal_%05d.jpg", "normal_%05d.npy"),
    "masks": ("masks", "mask_%05d.png", None),
}
# The per-frame arrays of anno.npz that a clip slices.
TRACK_KEYS = ("trajs_2d", "trajs_3d", "visibs", "valids", "intrinsics", "extrinsics", "visibilities", "visibility_codes")
# The per-point arrays, the same for every frame.
POINT_KEYS = ("point_vertex_ids", "point_barycentric", "point_actor_ids")


def _image(path):
    try:
        from PIL import Image
    except ImportError as error:  # pragma: no cover - depends on the machine
        raise ImportError("odyssey.data reads the PNG and JPEG maps with PIL (Debian: python3-pil)") from error
    with Image.open(path) as image:
        return np.array(image)


class Sequence:
    """One PointOdyssey-layout sequence folder.

    Arrays of anno.npz are read once, on first use (np.load, as the loaders read them); maps are
    read per frame. frames is T, points N; maps lists the map folders present.
    """

    def __init__(self, path):
        self.path = os.fspath(path)
        anno = os.path.join(self.path, "anno.npz")
        if not os.path.isfile(anno):
            raise FileNotFoundError("%s: not a sequence folder (no anno.npz)" % self.path)
        self.name = os.path.basename(os.path.normpath(self.path))
        self._anno = None
        info = os.path.join(self.path, "scene_info.json")
        self.info = json.load(open(info)) if os.path.isfile(info) else {}
        self.maps = [key for key, (folder, _, _) in MAPS.items() if os.path.isdir(os.path.join(self.path, folder))]
        # info.npz holds the shapes, so a dataset's index is built without reading every anno.npz.
        shape = None
        info_npz = os.path.join(self.path, "info.npz")
        if os.path.isfile(info_npz):
            with np.load(info_npz) as shapes:
                if "trajs_2d" in shapes.files:
                    shape = tuple(int(n) for n in shapes["trajs_2d"])
        if shape is None:
            shape = self.anno["trajs_2d"].shape
        self.frames, self.points = int(shape[0]), int(shape[1])
        self.fps = float(self.info["fps"]) if "fps" in self.info else float(self.anno.get("fps", 30))

    @property
    def anno(self):
        """Every array of anno.npz, loaded into memory (dict of numpy arrays)."""
        if self._anno is None:
            with np.load(os.path.join(self.path, "anno.npz")) as archive:
                self._anno = {key: archive[key] for key in archive.files}
        return self._anno

    @property
    def instances(self):
        """scene_info.json's instances: id -> {name, kind, category, source}."""
        return {entry["id"]: entry for entry in self.info.get("instances", [])}

    def __len__(self):
        return self.frames

    def _check_frame(self, k):
        if not 0 <= k < self.frames:
            raise IndexError("%s: frame %d is outside [0, %d)" % (self.path, k, self.frames))

    def _map_path(self, key, k, exact=False):
        folder, pattern, exact_pattern = MAPS[key]
        if exact and exact_pattern:
            path = os.path.join(self.path, folder, exact_pattern % k)
            if os.path.isfile(path):
                return path, True
        return os.path.join(self.path, folder, pattern % k), False

    def rgb(self, k):
        """uint8 [H, W, 3]: frame k's render (rgbs/, written by `odyssey render`)."""
        self._check_frame(k)
        return _image(self._map_path("rgbs", k)[0])

    def depth(self, k, exact=False):
        """float32 [H, W] metres along the optical axis, +inf where no surface; exact: the .npy when written."""
        self._check_frame(k)
        path, is_exact = self._map_path("depths", k, exact)
        if is_exact:
            return np.load(path)
        value = _image(path)
        depth = value.astype(np.float32) / 65535.0 * 1000.0
        depth[value == 65535] = np.inf
        return depth

    def normal(self, k, exact=False):
        """float32 [H, W, 3] world unit normals facing the camera, in [-1, 1]; exact: the .npy when written."""
        self._check_frame(k)
        path, is_exact = self._map_path("normals", k, exact)
        if is_exact:
            return np.load(path)
        return _image(path).astype(np.float32) / 255.0 * 2.0 - 1.0

    def mask(self, k):
        """uint8 [H, W]: the instance id of each pixel (0 nothing; see instances)."""
        self._check_frame(k)
        return _image(self._map_path("masks", k)[0])

    def clip(self, start=0, length=None, stride=1, maps=None, exact=False, points=None):
        """Frames start, start + stride, ... (length of them; default: to the end) as one dict.

        maps: which of rgbs, depths, normals, masks to read (default: every one present). points:
        indices of the points to keep (default: all). Keys: the TRACK_KEYS present, sliced to the
        clip [S, ...]; the per-point arrays; the maps stacked [S, H, W(, 3)]; 'frames' (int64 [S]),
        'fps', 'name'.
        """
        if stride < 1:
            raise ValueError("stride must be at least 1, got %d" % stride)
        last = self.frames - 1 if length is None else start + (length - 1) * stride
        if length is not None and length < 1:
            raise ValueError("length must be at least 1, got %d" % length)
        if not 0 <= start <= last < self.frames:
            raise IndexError("%s: frames %d to %d are outside [0, %d)" % (self.path, start, last, self.frames))
        frames = np.arange(start, last + 1, stride, dtype=np.int64)
        take = slice(None) if points is None else np.asarray(points)
        sample = {"frames": frames, "fps": self.fps, "name": self.name}
        anno = self.anno
        for key in TRACK_KEYS:
            if key in anno:
                values = anno[key][frames]
                sample[key] = values[:, take] if values.ndim >= 2 and key not in ("intrinsics", "extrinsics") else values
        for key in POINT_KEYS:
            if key in anno:
                sample[key] = anno[key][take]
        for key in self.maps if maps is None else maps:
            if key not in MAPS:
                raise ValueError("maps: unknown map %r (rgbs, depths, normals, masks)" % key)
            if key not in self.maps:
                raise FileNotFoundError("%s: no %s/ folder" % (self.path, MAPS[key][0]))
            read = {"rgbs": self.rgb, "depths": lambda k: self.depth(k, exact), "normals": lambda k: self.normal(k, exact),
                    "masks": self.mask}[key]
            sample[key] = np.stack([read(int(k)) for k in frames])
        return sample

    def __repr__(self):
        return "<odyssey.data.Sequence %s: %d frames, %d points, maps %s>" % (self.path, self.frames, self.points, ", ".join(self.maps) or "none")


def find_sequences(root, split=None):
    """The sequence folders under root (root/split when split is given), sorted: root itself when it
    holds anno.npz, else every folder below holding one."""
    base = os.fspath(root) if split is None else os.path.join(os.fspath(root), split)
    if not os.path.isdir(base):
        raise FileNotFoundError("%s: no such folder" % base)
    if os.path.isfile(os.path.join(base, "anno.npz")):
        return [base]
    found = []
    for folder, subfolders, files in os.walk(base):
        if "anno.npz" in files:
            found.append(folder)
            subfolders[:] = []  # a sequence's own folders (depths/ ...) hold no sequences
        subfolders.sort()
    return sorted(found)


class Dataset(_DatasetBase):
    """Clips of the sequences under a dataset folder (or one sequence), one sample per clip.

    clip_length frames (default: each sequence whole) every clip_stride frames of a sequence
    (default: clip_length, clips that do not overlap), frame step `stride`; maps and exact as in
    Sequence.clip; max_points keeps that many points per clip, drawn with a generator seeded by
    seed and the sample's index (the same sample every epoch). Samples are dicts of numpy arrays
    (Sequence.clip), which torch's default collate turns into tensors.
    """

    def __init__(self, root, split=None, clip_length=None, clip_stride=None, stride=1, maps=None, exact=False,
                 max_points=None, seed=0):
        self.sequences = [Sequence(path) for path in find_sequences(root, split)]
        if not self.sequences:
            raise FileNotFoundError("%s: no sequence folders (with anno.npz) found" % os.fspath(root))
        self.clip_length, self.stride, self.maps, self.exact = clip_length, stride, maps, exact
        self.max_points, self.seed = max_points, seed
        self.index = []  # (sequence, first frame) of every clip
        for s, sequence in enumerate(self.sequences):
            if clip_length is None:
                self.index.append((s, 0))
                continue
            span = (clip_length - 1) * stride + 1
            step = clip_stride or span
            self.index.extend((s, first) for first in range(0, sequence.frames - span + 1, step))

    def __len__(self):
        return len(self.index)

    def __getitem__(self, i):
        if not -len(self) <= i < len(self):
            raise IndexError("sample %d of %d" % (i, len(self)))
        s, first = self.index[i % len(self)]
        sequence = self.sequences[s]
        points = None
        if self.max_points is not None and self.max_points < sequence.points:
            rng = np.random.default_rng([self.seed, i % len(self)])
            points = np.sort(rng.choice(sequence.points, self.max_points, replace=False))
        length = self.clip_length if self.clip_length is not None else (sequence.frames + self.stride - 1) // self.stride
        return sequence.clip(first, length, self.stride, self.maps, self.exact, points)
