"""A plotting run with a home directory Matplotlib cannot write to: no warning of
Matplotlib's on a successful run (``MPLCONFIGDIR`` is pointed at a writable directory)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="XDG directories: Linux")
def test_a_plot_with_an_unwritable_home_prints_no_matplotlib_warning(tmp_path):
    home = tmp_path / "home"
    home.write_text("")  # a file: nothing can be made under it, whoever runs the test
    temporary = tmp_path / "tmp"
    temporary.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("MPLCONFIGDIR", "XDG_CONFIG_HOME",
                                                            "XDG_CACHE_HOME")}  # fmt: skip
    env.update(HOME=str(home), TMPDIR=str(temporary), VSW_CACHE_DIR=str(tmp_path / "cache"))
    plot = tmp_path / "walk.png"
    done = subprocess.run(
        [sys.executable, "-m", "vsw", "simulate", "--model", "rimless-wheel", "--steps", "2",
         "--plot", str(plot)],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert (done.returncode, done.stderr) == (0, ""), done.stderr
    assert plot.read_bytes().startswith(b"\x89PNG")
    kept = temporary / f"vsw-matplotlib-{os.getuid()}"
    assert kept.is_dir() and kept.stat().st_mode & 0o077 == 0
