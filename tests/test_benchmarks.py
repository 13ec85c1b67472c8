"""The benchmark scripts (benchmarks/<area>/*.py) stand on one harness (benchmarks/harness.py).

Read from the source: every script lies in an area folder, parses its options through
`harness.parser` (no `argparse.ArgumentParser` of its own), times through the harness, that is
through `wsmap.timing` (no raw `time.perf_counter` / `process_time` / `time.time`), and writes its
JSON through `harness.write_json`. Run, cheaply: every script imports and its `--help` prints
(all of them in one subprocess, so wsmap, numpy and torch load once); one script runs for real
at a tiny size and writes its JSON with the environment record. The benchmarks themselves are
never run here (minutes each). Every benchmark path a page, the Makefile or a docstring names exists.
"""

from __future__ import annotations

import ast
import json
import os
import re
import subprocess
import sys
import textwrap

import pytest

from wsmap import paths

BENCH = paths.ROOT / "benchmarks"
AREAS = ("kernel", "maps", "collision", "learn", "paper", "study")
SCRIPTS = sorted(p for area in AREAS for p in (BENCH / area).glob("*.py"))
IDS = [f"{p.parent.name}/{p.name}" for p in SCRIPTS]

sys.path.insert(0, str(BENCH))
import harness  # noqa: E402


def _tree(path):
    return ast.parse(path.read_text(), filename=str(path))


def test_every_script_lies_in_an_area_folder():
    assert len(SCRIPTS) >= 32
    loose = sorted(p.name for p in BENCH.glob("*.py") if p.name != "harness.py")
    assert not loose, f"benchmarks/ holds scripts outside the area folders {AREAS}: {loose}"
    others = sorted(d.name for d in BENCH.iterdir() if d.is_dir() and d.name not in AREAS + ("__pycache__",))
    assert not others, f"folders of benchmarks/ that are not areas: {others}"


@pytest.mark.parametrize("script", SCRIPTS, ids=IDS)
def test_script_uses_the_harness(script):
    """No argument parser, clock or JSON writer of its own: harness.parser, harness timing, harness.write_json."""
    tree = _tree(script)
    names = {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)}
    names |= {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
    names |= {a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) for a in n.names}
    assert "ArgumentParser" not in names, f"{script.name}: its own argparse.ArgumentParser; use harness.parser"
    raw = sorted(names & {"perf_counter", "process_time", "monotonic", "perf_counter_ns"})
    assert not raw, f"{script.name}: raw clock {raw}; time through the harness (wsmap.timing)"
    calls = {(n.func.value.id, n.func.attr) for n in ast.walk(tree) if isinstance(n, ast.Call)
             and isinstance(n.func, ast.Attribute) and isinstance(n.func.value, ast.Name)}
    assert ("time", "time") not in calls, f"{script.name}: time.time(); time through the harness"
    assert ("harness", "parser") in calls, f"{script.name}: options not from harness.parser"
    assert ("json", "dump") not in calls, f"{script.name}: json.dump; write through harness.write_json"
    assert ("harness", "write_json") in calls, f"{script.name}: --json not written by harness.write_json"
    mains = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "main"]
    assert mains and [a.arg for a in mains[0].args.args] == ["argv"], f"{script.name}: main(argv=None) missing"


def test_the_harness_times_through_wsmap_timing():
    tree = _tree(BENCH / "harness.py")
    imported = {(n.module, a.name) for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) for a in n.names}
    assert ("wsmap.timing", "time_call") in imported


_HELP = textwrap.dedent("""
    import contextlib, io, json, runpy, sys
    out = {}
    for path in sys.argv[1:]:
        sys.argv = [path, "--help"]
        buf = io.StringIO()
        try:
            with contextlib.redirect_stdout(buf):
                runpy.run_path(path, run_name="__main__")
            out[path] = {"code": None, "help": buf.getvalue()}
        except SystemExit as e:
            out[path] = {"code": e.code, "help": buf.getvalue()}
        except BaseException as e:
            out[path] = {"code": "error", "help": f"{type(e).__name__}: {e}"}
    print("RESULT" + json.dumps(out))
""")


