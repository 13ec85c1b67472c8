"""The UR closed form's numba build (tens of seconds in an empty cache) is announced, once, on
stderr through the progress machinery: a map with a progress bar says so before it compiles, a
quiet one does not, and nothing is said once numba's cache holds the build."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from wsmap._progress import notice, progress_bar

SRC = Path(__file__).resolve().parents[2] / "src"
NOTICE = "wsmap: compiling the UR closed form (numba, once per machine; about "

# two exact UR5e maps with progress bars in one process, then (argv[1] == "quiet") none
SCRIPT = r"""
import sys, time
from wsmap import robots, workspace as ws
arm = robots.load("ur5e")
g = ws.grid_spec("R3", -0.6, 0.6, 0.3)
nodes = ws.cartesian_grid(g["lo"], g["hi"], g["step"])
progress = sys.argv[1] != "quiet"
for _ in range(2):
    t0, c0 = time.perf_counter(), time.process_time()
    bits = ws.constant_orientation_map(arm, nodes, (0.0, 0.0, 0.0), method="exact", progress=progress)
    print(f"{time.perf_counter() - t0:.2f} s wall, {time.process_time() - c0:.2f} s CPU, {int(bits.sum())} reachable")
"""


def _maps(cache, how):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), NUMBA_NUM_THREADS="1", WSMAP_THREADS="1",
               PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    r = subprocess.run([sys.executable, "-c", SCRIPT, how], env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    return r.stdout, r.stderr


@pytest.mark.slow
def test_the_first_ur_build_is_announced_once_and_never_from_the_cache(tmp_path):
    cache = tmp_path / "numba"
    out, err = _maps(cache, "bar")  # compiles _run: one notice, before the first map only
    assert err.count(NOTICE) == 1, err
    line = next(line for line in err.splitlines() if NOTICE in line)
    assert line.rstrip().endswith(" s)..."), line
    assert any(cache.rglob("*.nbc"))
    out2, err2 = _maps(cache, "bar")  # loads the build from the cache: nothing to announce
    assert NOTICE not in err2, err2
    assert out.splitlines()[0].split(", ")[-1] == out2.splitlines()[0].split(", ")[-1]  # the same map
    print(out, out2)  # the timings (pytest -s): the first map's CPU seconds are the compile's


def test_a_notice_is_said_only_under_an_open_bar(capsys):
    notice("outside any bar")
    with progress_bar(False, 10):
        notice("under a quiet map")
    with progress_bar(lambda n: None, 10):
        notice("under the caller's own progress callable")
    assert capsys.readouterr().err == ""
    with progress_bar(True, 10):
        notice("compiling something, about 3 s...")
    err = capsys.readouterr().err
    assert "wsmap: compiling something, about 3 s...\n" in err
    notice("after the bar")
    assert "after the bar" not in capsys.readouterr().err
