"""The README's API tour runs verbatim, from the repository root and from elsewhere."""

import os
import re
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _tour():
    path = os.path.join(ROOT, "README.md")
    if not os.path.exists(path):
        pytest.skip("not running from a source checkout")
    text = open(path, encoding="utf-8").read()
    section = text.split("\n## API tour", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    assert len(blocks) == 1, "the API tour is one python block"
    return blocks[0]


@pytest.mark.parametrize("where", ["root", "elsewhere"])
def test_api_tour_runs_verbatim(where, tmp_path):
    cwd = ROOT if where == "root" else str(tmp_path)
    env = dict(os.environ, MPLBACKEND="Agg")
    env.pop("PYTHONPATH", None)
    res = subprocess.run([sys.executable, "-c", _tour()], cwd=cwd, env=env, capture_output=True, text=True,
                         timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
    assert "Traceback" not in res.stderr
