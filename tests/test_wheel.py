"""The package as a user installs it: the wheel, in a fresh venv that sees only what pyproject.toml declares.

There is no network here, so the dependencies cannot be downloaded, and the lock's environment
holds installed distributions, not wheels, so ``pip install --no-index`` has nothing to install
them from. The honest route instead: a fresh venv (no system site-packages), the wheel installed
into it by pip with ``--no-deps``, and then exactly the declared dependencies made visible to it —
the closure of the wheel's own ``Requires-Dist`` (plus the requested extras) over each
distribution's metadata, every file of each of those distributions (its RECORD) linked into the
venv's site-packages, nothing else. A dependency that pyproject.toml forgets is then missing in
the venv (``import wsmap`` fails, as it did for numba), a lower bound the lock does not meet fails
the version check, and ``pip check`` checks the staged set for consistency.

Slow: the numba kernels are compiled afresh for the installed files, once for both maps (one
venv, a shared ``NUMBA_CACHE_DIR``), about 15 s of CPU; the wheel's C++ kernel is built by CMake
configured afresh, ninja reusing the objects of the checkout's own install where they are current
(otherwise another minute of CPU: see ``_build_wheel``). Part of ``make test``.
"""

from __future__ import annotations

import importlib.metadata as md
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("wheel")]

packaging = pytest.importorskip("packaging.requirements")
from packaging.markers import default_environment  # noqa: E402
from packaging.requirements import Requirement  # noqa: E402
from packaging.utils import canonicalize_name  # noqa: E402

#: A three-joint arm (two links of 0.3 m), as a user would bring it.
URDF = """<?xml version="1.0"?>
<robot name="three">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="tip"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="tip"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 1 0"/><limit lower="-2.5" upper="2.5" effort="1" velocity="1"/></joint>
</robot>
"""


def _editable_build_dir() -> Path | None:
    """The build folder of the checkout's own install for this interpreter (pyproject.toml's
    ``build-dir = "build/{wheel_tag}"``, configured for this checkout), or None."""
    v = f"{sys.version_info.major}{sys.version_info.minor}"
    for cache in sorted((ROOT / "build").glob(f"cp{v}-cp{v}-*/CMakeCache.txt")):
        if f"CMAKE_HOME_DIRECTORY:INTERNAL={ROOT}\n" in cache.read_text():
            return cache.parent
    return None


def _build_wheel(out: Path) -> Path:
    """``python -m build --wheel --no-isolation`` of the checkout, into a build folder of the test's
    own (the checkout's files and its build folder stay as they are).

    CMake configures that folder afresh, the checkout's CMakeLists.txt as a user's build does; where
    the checkout's own install has a build folder (``make test`` has just compiled the kernel there,
    from these sources), its compiled objects and ninja's records are copied in first (not its CMake
    cache), so ninja recompiles only the sources that changed since, instead of the same C++ once
    more (a minute of CPU)."""
    build = out / "build"
    previous = _editable_build_dir()
    if previous is not None:
        shutil.copytree(previous, build, symlinks=True, ignore=shutil.ignore_patterns("CMakeCache.txt"))
    r = subprocess.run([sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir", str(out / "dist"),
                        f"-Cbuild-dir={build}", str(ROOT)], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    (wheel,) = (out / "dist").glob("wsmap-*.whl")
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
    assert "wsmap/py.typed" in names  # PEP 561
    assert any(n.startswith("wsmap/kinematics/_lanes.") and n.endswith((".so", ".pyd")) for n in names)
    return wheel


def _requirements(metadata_lines, extras) -> list[Requirement]:
    """The requirements of a distribution's ``Requires-Dist`` lines that apply with ``extras``."""
    out = []
    env = default_environment()
    for line in metadata_lines or ():
        req = Requirement(line)
        if req.marker is None or any(req.marker.evaluate({**env, "extra": e}) for e in (extras or {""})):
            out.append(req)
    return out


def _closure(reqs: list[Requirement], wheel_requires) -> dict[str, tuple[md.Distribution, set]]:
    """Every installed distribution the requirements need, transitively: name -> (dist, extras)."""
    found: dict[str, tuple[md.Distribution, set]] = {}
    todo = list(reqs)
    while todo:
        req = todo.pop()
        name = canonicalize_name(req.name)
        if name == "wsmap":  # the package's own extras (wsmap[learn,...]) are its own requirements
            todo += _requirements(wheel_requires, set(req.extras))
            continue
        dist, extras = found.get(name, (None, set()))
        if dist is not None and set(req.extras) <= extras:
            continue
        dist = md.distribution(req.name)  # PackageNotFoundError: the lock lacks a declared dependency
        assert req.specifier.contains(dist.version, prereleases=True), \
            f"the environment's {req.name} {dist.version} does not meet the declared {req}"
        extras = extras | set(req.extras)
        found[name] = (dist, extras)
        todo += _requirements(dist.requires, extras)
    return found


def _stage(found, site: Path) -> None:
    """Link every file of each distribution (by its RECORD) into ``site``, top-level entries only."""
    for dist, _ in found.values():
        base = Path(dist.locate_file(""))
        tops = {Path(f).parts[0] for f in dist.files or () if not str(f).startswith("..")}
        for top in sorted(tops):
            target = site / top
            if not target.exists() and (base / top).exists():
                target.symlink_to(base / top)


def _venv(tmp: Path, wheel: Path) -> tuple[Path, dict]:
    """A fresh venv with the wheel installed (no dependencies yet), and the environment to run it in."""
    venv = tmp / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    subprocess.run([sys.executable, "-m", "pip", "--python", str(venv / "bin" / "python"), "install", "--quiet",
                    "--no-deps", "--no-index", "--no-compile", str(wheel)], check=True, capture_output=True, text=True)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "WSMAP_ROOT", "PYTHONHOME")}
    env.update(PATH=f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}", NUMBA_CACHE_DIR=str(tmp / "numba-cache"),
               MPLBACKEND="Agg")
    return venv, env


