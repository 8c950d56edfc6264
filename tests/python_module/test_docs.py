"""docs/python.md's example runs as printed (from the checkout, where its paths point)."""

import os
import re
import subprocess
import sys

from conftest import SOURCE


def test_the_example_runs_as_printed(tmp_path):
    text = open(os.path.join(SOURCE, "docs", "python.md")).read()
    example = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    assert len(example.strip().splitlines()) <= 12
    done = subprocess.run([sys.executable, "-c", example], cwd=SOURCE, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "trajs_3d (" in done.stdout and "visible" in done.stdout
