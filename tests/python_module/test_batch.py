"""Batches from Python: the jobs the command runs, progress as a callback, resuming."""

import json
import os
import subprocess

import pytest

import odyssey
from conftest import CESIUM, FIGURE, WALK


def test_batch_runs_reports_and_resumes(tmp_path):
    events = []
    out = tmp_path / "batch"
    summary = odyssey.run_batch(out, [WALK], [FIGURE, CESIUM], quality="fast", outputs="report", progress=events.append)
    assert summary["total"] == 2 and summary["done"] == 2 and summary["failed"] == 0
    assert summary["frames"] > 0
    assert [os.path.basename(p) for p in summary["reports"]] == ["report.json", "report.csv"]
    finished = [e["finished"] for e in events if e["finished"] is not None]
    assert sorted(r["job"] for r in finished) == ["CesiumMan/cmu_walk_cgspeed", "RiggedFigure/cmu_walk_cgspeed"]
    assert events[-1]["done"] == 2
    report = json.load(open(out / "jobs" / "RiggedFigure" / "cmu_walk_cgspeed" / "retarget.json"))
    assert report["metrics"] == odyssey.retarget(WALK, FIGURE).report["metrics"]
    again = odyssey.run_batch(out, [WALK], [FIGURE, CESIUM], quality="fast", outputs="report")
    assert again["resumed"] == 2 and again["frames"] == 0


def test_an_error_in_the_progress_callback_is_raised_after_the_jobs(tmp_path):
    calls = []

    def progress(counts):
        calls.append(counts)
        raise KeyError("stop")

    with pytest.raises(KeyError, match="stop"):
        odyssey.run_batch(tmp_path / "b", [WALK], [FIGURE, CESIUM], outputs="report", workers=2, progress=progress)
    assert len(calls) == 1  # not called again once it raised
    # The jobs finished and the workers are gone: no child process of this one is left.
    children = subprocess.run(["ps", "--ppid", str(os.getpid()), "-o", "pid="], capture_output=True, text=True).stdout.split()
    assert len(children) <= 1  # ps itself
    assert odyssey.run_batch(tmp_path / "b", [WALK], [FIGURE, CESIUM], outputs="report")["resumed"] == 2


def test_a_bad_job_fails_alone(tmp_path):
    broken = tmp_path / "broken.bvh"
    broken.write_text("HIERARCHY\nROOT\n")
    summary = odyssey.run_batch(tmp_path / "b", [WALK, str(broken)], [FIGURE], outputs="report")
    assert summary["done"] == 1 and summary["failed"] == 1
