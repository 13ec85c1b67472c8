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

# the process that compiles says so once (and the cached one never), then searches: one fresh compile
# serves the notice and the bits (the kernel's first compile is most of this file's time)
SCRIPT = r"""
import sys
import numpy as np
sys.path.insert(0, sys.argv[2])
from test_urdf_coupled import WRIST
from wsmap.kinematics import ikine_search
from wsmap.kinematics.ik.warmup import ensure_compiled, needs_compile
from wsmap.kinematics.urdf import from_urdf
notices, again = [], []
before = needs_compile(coupled=True)
seconds = ensure_compiled(notify=notices.append, coupled=True)
after = needs_compile(coupled=True)
second = ensure_compiled(notify=again.append, coupled=True)
arm = from_urdf(WRIST, ee_link="w2")
q = arm.random_q(150, np.random.default_rng(0))
T = np.array(arm.fkine(q))
T[::3, :3, 3] *= 1.3
sol = ikine_search(arm, T, starts=6, seed=1)
np.savez(sys.argv[1], q=sol.q, it=sol.iterations, ok=sol.success, res=sol.residual, before=before, after=after,
         seconds=seconds, second=second, notices=np.array(notices + again, dtype=str))
"""


def _run(cache_dir, out, threads):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir), NUMBA_NUM_THREADS=str(threads), WSMAP_THREADS=str(threads),
               PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    subprocess.run([sys.executable, "-c", SCRIPT, str(out), str(HERE)], env=env, check=True, timeout=900)
    return np.load(out)


@pytest.mark.slow
def test_cached_coupled_kernel_gives_the_bits_of_a_fresh_compile_and_only_the_compile_is_announced(tmp_path):
    cache = tmp_path / "numba_cache"
    fresh = _run(cache, tmp_path / "fresh.npz", 1)  # compiles, and writes the cache
    assert any(cache.rglob("*lm_coupled*.nbc")), "the first run cached no coupled kernel"
    cached = _run(cache, tmp_path / "cached.npz", 2)  # loads it (threads must not matter either)
    # the first compile: announced once, naming the cache; a second call and the cached process say nothing
    assert fresh["before"] and not fresh["after"] and fresh["seconds"] > 0 and fresh["second"] == 0.0
    assert len(fresh["notices"]) == 1 and fresh["notices"][0].startswith("compiling the IK kernel of coupled joints once")
    assert fresh["notices"][0].endswith(f"s; cached in {cache}")
    assert not cached["before"] and cached["seconds"] == 0.0 and len(cached["notices"]) == 0
    assert fresh["ok"].any() and not fresh["ok"].all()
    for field in ("q", "it", "ok", "res"):
        assert fresh[field].tobytes() == cached[field].tobytes(), f"{field}: the cached kernel differs from the fresh one"
