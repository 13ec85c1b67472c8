"""``wsmap paper full``: paper-scale parts, resumable (run here with params.smoke.yaml: seconds).

Resumability: a part whose result holds the same settings hash is skipped; other settings rerun it;
a run that crashes half way leaves no part file and no temporary file, and the next run reuses the
steps that had finished. Also the listing, and bad input (exit 2, one line, nothing written).
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
import yaml

from wsmap import cli, paths
from wsmap.paper import full

SMOKE = paths.ROOT / "params.smoke.yaml"
FULL = paths.ROOT / "params.full.yaml"
QUICK = ["table1_r3_step1", "table2_rprop_mse"]  # the fastest parts (about a second together)


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory):
    """One dataset folder for the module: parts build what they need into it on demand."""
    return tmp_path_factory.mktemp("full_data")


def _run(argv, capsys):
    code = cli.main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file()) if folder.exists() else []


def _args(out, data, params=SMOKE):
    return ["--params", str(params), "--out", str(out), "--data", str(data)]


def _changed_params(tmp_path, section, **values) -> Path:
    params = yaml.safe_load(SMOKE.read_text())
    params[section].update(values)
    path = tmp_path / "params.changed.yaml"
    path.write_text(yaml.safe_dump(params))
    return path


def test_the_plan_of_the_paper_scale():
    parts = full.plan(FULL)
    names = [p.name for p in parts]
    assert names == ["sec61_subspace", "sec62_puma560", "table1_r3_step1", "table1_r3_step05", "table1_r3_block5",
                     "table1_r3_crop3087", "table1_r3_full", "table1_so3_pi3", "table1_so3_pi8", "table1_so3_pi10",
                     "table2_rprop_mse", "table3_subspace", "table3_workspace", "table3_nosubspace"]
    by = {p.name: p for p in parts}
    sec61 = by["sec61_subspace"].settings
    assert sec61["section"]["train_samples"] == 100_000 and sec61["train_config"]["max_epochs"] == 1000
    assert len(by["sec61_subspace"].steps) == sec61["section"]["sessions"] >= 3
    assert by["sec62_puma560"].steps == [f"block_{k}" for k in range(1, 8)]
    assert by["table1_r3_crop3087"].settings["section"]["train_samples"] == 30_000
    assert by["table1_r3_full"].settings["train_config"]["max_epochs"] == 1000
    assert by["table2_rprop_mse"].settings["train_config"]["optimizer"] == "rprop"
    assert set(by["table3_workspace"].datasets) == {"table3_subspace", "table3_workspace", "table3_nosubspace"}
    assert all(p.device == "auto" and "params.full.yaml" in p.device_what for p in parts)
    assert all("device" not in p.settings["train_config"] for p in parts)  # the device is not hashed
    # the hash is of the settings: another device, the same hash
    assert [p.hash for p in full.plan(FULL, device="cpu")] == [p.hash for p in parts]
    assert full.select(parts, ["table1"]) == [p for p in parts if p.kind == "table1"]
    assert [p.name for p in full.select(parts, ["table3_*", "sec61_subspace"])] == [
        "sec61_subspace", "table3_subspace", "table3_workspace", "table3_nosubspace"]


def test_the_runner_runs_the_parts_own_records():
    """Each unit runs through its part module's own ``SCALE`` (the record on its registered
    ``PART``); the runner names no part and switches on no kind."""
    import ast
    import importlib

    from wsmap.paper import parts
    from wsmap.paper.scale import Planner

    scaled = {name: p for name, p in parts.registry().items() if p.scale is not None}
    assert list(scaled) == ["sec61_subspace", "sec62_puma560", "table1_workspaces", "table2_optimisers",
                            "table3_embeddings"]
    assert all(p.scale is importlib.import_module(p.module).SCALE for p in scaled.values())
    units = full.plan(SMOKE)
    assert [u.kind for u in units] == [p.scale.kind for p in scaled.values() for u in p.scale.plan(
        paths.notebook_params(p.name, SMOKE), Planner(SMOKE))]
    source = Path(full.__file__).read_text()
    strings = {n.value for n in ast.walk(ast.parse(source)) if isinstance(n, ast.Constant) and isinstance(n.value, str)}
    assert not strings & ({*parts.order(), *(u.kind for u in units), *(u.name for u in units)})
    assert "kind ==" not in source and ".kind in" not in source


def test_a_part_runs_end_to_end_and_is_skipped_when_done(tmp_path, data_dir, capsys):
    out = tmp_path / "out"
    code, stdout, err = _run(["paper", "full", *QUICK, *_args(out, data_dir)], capsys)
    assert code == 0, err
    result = json.loads((out / "table1_r3_step1.json").read_text())
    part = full.select(full.plan(SMOKE), ["table1_r3_step1"])[0]
    assert result["settings_hash"] == part.hash and result["settings"] == json.loads(json.dumps(part.settings))
    assert result["metrics"]["dataset"] == "table1_r3_step1" and 0 <= result["metrics"]["f"] <= 1
    assert result["metrics"]["paper_f"] == 1.0 and len(result["metrics"]["runs"]) == 1
    assert result["steps"][0]["step"] == "session_0" and result["steps"][0]["timings"]["train_s"] > 0
    assert result["wall_seconds"] > 0 and result["device"]["used"] == "cpu"
    assert result["machine"]["cpus"] >= 1 and "torch" in result["machine"]
    history = json.loads((out / "table1_r3_step1.history.json").read_text())
    assert len(history["steps"]["session_0"]["loss"]) == 6  # epochs 0..5 of the smoke run
    table2 = json.loads((out / "table2_rprop_mse.json").read_text())
    assert [r["session"] for r in table2["metrics"]["runs"]] == [0, 1] and table2["metrics"]["sessions"] == 2
    mtimes = {p: p.stat().st_mtime_ns for p in out.rglob("*.json")}

    code, stdout, err = _run(["paper", "full", *QUICK, *_args(out, data_dir)], capsys)
    assert code == 0, err
    assert "table1_r3_step1: done" in stdout and "skipped" in stdout and "running" not in stdout
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*.json")} == mtimes


def test_changed_settings_rerun_the_part(tmp_path, data_dir, capsys):
    out = tmp_path / "out"
    assert _run(["paper", "full", "table1_r3_step1", *_args(out, data_dir)], capsys)[0] == 0
    first = json.loads((out / "table1_r3_step1.json").read_text())
    changed = _changed_params(tmp_path, "table1_workspaces", max_epochs=3)
    assert full.part_state(full.select(full.plan(changed), ["table1_r3_step1"])[0], out)["state"] == "stale"
    code, stdout, _ = _run(["paper", "full", "table1_r3_step1", *_args(out, data_dir, changed)], capsys)
    assert code == 0 and "session_0: running" in stdout
    second = json.loads((out / "table1_r3_step1.json").read_text())
    assert second["settings_hash"] != first["settings_hash"]
    assert second["settings"]["train_config"]["max_epochs"] == 3 and second["metrics"]["runs"][0]["epochs"] == 3
    # a dataset of another size is another setting too, and the dataset is rebuilt at that size
    bigger = _changed_params(tmp_path, "datasets", table1_r3_step1={"samples": 310, "test_samples": 100})
    part = full.select(full.plan(bigger), ["table1_r3_step1"])[0]
    assert part.hash != first["settings_hash"]
    result = full.run_part(part, out, data_dir, log=lambda s: None)
    assert result["timings"]["datasets"]["table1_r3_step1"]["build_s"] >= 0
    assert result["settings"]["datasets"]["table1_r3_step1"]["samples"] == 310


def test_more_sessions_reuse_the_sessions_already_run(tmp_path, data_dir, capsys):
    """Session k trains with seed + k whatever the number of sessions: raising ``sessions`` (one
    dataset's, ``{default: 1, name: 3}``) runs only the new ones, also where a finished result is
    all that is left of the earlier run (its step files gone), and gives what a run in one go gives."""
    import shutil

    out = tmp_path / "out"
    assert _run(["paper", "full", "table1_r3_step1", *_args(out, data_dir)], capsys)[0] == 0
    first = json.loads((out / "table1_r3_step1.json").read_text())
    shutil.rmtree(out / "steps")  # a result from before the step files, as results/full/ had
    more = _changed_params(tmp_path, "table1_workspaces", sessions={"default": 1, "table1_r3_step1": 3})
    by = {p.name: p for p in full.plan(more)}
    part = by["table1_r3_step1"]
    assert part.steps == ["session_0", "session_1", "session_2"] and by["table1_r3_step05"].steps == ["session_0"]
    assert part.hash != first["settings_hash"] and part.step_hash == full.step_hash(first["settings"])
    assert full.part_state(part, out)["steps_done"] == 1
    code, stdout, err = _run(["paper", "full", "table1_r3_step1", *_args(out, data_dir, more)], capsys)
    assert code == 0, err
    assert "session_0: done earlier" in stdout and stdout.count("running") == 2
    grown = json.loads((out / "table1_r3_step1.json").read_text())
    assert grown["metrics"]["sessions"] == 3 and [r["seed"] for r in grown["metrics"]["runs"]] == [0, 1, 2]
    assert grown["metrics"]["runs"][0] == first["metrics"]["runs"][0]
    assert json.loads((out / "steps" / "table1_r3_step1" / "session_0.json").read_text())["step_hash"] == part.step_hash
    fresh = full.run_part(part, tmp_path / "fresh", data_dir, log=lambda s: None)
    assert [r["f"] for r in grown["metrics"]["runs"]] == [r["f"] for r in fresh["metrics"]["runs"]]
    assert grown["metrics"]["f_session_std"] == pytest.approx(np.std([r["f"] for r in fresh["metrics"]["runs"]],
                                                                      ddof=1))
    # another setting than the number of sessions is not reused
    other = _changed_params(tmp_path, "table1_workspaces", sessions=3, max_epochs=3)
    assert full.part_state(full.select(full.plan(other), ["table1_r3_step1"])[0], out)["steps_done"] == 0


def test_a_crashed_run_leaves_no_partial_file_and_resumes(tmp_path, data_dir, monkeypatch, capsys):
    out = tmp_path / "out"
    part = full.select(full.plan(SMOKE), ["table2_rprop_mse"])[0]
    real = full.run_step

    def crash_on_second(unit, step, *args):
        if unit.name == "table2_rprop_mse" and step == "session_1":
            raise KeyboardInterrupt  # Ctrl-C, or SIGTERM (the CLI turns it into this)
        return real(unit, step, *args)

    monkeypatch.setattr(full, "run_step", crash_on_second)
    code, _, err = _run(["paper", "full", "table2_rprop_mse", *_args(out, data_dir)], capsys)
    assert code == 130 and "interrupted" in err
    files = _files(out)
    assert "table2_rprop_mse.json" not in files and "table2_rprop_mse.history.json" not in files
    assert not [f for f in files if Path(f).name.startswith(".")]  # no temporary file left
    assert files == ["models/table2_rprop_mse/session_0.pt", "steps/table2_rprop_mse/session_0.json"]
    assert full.part_state(part, out)["state"] == "partial"
    lines = full.list_lines(SMOKE, out, data_dir, names=["table2_rprop_mse"])
    assert "partial" in lines[1] and "1/2" in lines[1]

    monkeypatch.setattr(full, "run_step", real)
    code, stdout, err = _run(["paper", "full", "table2_rprop_mse", *_args(out, data_dir)], capsys)
    assert code == 0, err
    assert "session_0: done earlier" in stdout and "session_1: running" in stdout
    resumed = json.loads((out / "table2_rprop_mse.json").read_text())
    # the same numbers as a run in one go
    fresh = full.run_part(part, tmp_path / "fresh", data_dir, log=lambda s: None)
    assert [r["f"] for r in resumed["metrics"]["runs"]] == [r["f"] for r in fresh["metrics"]["runs"]]


def test_a_fresh_checkout_resumes_from_the_committed_step_files(tmp_path, data_dir, capsys):
    """Step files are committed, models are not: a session's steps survive a fresh checkout, and
    a §6.2 block runs again only where its model (which the stacked §6.2 model needs) is gone."""
    import shutil

    out = tmp_path / "out"
    assert _run(["paper", "full", "table2_rprop_mse", "sec62", *_args(out, data_dir)], capsys)[0] == 0
    first = {n: json.loads((out / f"{n}.json").read_text()) for n in ("table2_rprop_mse", "sec62_puma560")}
    # what a fresh clone holds: the part and step files, no model
    for name in first:
        (out / f"{name}.json").unlink()
    shutil.rmtree(out / "models" / "table2_rprop_mse")
    (out / "models" / "sec62_puma560" / "block_3.pt").unlink()
    sec62 = full.select(full.plan(SMOKE), ["sec62"])[0]
    assert full.part_state(sec62, out)["steps_done"] == 6

    code, stdout, err = _run(["paper", "full", "table2_rprop_mse", "sec62", *_args(out, data_dir)], capsys)
    assert code == 0, err
    assert "session_0: done earlier" in stdout and "session_1: done earlier" in stdout
    assert "block_3: running" in stdout and stdout.count("running") == 1
    again = {n: json.loads((out / f"{n}.json").read_text()) for n in first}
    assert again["table2_rprop_mse"]["metrics"]["runs"] == first["table2_rprop_mse"]["metrics"]["runs"]
    # the rerun block is seeded as before: the same scores, so the same stacked map
    assert again["sec62_puma560"]["metrics"]["f_blocks"] == first["sec62_puma560"]["metrics"]["f_blocks"]


def test_section_6_1_sweeps_its_best_session_and_a_new_sweep_trains_nothing(tmp_path, data_dir, capsys):
    """§6.1's threshold sweep (the paper's "best threshold 0.5, F 0.9714") is its best session's
    model on the test set. Another ``sweep_points`` summarises the same sessions again without
    training; a fresh checkout (step files, no models) trains them again, seeded as before."""
    from wsmap.learn.files import load
    from wsmap.metrics import threshold_sweep
    from wsmap.paper import fitting
    from wsmap.paper.specs import load_pair

    out = tmp_path / "out"
    code, _, err = _run(["paper", "full", "sec61", *_args(out, data_dir)], capsys)
    assert code == 0, err
    first = json.loads((out / "sec61_subspace.json").read_text())
    m = first["metrics"]
    best = m["best_session"]
    assert best == int(np.argmin([r["best_val_loss"] for r in m["runs"]]))
    model, _ = load(out / "models" / "sec61_subspace" / f"session_{best}.pt")
    ev = fitting.evaluate(model, load_pair("sec61", data_dir)[1])
    sweep = threshold_sweep(ev["scores"], ev["truth"], np.linspace(0.0, 1.0, 101))
    assert (m["best_threshold"], m["best_threshold_f"]) == (sweep.best_threshold, sweep.best_f)
    assert first["analysis"] == {"sweep_points": 101} and len(m["sweep"]["f"]) == 101
    assert m["sweep"]["thresholds"][50] == 0.5 and m["sweep"]["f"][50] == pytest.approx(m["best_session_f"])

    eleven = _changed_params(tmp_path, "sec61_subspace", sweep_points=11)
    code, stdout, err = _run(["paper", "full", "sec61", *_args(out, data_dir, eleven)], capsys)
    assert code == 0, err
    assert "running" not in stdout and stdout.count("done earlier") == 2
    again = json.loads((out / "sec61_subspace.json").read_text())
    assert again["settings_hash"] == first["settings_hash"] and again["analysis"] == {"sweep_points": 11}
    assert again["metrics"]["sweep"]["thresholds"] == np.linspace(0.0, 1.0, 11).tolist()
    assert again["metrics"]["runs"] == m["runs"]

    (out / "sec61_subspace.json").unlink()
    (out / "models" / "sec61_subspace" / "session_1.pt").unlink()
    code, stdout, err = _run(["paper", "full", "sec61", *_args(out, data_dir)], capsys)
    assert code == 0, err
    assert "session_0: done earlier" in stdout and "session_1: running" in stdout
    assert json.loads((out / "sec61_subspace.json").read_text())["metrics"]["f_sessions"] == m["f_sessions"]


def test_a_crash_while_writing_the_result_leaves_nothing_half_written(tmp_path, data_dir, monkeypatch):
    out = tmp_path / "out"
    part = full.select(full.plan(SMOKE), ["table1_r3_step1"])[0]
    real = Path.write_text

    def failing(self, text, *a, **k):
        if self.name.startswith(".table1_r3_step1.json"):  # the part file's temporary file
            real(self, text[:10])
            raise OSError(28, "No space left on device")
        return real(self, text, *a, **k)

    monkeypatch.setattr(Path, "write_text", failing)
    with pytest.raises(OSError):
        full.run_part(part, out, data_dir, log=lambda s: None)
    monkeypatch.undo()
    files = _files(out)
    assert "table1_r3_step1.json" not in files and "table1_r3_step1.history.json" not in files
    assert not [f for f in files if Path(f).name.startswith(".")]
    assert full.part_state(part, out)["state"] == "partial"


def test_the_listing(tmp_path, data_dir, capsys):
    out = tmp_path / "out"
    code, stdout, err = _run(["paper", "full", "--list", *_args(out, data_dir)], capsys)
    assert code == 0, err
    lines = stdout.splitlines()
    assert lines[0].split()[:4] == ["part", "state", "steps", "time"]
    assert len(lines) == 1 + 14 + 1 and all("pending" in line for line in lines[1:15])
    assert "0 of 14 parts done" in lines[-1]
    assert not out.exists()  # listing writes nothing
    assert _run(["paper", "full", "table1_r3_step1", *_args(out, data_dir)], capsys)[0] == 0
    stdout = _run(["paper", "full", "--list", *_args(out, data_dir)], capsys)[1]
    row = next(line for line in stdout.splitlines() if line.startswith("table1_r3_step1 "))
    assert "done" in row and "measured" in row and "1/1" in row
    assert "1 of 14 parts done" in stdout
    # the paper scale without estimates: a floating-point count on the CPU, every part pending
    lines = full.list_lines(FULL, out / "nothing", data_dir, device="cpu")
    assert all(("flops" in line) and ("≈" in line or "≤" in line) for line in lines[1:-1])
    sec61 = next(line for line in lines if line.startswith("sec61_subspace"))
    assert "h" in sec61.split("flops")[0]  # hours at the paper's scale


def test_estimates_are_timed_and_listed(tmp_path, data_dir, capsys):
    out = tmp_path / "out"
    code, stdout, err = _run(["paper", "full", "--estimate", "table1_r3_step1", *_args(out, data_dir)], capsys)
    assert code == 0, err
    est = json.loads((out / "estimates.json").read_text())
    assert est["table1_r3_step1"]["seconds_per_epoch"] > 0 and est["table1_r3_step1"]["device"] == "cpu"
    lines = full.list_lines(SMOKE, out, data_dir, names=["table1_r3_step1"])
    assert "timed" in lines[1]


@pytest.mark.parametrize("argv, message", [
    (["no_such_part"], "unknown part 'no_such_part'"),
    (["table1", "tabel2"], "unknown part 'tabel2'"),
    (["--device", "gpu"], "unknown --device 'gpu'"),
    (["--list", "--estimate"], "not both"),
])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, argv, message, capsys):
    out, data = tmp_path / "out", tmp_path / "data"
    code, stdout, err = _run(["paper", "full", *argv, *_args(out, data)], capsys)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1
    assert not out.exists() and not data.exists()


@pytest.mark.skipif(torch.cuda.is_available(), reason="this machine has a GPU")
def test_cuda_without_a_gpu_fails_before_any_work(tmp_path, capsys):
    out, data = tmp_path / "out", tmp_path / "data"
    params = _changed_params(tmp_path, "table2_optimisers", device="cuda")
    code, _, err = _run(["paper", "full", "table1_r3_step1", "table2", *_args(out, data, params)], capsys)
    assert code == 2 and "section 'table2_optimisers' device" in err and "CUDA" in err
    assert not out.exists() and not data.exists()
    code, _, err = _run(["paper", "full", "table1_r3_step1", "--device", "cuda", *_args(out, data)], capsys)
    assert code == 2 and "--device 'cuda'" in err and not data.exists()


def test_sections_6_1_and_6_2_end_to_end(tmp_path, data_dir):
    """§6.1's sessions equal one fit of all sessions; §6.2's 7 blocks assemble the whole map."""
    from wsmap.learn.training import TrainConfig
    from wsmap.paper import fitting
    from wsmap.paper.parts import sec61_subspace, sec62_puma560
    from wsmap.paper.specs import load_pair

    out = tmp_path / "out"
    sec61, sec62 = full.run(["sec61", "sec62"], SMOKE, out, data_dir, log=lambda s: None)
    cfg = paths.notebook_params("sec61_subspace", SMOKE)
    train, test = load_pair("sec61", data_dir)
    results = fitting.fit(train.head(cfg["train_samples"]), TrainConfig(max_epochs=cfg["max_epochs"],
                    max_fail=cfg["max_fail"], seed=cfg["seed"]), sessions=cfg["sessions"], hidden=cfg["hidden"])
    np.testing.assert_array_equal(sec61["metrics"]["f_sessions"], [fitting.evaluate(r.model, test)["f"] for r in results])
    assert sec61["metrics"]["paper"]["f_mean"] == 0.9665
    # the notebooks' parts' schemas: the paper-scale metrics are their summaries, key for key
    assert list(sec61["metrics"]) == list(sec61_subspace.PaperScaleMetrics.__annotations__)
    assert list(sec62["metrics"]) == list(sec62_puma560.PaperScaleMetrics.__annotations__)
    m = sec62["metrics"]
    assert len(m["f_blocks"]) == 7 and 0 <= m["f_full"] <= 1 and m["puma560_reachable_exact"] > 0
    assert [s["metrics"]["block"] for s in sec62["steps"]] == list(range(1, 8))
    from wsmap.learn.files import load

    model, _ = load(out / m["model_file"])
    assert model.n_subspaces == 7 and model.map_spec["assemble"]


def test_module_entry_point_lists(tmp_path):
    """``python -m wsmap paper full`` (the runner has no entry point of its own: cli imports it, not
    the other way round)."""
    r = subprocess.run([sys.executable, "-m", "wsmap", "paper", "full", "--list", "--params", str(SMOKE),
                        "--out", str(tmp_path / "out"), "--data", str(tmp_path / "data")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines()[1].startswith("sec61_subspace")


# --------------------------------------------------------------------------- the params file's own errors (issue 29)
def _edited(tmp_path, edit) -> Path:
    params = yaml.safe_load(SMOKE.read_text())
    edit(params)
    path = tmp_path / "params.edited.yaml"
    path.write_text(yaml.safe_dump(params))
    return path


@pytest.mark.parametrize("edit, message", [
    (lambda p: p["datasets"]["sec61"].pop("samples"),
     "params.edited.yaml section 'datasets', dataset 'sec61' has no 'samples' (it needs samples and test_samples)"),
    (lambda p: p["datasets"]["sec61"].update(samples="lots"),
     "params.edited.yaml section 'datasets', dataset 'sec61': samples must be a whole number of at least 1, "
     "got 'lots'"),
    (lambda p: p["datasets"].update(sec61=[1, 2]),
     "params.edited.yaml section 'datasets', dataset 'sec61' must be a mapping with samples and test_samples, "
     "got list"),
    (lambda p: p["sec61_subspace"].update(sessions="many"),
     "params.edited.yaml section 'sec61_subspace': sessions must be a whole number of at least 1, got 'many'"),
    (lambda p: p["table2_optimisers"].update(max_epochs=[1, 2]),
     "params.edited.yaml section 'table2_optimisers': max_epochs must be a whole number of at least 1, got [1, 2]"),
])
def test_a_bad_value_in_the_params_file_names_file_section_and_key(tmp_path, capsys, edit, message):
    params = _edited(tmp_path, edit)
    with pytest.raises(ValueError) as e:
        full.plan(params)
    assert str(e.value) == message
    code, _, err = _run(["paper", "full", "--list", *_args(tmp_path / "out", tmp_path / "data", params)], capsys)
    assert code == 2 and err == f"wsmap: error: {message}\n"


@pytest.mark.parametrize("text, message", [
    ("a: [1, 2\n", r"is not valid YAML at line 2, column 1: expected ',' or '\]', but got '<stream end>'$"),
    ("a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\nb: &b [" + ", ".join(["*a"] * 10) + "]\nc: &c ["
     + ", ".join(["*b"] * 10) + "]\nd: &d [" + ", ".join(["*c"] * 10) + "]\ne: [" + ", ".join(["*d"] * 10) + "]\n",
     r"holds more than 100000 values once its YAML aliases \(\*name\) are expanded"),
    ("a: &a [*a]\n", r"holds more than 100000 values"),  # a recursive alias
])
def test_a_params_file_that_is_not_yaml_or_an_alias_bomb_is_named(tmp_path, text, message):
    path = tmp_path / "p.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=f"^{re.escape(str(path))} {message}"):
        paths.load_params(path=path)
    path.write_bytes(b"\x00\xff\xfe binary")
    with pytest.raises(ValueError, match=f"^{re.escape(str(path))} is not a text file \\(byte 1 is not UTF-8\\)"):
        paths.load_params(path=path)
