"""A process that loads the compiled LM kernel from numba's disk cache gives the same bits as the process
that compiled it (see "Cache" in :mod:`wsmap.kinematics.lm_compiled`): a 7-joint arm's search once
differed by ~1e-9 in ``q`` and in iteration counts."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SRC = Path(__file__).resolve().parents[2] / "src"

# a Panda search (7 joints: the generic build) and a UR5e one (6: the fixed six-joint build), a third of
# the targets pushed out of reach so that the random starts and the failure paths run too
SCRIPT = r"""
import sys
import numpy as np
import wsmap
from wsmap.kinematics import ikine_search, lm_compiled
from wsmap.kinematics.ik.warmup import ensure_compiled, needs_compile
notices = []
need = needs_compile()
ensure_compiled(notify=notices.append)
out = {"need_before": need, "need_after": needs_compile(), "notices": np.array(notices, dtype=str)}
for name in ("panda", "ur5e"):
    arm = wsmap.load(name)
    q = np.random.default_rng(0).uniform(-1.5, 1.5, size=(120, arm.n))
    T = np.array(arm.fkine(q))
    T[::3, :3, 3] *= 1.3
    sol = ikine_search(arm, T, starts=6, seed=1)
    out[name + "_q"] = sol.q
    out[name + "_it"] = sol.iterations
    out[name + "_ok"] = sol.success
    out[name + "_res"] = sol.residual
np.savez(sys.argv[1], **out)
"""


def _run(cache_dir, out, threads, kernel):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir), NUMBA_NUM_THREADS=str(threads), WSMAP_KERNEL=kernel,
               WSMAP_THREADS=str(threads), PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    subprocess.run([sys.executable, "-c", SCRIPT, str(out)], env=env, check=True, timeout=600)
    return np.load(out)


@pytest.mark.slow
@pytest.mark.parametrize("kernel", ["scalar", "lanes"])
def test_cached_kernel_gives_the_bits_of_a_fresh_compile(tmp_path, kernel):
    cache = tmp_path / "numba_cache"
    fresh = _run(cache, tmp_path / "fresh.npz", 1, kernel)  # compiles, and writes the cache
    assert any(cache.rglob("*.nbc")), "the first run wrote no numba cache"
    cached = _run(cache, tmp_path / "cached.npz", 2, kernel)  # loads it (threads must not matter either)
    assert fresh["need_before"] and not fresh["need_after"] and not cached["need_before"]
    if kernel == "scalar":
        # the first-run notice: once, in the process that compiles, naming the cache; none once cached
        assert len(fresh["notices"]) == 1 and len(cached["notices"]) == 0
        assert fresh["notices"][0].startswith("compiling the IK kernels once, about ")
        assert fresh["notices"][0].endswith(f"s; cached in {cache}")
    else:
        # the lane kernel was compiled at install; the search's numba helpers take a second: no notice
        assert len(fresh["notices"]) == 0 and len(cached["notices"]) == 0
    for name in ("panda", "ur5e"):
        assert fresh[name + "_ok"].any() and not fresh[name + "_ok"].all()
        for field in ("q", "it", "ok", "res"):
            a, b = fresh[f"{name}_{field}"], cached[f"{name}_{field}"]
            assert a.tobytes() == b.tobytes(), f"{name} {field}: the cached kernel differs from the fresh one"


def test_the_cache_lives_in_a_user_directory(monkeypatch, tmp_path):
    from wsmap.kinematics import lm_compiled

    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert lm_compiled.cache_dir() == os.path.join(str(tmp_path), "wsmap", "numba")
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert lm_compiled.cache_dir() == os.path.join(os.path.expanduser("~"), ".cache", "wsmap", "numba")
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "nb"))
    assert lm_compiled.cache_dir() == str(tmp_path / "nb")


def test_the_kernels_cache_where_cache_dir_said_at_import_and_numba_keeps_its_setting():
    import numba

    from wsmap.kinematics import lm_compiled

    where = lm_compiled._run_targets._cache._cache_path
    # the directory cache_dir() named when the module was imported (numba's own place if unwritable)
    assert where.startswith(lm_compiled.cache_dir()) or "__pycache__" in where
    assert numba.config.CACHE_DIR == os.environ.get("NUMBA_CACHE_DIR", "")


def test_ensure_compiled_is_silent_once_compiled():
    from wsmap.kinematics import lm_compiled
    from wsmap.kinematics.ik.warmup import ensure_compiled

    ensure_compiled()  # compiles or loads, whichever this machine needs
    notices = []
    assert ensure_compiled(notify=notices.append) == 0.0 and notices == []
    assert not lm_compiled.needs_compile()