def _declare(venv: Path, wheel: Path, extras=()) -> None:
    """Make the wheel's declared dependencies (with ``extras``) visible in ``venv``, and nothing else."""
    with zipfile.ZipFile(wheel) as z:
        meta = next(n for n in z.namelist() if n.endswith(".dist-info/METADATA"))
        text = z.read(meta).decode()
    requires = [line.split(":", 1)[1].strip() for line in text.splitlines() if line.startswith("Requires-Dist:")]
    found = _closure(_requirements(requires, set(extras)), requires)
    _stage(found, next((venv / "lib").glob("python*/site-packages")))


def _run(venv, env, cwd, *argv, code=0):
    r = subprocess.run([str(venv / "bin" / "wsmap"), *argv], cwd=cwd, env=env, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == code, f"wsmap {' '.join(argv)}: exit {r.returncode}\n{r.stdout}\n{r.stderr}"
    return r


def test_the_wheel_installs_a_working_tool(tmp_path):
    wheel = _build_wheel(tmp_path)
    work = tmp_path / "work"  # outside the checkout, as a user runs it
    work.mkdir()
    (work / "three.urdf").write_text(URDF)

    venv, env = _venv(tmp_path, wheel)
    _declare(venv, wheel)
    py = str(venv / "bin" / "python")
    where = subprocess.run([py, "-c", "import wsmap; print(wsmap.__file__)"], env=env, capture_output=True,
                           text=True, check=True).stdout
    assert str(venv) in where, f"wsmap imported from {where}, not the venv"
    # the wheel carries the compiled lane kernel, and the search runs on it
    kernel = subprocess.run([py, "-c", "from wsmap.kinematics import lm_lanes; print(lm_lanes.kernel())"], env=env,
                            capture_output=True, text=True, check=True).stdout
    assert kernel.strip() == "lanes"
    check = subprocess.run([sys.executable, "-m", "pip", "--python", py, "check"], capture_output=True, text=True)
    assert check.returncode == 0, check.stdout + check.stderr
    from wsmap import __version__

    assert _run(venv, env, work, "--version").stdout.strip() == f"wsmap {__version__}"
    _run(venv, env, work, "map", "--robot", "panda", "--step", "0.5", "--out", "panda.npz", "-q")
    assert (work / "panda.npz").stat().st_size > 0
    # the optional parts that are not installed: one line naming the extra, before any work, nothing written
    r = _run(venv, env, work, "map", "--urdf", "three.urdf", "--out", "three.npz", code=2)
    assert r.stderr.strip().splitlines() == [
        "wsmap: error: a URDF arm needs yourdfpy, which is not installed: pip install 'wsmap[urdf]'"]
    r = _run(venv, env, work, "map", "--robot", "puma560", "--step", "0.5", "--html", "v.html", code=2)
    assert "pip install 'wsmap[views]'" in r.stderr and "Traceback" not in r.stderr
    r = _run(venv, env, work, "paper", "list", code=2)
    assert "needs a checkout of the wsmap repository" in r.stderr
    assert sorted(p.name for p in work.iterdir()) == ["panda.npz", "three.urdf"]

    _declare(venv, wheel, extras=("urdf",))  # pip install 'wsmap[urdf]'
    # a three-joint arm reaches positions, not every orientation: its reach map
    _run(venv, env, work, "map", "--urdf", "three.urdf", "--kind", "reach", "--step", "0.25", "--out", "three.npz",
         "-q")
    import numpy as np

    with np.load(work / "three.npz") as f:
        assert f["map"].dtype == bool and f["map"].any()