@pytest.fixture(scope="module")
def helps():
    """Each script's `--help` (exit code and text), all run in one subprocess."""
    env = {"OMP_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, "-c", _HELP, *map(str, SCRIPTS)], capture_output=True, text=True,
                          timeout=600, cwd=paths.ROOT, env={**os.environ, **env})
    line = [x for x in proc.stdout.splitlines() if x.startswith("RESULT")]
    assert line, f"the --help runner failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
    return json.loads(line[-1][len("RESULT"):])


@pytest.mark.parametrize("script", SCRIPTS, ids=IDS)
def test_script_imports_and_prints_help(script, helps):
    got = helps[str(script)]
    assert got["code"] == 0, f"{script.name} --help: {got['help'][-1500:]}"
    assert "--json PATH" in got["help"], f"{script.name} --help names no --json"


def test_parser_common_options_and_the_old_repeats_spelling():
    ap = harness.parser("Title line.\n\nMore text.", repeat=5, threads=None, seed=3, quick="smaller")
    a = ap.parse_args([])
    assert (a.json, a.repeat, a.threads, a.seed, a.quick) == (None, 5, None, 3, False)
    assert ap.parse_args(["--repeats", "7"]).repeat == 7  # the name the documented commands use
    assert ap.parse_args(["--repeat", "2", "--threads", "4", "--quick"]).threads == 4
    assert ap.description == "Title line." and ap.epilog == "More text."
    with pytest.raises(SystemExit):
        ap.parse_args(["--repeat", "0"])
    bare = harness.parser(None).parse_args([])
    assert vars(bare) == {"json": None}  # options a script does not use are not offered


def test_timing_returns_the_answer_with_the_seconds():
    calls = []
    seconds, out = harness.best_of(lambda: calls.append(1) or len(calls), 3, warmup=2)
    assert out == 5 and len(calls) == 5 and seconds >= 0
    t, out = harness.timings(lambda: "x", 4)
    assert out == "x" and t.n == 4 and t.min <= t.mean
    with harness.Stopwatch() as sw:
        sum(range(1000))
    assert sw.seconds >= 0 and sw.cpu_seconds >= 0 and sw.timing.n == 1


def test_write_json_adds_the_environment_record(tmp_path):
    ap = harness.parser("t", threads=2)
    assert harness.write_json(ap.parse_args([]), {"rows": [1]}) is None  # no --json: nothing written
    out = tmp_path / "b.json"
    harness.write_json(ap.parse_args(["--json", str(out)]), [{"x": float("nan")}])
    got = json.loads(out.read_text())
    assert got["results"] == [{"x": None}]
    env = got["environment"]
    assert env["threads"] == 2 and env["versions"]["python"] and env["cpus"] >= 1
    assert set(env) >= {"machine", "load_average", "git_commit", "command", "utc", "thread_environment"}


def test_one_tiny_run_writes_its_table_and_json(tmp_path):
    out = tmp_path / "urdf.json"
    proc = subprocess.run([sys.executable, str(BENCH / "kernel" / "bench_urdf_long_chain.py"), "--links", "20",
                           "--old-max", "20", "--json", str(out)], capture_output=True, text=True, timeout=300,
                          cwd=paths.ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "| 20 |" in proc.stdout
    got = json.loads(out.read_text())
    assert got["rows"][0]["links"] == 20 and got["rows"][0]["old_check_seconds"] >= 0
    assert got["environment"]["command"].endswith(str(out))


def test_every_benchmark_path_named_in_the_docs_exists():
    named = re.compile(r"benchmarks/[\w/]+\.py")
    sources = [paths.ROOT / "README.md", paths.ROOT / "Makefile", *sorted((paths.ROOT / "docs").glob("*.md")),
               *sorted((paths.ROOT / "src").rglob("*.py")), *SCRIPTS]
    missing = sorted({f"{src.relative_to(paths.ROOT)}: {m}" for src in sources
                      for m in named.findall(src.read_text()) if not (paths.ROOT / m).is_file()})
    assert not missing, "benchmark paths that do not exist:\n" + "\n".join(missing)
