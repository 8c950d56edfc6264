"""Shared fixtures of the Python module's tests: where the assets, the bundled data and the odyssey
command are (ctest passes them in the environment; run by hand, they default to the checkout's)."""

import os
import subprocess

import pytest

SOURCE = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
SHARED = os.environ.get("ODYSSEY_SHARED_DIR", os.path.join(SOURCE, "..", "shared"))
DATA = os.path.join(SOURCE, "data")
CLI = os.environ.get("ODYSSEY_CLI", os.path.join(SOURCE, "build", "cli", "odyssey"))

WALK = os.path.join(DATA, "mocap", "cmu_walk_cgspeed.bvh")
FIGURE = os.path.join(DATA, "characters", "RiggedFigure.glb")
CESIUM = os.path.join(DATA, "characters", "CesiumMan.glb")
JUMP = os.path.join(SHARED, "assets", "mocap", "cmu_jump_cgspeed.bvh")
SMPLX_FIXTURE = os.path.join(SHARED, "fixtures", "smplx")


def run_cli(*arguments, cwd=None):
    """Runs the odyssey command; returns (exit code, stdout, stderr)."""
    if not os.access(CLI, os.X_OK):
        pytest.skip("the odyssey command is not built at %s" % CLI)
    done = subprocess.run([CLI, *arguments], capture_output=True, text=True, cwd=cwd)
    return done.returncode, done.stdout, done.stderr


def small_scene(name="shot", seconds=1.0, layout=None, outputs=None):
    """A one-second shot: the bundled walk on RiggedFigure, a ground and a box, two cameras."""
    scene = {
        "version": 1, "name": name, "fps": 30, "seed": 3,
        "actors": [{"name": "walker", "motion": "data:mocap/cmu_walk_cgspeed.bvh", "bvh_units": "cmu",
                    "character": "data:characters/RiggedFigure.glb", "quality": "fast",
                    "trim": [0.1, 0.1 + seconds], "points": 400}],
        "props": [{"name": "floor", "type": "ground", "size": [6, 6]},
                  {"name": "crate", "type": "box", "size": [0.5, 0.5, 0.5], "position": [1.0, 1.0, 0]}],
        "cameras": [{"name": "front", "type": "static", "position": [0, -4, 1.5], "target": [0, 0, 1]},
                    {"name": "orbit", "type": "orbit", "radius": 3.5, "height_m": 1.6, "period": 8}],
        "outputs": {"trajectories": True, "camera_paths": True, "report": True, "prop_points": 100},
    }
    if layout:
        scene["outputs"]["layout"] = layout
    if outputs:
        scene["outputs"].update(outputs)
    return scene


def rss_bytes():
    """Resident memory of this process (/proc/self/statm's second field, in pages)."""
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
