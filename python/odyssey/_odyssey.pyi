"""Type stub of odyssey._odyssey, the compiled half of the odyssey package (python/*.cpp)."""

import os
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

PathLike = Union[str, os.PathLike]
Progress = Optional[Callable[[Dict[str, Any]], None]]

class Error(RuntimeError):
    """Any error odyssey reports; the message is the command line's one line."""

class InputError(Error):
    """A file that cannot be read or is not valid: str() is 'FILE: PROBLEM'."""
    file: str
    problem: str

class UsageError(Error):
    """An argument value odyssey does not accept."""

def inspect(path: PathLike, bvh_units: Union[None, str, float] = None) -> Dict[str, Any]:
    """What `odyssey inspect PATH` prints, as a dict."""

class Motion:
    """A motion on a skeleton; arrays are read-only views of it."""
    @property
    def fps(self) -> float: ...
    @property
    def frame_count(self) -> int: ...
    @property
    def joint_names(self) -> List[str]: ...
    @property
    def parents(self) -> List[int]: ...
    @property
    def translated_joints(self) -> List[int]: ...
    @property
    def rotations(self) -> npt.NDArray[np.float64]:
        """[T, J, 4] local rotations as quaternions (x, y, z, w)."""
    @property
    def translations(self) -> npt.NDArray[np.float64]:
        """[T, K, 3] local translations of translated_joints, metres."""
    @property
    def root_translation(self) -> npt.NDArray[np.float64]:
        """[T, 3] the root's local translation, metres."""
    def world_joints(self) -> npt.NDArray[np.float64]:
        """[T, J, 3] world joint positions, metres, Z up."""
    def resampled(self, fps: float) -> "Motion": ...

def load_bvh(path: PathLike, bvh_units: Union[None, str, float] = None) -> Motion: ...
def load_amass(path: PathLike) -> Dict[str, Any]:
    """{'poses' [T, 3J], 'trans' [T, 3], 'betas', 'gender', 'fps', 'model', 'pose_keys', 'frame_rate_key', 'keys_skipped'}"""

class Character:
    def __init__(self, path: PathLike) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def path(self) -> str: ...
    @property
    def joint_names(self) -> List[str]: ...
    @property
    def parents(self) -> List[int]: ...
    @property
    def vertex_count(self) -> int: ...
    @property
    def rest_vertices(self) -> npt.NDArray[np.float32]:
        """[V, 3] every mesh's vertices as stored, meshes in order."""
    @property
    def triangles(self) -> npt.NDArray[np.uint32]:
        """[F, 3] indices into the vertices numbered across the meshes."""
    def summary(self) -> Dict[str, Any]: ...

class BodyModel:
    def __init__(self, path: PathLike) -> None: ...
    @staticmethod
    def synthetic(seed: int = 0, dense: bool = False) -> "BodyModel": ...
    @property
    def kind(self) -> str: ...
    @property
    def joint_names(self) -> List[str]: ...
    @property
    def parents(self) -> List[int]: ...
    @property
    def vertex_count(self) -> int: ...
    @property
    def pose_size(self) -> int: ...
    @property
    def shape_count(self) -> int: ...
    @property
    def expression_count(self) -> int: ...
    @property
    def faces(self) -> npt.NDArray[np.int32]: ...
    def forward(self, poses: npt.NDArray[np.float64], trans: Optional[npt.NDArray[np.float64]] = None,
                betas: Optional[npt.NDArray[np.float64]] = None, expression: Optional[npt.NDArray[np.float64]] = None, *,
                hands: bool = True, face: bool = True, correctives: bool = True,
                vertices: bool = True) -> Tuple[npt.NDArray[np.float64], Optional[npt.NDArray[np.float32]]]:
        """(joints [T, J, 3] float64, vertices [T, V, 3] float32 or None) from poses [T, pose_size]."""

class Retargeted:
    @property
    def motion(self) -> Motion: ...
    @property
    def source(self) -> Motion: ...
    @property
    def character(self) -> Character: ...
    @property
    def fps(self) -> float: ...
    @property
    def frame_count(self) -> int: ...
    @property
    def joint_names(self) -> List[str]: ...
    @property
    def parents(self) -> List[int]: ...
    @property
    def rotations(self) -> npt.NDArray[np.float64]: ...
    @property
    def root_translation(self) -> npt.NDArray[np.float64]: ...
    @property
    def world_joints(self) -> npt.NDArray[np.float64]: ...
    @property
    def report(self) -> Dict[str, Any]: ...
    def skin(self, frames: Optional[Sequence[int]] = None, threads: int = 1) -> npt.NDArray[np.float32]:
        """[F, V, 3] every mesh vertex skinned at the frames (default all)."""

def retarget(motion: PathLike, character: PathLike, quality: str = "fast", *, fps: float = 30.0, parts: str = "body",
             map: Optional[PathLike] = None, source_map: Optional[PathLike] = None, model: Optional[PathLike] = None,
             betas: str = "fit", bvh_units: Union[None, str, float] = None, source_rest: str = "rest",
             weights: Optional[Mapping[str, float]] = None, contact_lift: Union[None, float, str] = None,
             threads: int = 1) -> Retargeted: ...

def example_scene() -> Dict[str, Any]: ...
def run_scene(scene: Union[PathLike, Mapping[str, Any]], out: PathLike, *, layout: Optional[str] = None,
              base_dir: Optional[PathLike] = None, progress: Progress = None) -> Dict[str, Any]:
    """Runs a scene into files; returns the scene's report."""
def scene_arrays(scene: Union[PathLike, Mapping[str, Any]], *, base_dir: Optional[PathLike] = None,
                 progress: Progress = None) -> Dict[str, Any]:
    """{'cameras': {name: {key: array}}, 'report': dict}: the trajectory files' arrays in memory."""

def run_batch(out: PathLike, motions: Union[None, PathLike, Sequence[PathLike]] = None,
              characters: Union[None, PathLike, Sequence[PathLike]] = None, *, manifest: Optional[PathLike] = None,
              quality: str = "fast", fps: float = 30.0, parts: str = "body", model: Optional[PathLike] = None,
              betas: str = "fit", bvh_units: Union[None, str, float] = None, outputs: str = "glb,report",
              workers: int = 1, timeout_s: float = 0.0, max_memory_gib: Optional[float] = None, shard: str = "1/1",
              gates: Optional[Mapping[str, float]] = None, progress: Progress = None) -> Dict[str, Any]: ...

def run_dataset(recipe: Union[PathLike, Mapping[str, Any]], out: PathLike, *, count: Optional[int] = None,
                workers: int = 1, timeout_s: float = 0.0, max_memory_gib: Optional[float] = None, shard: str = "1/1",
                base_dir: Optional[PathLike] = None, progress: Progress = None) -> Dict[str, Any]:
    """Makes a dataset from a recipe as `odyssey dataset` does (present where the build has the dataset library)."""
