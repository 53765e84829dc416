"""The README's walk-through runs as written (in a scratch folder)."""
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _walkthrough():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("## Five minutes with robocal", 1)[1]
    return re.search(r"```bash\n(.*?)```", section, re.S).group(1)


@pytest.mark.skipif(shutil.which("robocal") is None and not os.environ.get("CI"),
                    reason="the robocal command is not installed")
def test_readme_walkthrough_runs(tmp_path):
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    script = "set -euo pipefail\n" + _walkthrough()
    env = dict(os.environ, PATH=os.path.dirname(sys.executable) + os.pathsep + os.environ.get("PATH", ""))
    done = subprocess.run(["bash", "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    for written in ("commands.csv", "ur5_commands.csv", "ur5_report.html", "ur5_calibrated.urdf"):
        assert (tmp_path / written).is_file(), written
    assert "UR5" in done.stdout


@pytest.mark.slow
def test_readme_python_examples_run():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) >= 2
    for block in blocks:
        exec(compile(block, "README.md", "exec"), {})
