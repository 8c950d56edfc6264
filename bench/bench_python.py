"""What calling odyssey through Python costs: the same work timed as a Python call and as the C++
library call, in this one process (the module times the C++ call itself with a steady clock, no
Python in the loop), in adjacent pairs. Prints one table: what, size, pairs, the fastest C++ and
Python times, the median overhead over the pairs, and the machine.

Usage (from the checkout, after the build):
    PYTHONPATH=build/python python3 bench/bench_python.py [MIN_PAIRS]
"""

import json
import os
import platform
import sys
import tempfile
import time

import odyssey
from odyssey import _odyssey

SOURCE = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
DATA = os.path.join(SOURCE, "data")
SHARED = os.environ.get("ODYSSEY_SHARED_DIR", os.path.join(SOURCE, "..", "shared"))


def machine():
    name, family, model = "unknown CPU", "", ""
    for line in open("/proc/cpuinfo"):
        if not line.strip():
            break
        key, _, value = line.partition(":")
        key, value = key.strip(), value.strip()
        if key == "model name":
            name = value
        elif key == "cpu family":
            family = value
        elif key == "model":
            model = value
    cores = os.cpu_count()
    return "%s%s, %d cores, Python %s" % (name, " (family %s, model %s)" % (family, model) if family else "", cores,
                                          platform.python_version())


def timed(call):
    start = time.perf_counter()
    call()
    return time.perf_counter() - start


def compare(repeats, cpp, python, seconds=20.0):
    """Runs the two in adjacent pairs, each pair in the other order than the last, over at least
    `repeats` pairs and `seconds` of each (short calls get more pairs; at most 500). Returns the
    fastest run of each, the median over pairs of python / cpp - 1 (two runs next to each other
    share the machine's state, so on a busy machine the pairs' ratio is steadier than the ratio of
    the fastest runs), and the number of pairs."""
    cpp_times, python_times = [], []
    while len(cpp_times) < 500 and (len(cpp_times) < repeats or min(sum(cpp_times), sum(python_times)) < seconds):
        if len(cpp_times) % 2 == 0:
            cpp_times.append(cpp())
            python_times.append(timed(python))
        else:
            python_times.append(timed(python))
            cpp_times.append(cpp())
    ratios = sorted(p / c - 1 for c, p in zip(cpp_times, python_times))
    return min(cpp_times), min(python_times), ratios[len(ratios) // 2], len(cpp_times)


def shot(frames):
    """The benchmark shot: the bundled indoor scene's two walkers at fast, two of its cameras, `frames` frames."""
    scene = json.load(open(os.path.join(DATA, "scenes", "indoor.json")))
    for actor in scene["actors"]:
        actor["quality"] = "fast"
        actor["trim"] = [0.1, 0.1 + (frames - 1) / 30]
        actor.pop("start", None)
    scene["cameras"] = [c for c in scene["cameras"] if c["type"] != "ego"]
    scene["outputs"] = {"trajectories": True, "camera_paths": True, "report": True, "prop_points": 1000}
    return scene


def main():
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 11
    walk = os.path.join(DATA, "mocap", "cmu_walk_cgspeed.bvh")
    jump = os.path.join(SHARED, "assets", "mocap", "cmu_jump_cgspeed.bvh")
    figure = os.path.join(DATA, "characters", "RiggedFigure.glb")
    rows = []
    for clip, name in ((walk, "CMU walk"), (jump, "CMU jump")):
        if not os.path.exists(clip):
            continue
        frames = odyssey.retarget(clip, figure).frame_count
        for quality in ("fast", "balanced"):
            rows.append(("retarget %s, %s -> RiggedFigure" % (quality, name), "%d frames" % frames,
                         *compare(repeats, lambda: _odyssey._cpp_retarget_seconds(clip, figure, quality, 1)[0],
                                  lambda: odyssey.retarget(clip, figure, quality))))
    with tempfile.TemporaryDirectory() as folder:
        for frames in (31, 151):
            path = os.path.join(folder, "shot_%d.json" % frames)
            scene = shot(frames)
            open(path, "w").write(json.dumps(scene))
            size = "%d frames, 2 actors, 2 cameras, %d points" % (frames, 4000 + 1000)
            out_cpp, out_python = os.path.join(folder, "cpp"), os.path.join(folder, "python")
            rows.append(("scene into files (run_scene)", size,
                         *compare(repeats, lambda: _odyssey._cpp_scene_seconds(path, out_cpp, False, 1)[0],
                                  lambda: odyssey.run_scene(path, out_python))))
            rows.append(("scene into numpy (scene_arrays)", size,
                         *compare(repeats, lambda: _odyssey._cpp_scene_seconds(path, "", True, 1)[0],
                                  lambda: odyssey.scene_arrays(path))))
    load = open("/proc/loadavg").read().split()[0]
    print("machine: %s; load average %s at the start; times: the fastest of the runs; overhead: the median over\n"
          "adjacent pairs of Python / C++ - 1\n" % (machine(), load))
    print("| what | size | pairs | C++ ms | Python ms | overhead |")
    print("|---|---|---:|---:|---:|---:|")
    for what, size, cpp, python, overhead, runs in rows:
        print("| %s | %s | %d | %.2f | %.2f | %+.1f%% |" % (what, size, runs, 1e3 * cpp, 1e3 * python, 100 * overhead))


if __name__ == "__main__":
    main()
