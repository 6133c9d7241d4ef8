"""The Python example of docs/USAGE.md (where the README points Python users) runs as printed."""

import os
import re
import subprocess
import sys

import pytest

from conftest import ROOT


def test_readme_example_runs():
    pytest.importorskip("matplotlib")
    text = (ROOT / "docs" / "USAGE.md").read_text()
    section = text.split("\n## Python\n", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, re.S)
    assert blocks, "docs/USAGE.md has no ```python block under ## Python"
    env = {**os.environ, "MPLBACKEND": "Agg"}
    run = subprocess.run([sys.executable, "-c", blocks[0]], cwd=ROOT, env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    assert re.search(r"D_C \d+\.\d+ mm, physics (pass|fail)", run.stdout), run.stdout
