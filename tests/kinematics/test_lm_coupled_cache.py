"""A process that loads the coupled-joint kernel (`wsmap.kinematics.lm_coupled`) from numba's disk cache gives
the bits of the process that compiled it (lm_compiled's notes, "Cache"): without binding its callees first, a
cached process differed from the fresh one in `q`, iteration counts and residuals."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

HERE = Path(__file__).resolve().parent
SRC = HERE.parents[1] / "src"

SCRIPT = r"""
import sys
import numpy as np
sys.path.insert(0, sys.argv[2])
from test_urdf_coupled import WRIST
from wsmap.kinematics import ikine_search
from wsmap.kinematics.urdf import from_urdf
arm = from_urdf(WRIST, ee_link="w2")
q = arm.random_q(150, np.random.default_rng(0))
T = np.array(arm.fkine(q))
T[::3, :3, 3] *= 1.3
sol = ikine_search(arm, T, starts=6, seed=1)
np.savez(sys.argv[1], q=sol.q, it=sol.iterations, ok=sol.success, res=sol.residual)
"""


def _run(cache_dir, out, threads):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir), NUMBA_NUM_THREADS=str(threads), WSMAP_THREADS=str(threads),
               PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    subprocess.run([sys.executable, "-c", SCRIPT, str(out), str(HERE)], env=env, check=True, timeout=900)
    return np.load(out)


@pytest.mark.slow
def test_cached_coupled_kernel_gives_the_bits_of_a_fresh_compile(tmp_path):
    cache = tmp_path / "numba_cache"
    fresh = _run(cache, tmp_path / "fresh.npz", 1)  # compiles, and writes the cache
    assert any(cache.rglob("*lm_coupled*.nbc")), "the first run cached no coupled kernel"
    cached = _run(cache, tmp_path / "cached.npz", 2)  # loads it (threads must not matter either)
    assert fresh["ok"].any() and not fresh["ok"].all()
    for field in ("q", "it", "ok", "res"):
        assert fresh[field].tobytes() == cached[field].tobytes(), f"{field}: the cached kernel differs from the fresh one"


NOTICE = r"""
import sys
import numpy as np
from wsmap.kinematics.ik.warmup import ensure_compiled, needs_compile
notices = []
before = needs_compile(coupled=True)
seconds = ensure_compiled(notify=notices.append, coupled=True)
again = []
np.savez(sys.argv[1], before=before, after=needs_compile(coupled=True), seconds=seconds,
         second=ensure_compiled(notify=again.append, coupled=True), notices=np.array(notices + again, dtype=str))
"""


@pytest.mark.slow
def test_the_coupled_kernel_s_first_compile_is_announced_once(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), NUMBA_NUM_THREADS="1",
               PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    subprocess.run([sys.executable, "-c", NOTICE, str(tmp_path / "n.npz")], env=env, check=True, timeout=900)
    out = np.load(tmp_path / "n.npz")
    assert out["before"] and not out["after"] and out["seconds"] > 0 and out["second"] == 0.0
    assert len(out["notices"]) == 1 and out["notices"][0].startswith("compiling the IK kernel of coupled joints once")
    assert out["notices"][0].endswith(f"s; cached in {tmp_path / 'cache'}")
