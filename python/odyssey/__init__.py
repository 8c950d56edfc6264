"""odyssey from Python: motions, characters, the body model, retargeting, scenes and batches.

The compiled module (odyssey._odyssey) binds the C++ library; arrays come back as numpy arrays
(float64 for kinematics, float32 for skinned points and trajectories), errors as odyssey.Error and
its subclasses InputError and UsageError with the command line's one-line messages, and wrong
numpy arguments as ValueError naming the argument and both shapes. odyssey.data reads the
sequences odyssey writes. See docs/python.md.
"""

import os as _os

# An installed package (PREFIX/lib/python3.X/dist-packages/odyssey) reads the bundled data that
# `cmake --install` put in PREFIX/share/odyssey/data, unless the caller chose a folder.
_installed_data = _os.path.normpath(_os.path.join(_os.path.dirname(__file__), "..", "..", "..", "..", "share", "odyssey", "data"))
if "ODYSSEY_DATA_DIR" not in _os.environ and _os.path.isdir(_installed_data):
    _os.environ["ODYSSEY_DATA_DIR"] = _installed_data

from ._odyssey import (  # noqa: E402
    BodyModel,
    Character,
    Error,
    InputError,
    Motion,
    Retargeted,
    UsageError,
    example_scene,
    inspect,
    load_amass,
    load_bvh,
    retarget,
    run_batch,
    run_scene,
    scene_arrays,
)

__all__ = [
    "BodyModel", "Character", "Error", "InputError", "Motion", "Retargeted", "UsageError", "example_scene", "inspect",
    "load_amass", "load_bvh", "retarget", "run_batch", "run_scene", "scene_arrays",
]

try:  # built where the source tree has the dataset library (dataset/)
    from ._odyssey import run_dataset  # noqa: F401
except ImportError:  # pragma: no cover - depends on the build
    pass
else:
    __all__.append("run_dataset")
