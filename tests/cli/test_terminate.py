"""A command ended by SIGTERM (``kill``, a job's time limit) unwinds as Ctrl+C does: one line, status 130,
and what it was writing into a staging folder beside its output is removed, not left behind."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from tests.cli.test_bad_input import run

ROOT = Path(__file__).resolve().parents[2]


def test_a_render_terminated_midway_leaves_no_staging_folder_and_no_output(tmp_path):
    target = tmp_path / "board.json"
    assert run(["target", "describe", "chessboard", "--cols", "9", "--rows", "6", "--square", "30",
                "--out", str(target)])[0] == 0
    out = tmp_path / "views"
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    process = subprocess.Popen([sys.executable, "-m", "usvips", "render", "--target", str(target), "--views", "1",
                                "--video-frames", "5000", "--image-size", "320x240", "--supersample", "1",
                                "--out", str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                               env=env, cwd=tmp_path)
    try:
        deadline = time.monotonic() + 300  # until the still view is written: the video's frames are under way

        def started() -> bool:
            return any(any(staging.glob("left/*")) for staging in tmp_path.glob(".views.render-*"))

        while not started() and process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert started(), "the render never wrote its still view"
        process.send_signal(signal.SIGTERM)
        _, err = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 130 and err.strip().splitlines() == ["usvips render: interrupted"], err
    assert not list(tmp_path.glob(".views.render-*")) and not out.exists()


def test_the_handler_before_a_command_is_restored_after_it():
    before = signal.getsignal(signal.SIGTERM)
    assert run(["--version"])[0] == 0 and run(["plan", "--help"])[0] == 0
    assert run(["plan", "--json", "--focal-px", "1000", "--image-size", "1280x960", "--baseline", "0.3"])[0] == 0
    assert signal.getsignal(signal.SIGTERM) is before
