"""The DVC-free runner: dataset building for a params file, and the errors it gives; the parts'
registry (the run order, what each part reads and writes) against dvc.yaml; no import circle among
the paper's modules and the command line."""

import ast
import importlib
import importlib.util
from pathlib import Path

import pytest
import yaml

from wsmap import paths
from wsmap.paper import parts, pipeline
from wsmap.paper.pipeline import build_datasets, run_notebook
from wsmap.paper.specs import load_pair


@pytest.fixture
def params_file(tmp_path):
    p = tmp_path / "params.yaml"
    p.write_text("datasets:\n  table1_r3_step1: {samples: 20, test_samples: 5}\n")
    return p


def test_build_datasets_builds_missing_pairs_once(tmp_path, params_file):
    data = tmp_path / "data"
    built = list(build_datasets(params_file, data))
    assert [name for name, _ in built] == ["table1_r3_step1"] and built[0][1] > 0
    train, test = load_pair("table1_r3_step1", data)
    assert (len(train), len(test)) == (20, 5)
    assert list(build_datasets(params_file, data)) == []  # already there: nothing to do
    assert [n for n, _ in build_datasets(params_file, data, rebuild=True)] == ["table1_r3_step1"]


def test_run_notebook_names_an_unknown_notebook(tmp_path):
    with pytest.raises(ValueError, match="unknown notebook 'nope'; known: .*sec61_subspace"):
        run_notebook("nope", root=tmp_path)


def test_a_failing_notebook_is_one_line_and_keeps_the_last_good_copy(tmp_path, capsys):
    """A root without the datasets: the notebook's own error in one line (no traceback), the
    executed copy with the traceback beside it, and the previous executed copy left in place."""
    from wsmap import cli, paths

    root = tmp_path / "root"
    executed = root / "results" / "notebooks"
    executed.mkdir(parents=True)
    (executed / "sec61_subspace.ipynb").write_text("the last good copy")
    code = cli.main(["paper", "run", "sec61_subspace", "--params", str(paths.ROOT / "params.smoke.yaml"),
                     "--root", str(root)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("wsmap: error: notebook sec61_subspace failed in cell ")
    assert f"FileNotFoundError: dataset file {root / 'data' / 'sec61.npz'} does not exist" in err
    assert (executed / "sec61_subspace.ipynb").read_text() == "the last good copy"
    assert "FileNotFoundError" in (executed / "sec61_subspace.failed.ipynb").read_text()
    assert sorted(p.name for p in executed.iterdir()) == ["sec61_subspace.failed.ipynb", "sec61_subspace.ipynb"]


# ------------------------------------------------------------------------------------------ parts

ORDER = ["classical_workspace", "sec61_subspace", "sec62_puma560", "table1_workspaces", "table2_optimisers",
         "table3_embeddings", "runtime_comparison", "improved_model", "real_arms", "reach_study", "learned_maps", "morphologies",
         "ram_protocol", "report"]


def test_the_run_order_and_what_each_part_reads_come_from_the_registry():
    assert pipeline.order() == parts.order() == ORDER
    assert parts.reads("learned_maps") == ["improved_model"]
    assert parts.reads("report") == [n for n in ORDER if n not in ("real_arms", "reach_study", "morphologies", "ram_protocol", "report")]
    assert all(parts.reads(n) == [] for n in ORDER[:8])
    # every notebook is a part, and every part a notebook
    assert sorted(p.stem for p in paths.NOTEBOOKS.glob("*.ipynb")) == sorted(ORDER)
    with pytest.raises(ValueError, match="unknown part 'nope'; known: classical_workspace, "):
        parts.reads("nope")


def _stage_files(stage: dict, *keys) -> set[str]:
    return {o if isinstance(o, str) else next(iter(o)) for k in keys for o in stage.get(k, [])}


def test_dvc_stages_hold_the_registry():
    """Each part is a dvc.yaml stage that writes the part's outputs (and its executed notebook) and
    depends on the outputs of exactly the parts it reads."""
    stages = yaml.safe_load((paths.ROOT / "dvc.yaml").read_text())["stages"]
    registry = parts.registry()
    assert set(stages) - {"datasets"} == set(registry)
    writer = {o: name for name in registry for o in _stage_files(stages[name], "outs", "plots", "metrics")}
    for name, part in registry.items():
        stage = stages[name]
        assert stage["cmd"] == f"python -m wsmap.paper.notebook {name}"
        outs = _stage_files(stage, "outs", "plots", "metrics")
        assert outs == {*part.outputs, f"results/notebooks/{name}.ipynb"}, name
        read = {writer[d] for d in stage["deps"] if d in writer}
        assert read == set(part.reads), f"dvc.yaml stage {name} depends on the outputs of {sorted(read)}"


def test_a_bad_registration_is_an_error_naming_it():
    sec61 = parts.part("sec61_subspace")
    with pytest.raises(ValueError, match="part 'sec61_subspace' registered twice"):
        parts.register(parts.Part("sec61_subspace", "another", 999))
    with pytest.raises(ValueError, match="parts 'new' and 'sec61_subspace' share priority 20"):
        parts.register(parts.Part("new", "new", sec61.priority))
    with pytest.raises(ValueError, match="must be a Python identifier"):
        parts.register(parts.Part("new-part", "new", 12345))
    assert parts.register(sec61) is sec61  # the same record again: nothing changes
    assert "new" not in parts.registry()


def test_metrics_are_held_to_their_schema():
    from wsmap.paper.parts import improved_model

    keys = parts.metric_keys(improved_model.Metrics)
    good = dict.fromkeys(keys, 0.0)
    assert parts.check_metrics(good, improved_model.Metrics, "x") is good
    with pytest.raises(ValueError, match=r"improved_model: metrics lack \['f'\]; have keys not in the schema \['g'\]"):
        parts.check_metrics({**{k: 0.0 for k in keys if k != "f"}, "g": 1}, improved_model.Metrics, "improved_model")


def test_the_report_reads_keys_of_the_parts_schemas():
    from wsmap.paper import report

    assert report.unknown_keys() == []
    assert parts.knows_key("sec61_subspace", "f_mean") and parts.knows_key("learned_maps", "panda7.speed.speedup")
    assert parts.knows_key("table2_optimisers", "rprop_mse.f_mean")
    assert parts.knows_key("table3_embeddings", "subspace.subspace.f_sample_std")
    assert parts.knows_key("runtime_comparison", "classical_per_node_numerical.9261")
    assert parts.knows_key("classical_workspace", "label_audit.fn_rate_max")
    assert not parts.knows_key("sec61_subspace", "f_meen")
    assert not parts.knows_key("learned_maps", "panda7.nope")
    assert not parts.knows_key("table2_optimisers", "rprop_mse.nope")
    assert not parts.knows_key("runtime_comparison", "nope.9261")


def test_every_notebook_calls_its_part():
    for name in ORDER:
        source = (paths.NOTEBOOKS / "py" / f"{name}.py").read_text()
        assert f"from wsmap.paper.parts import {name} as part" in source, name
        assert "part.run(cfg, out)" in source and "part.figures(result, out)" in source, name
        module = importlib.import_module(f"wsmap.paper.parts.{name}")
        assert module.PART is parts.part(name)


# ------------------------------------------------------------------------------------ import circles

def _imports(module: str) -> set[str]:
    """The ``wsmap`` modules ``module``'s source imports, function bodies included."""
    file = Path(importlib.import_module(module).__file__)
    is_pkg = file.name == "__init__.py"
    found = set()
    for node in ast.walk(ast.parse(file.read_text())):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.startswith("wsmap")}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = module.split(".") if is_pkg else module.split(".")[:-1]
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if not target.startswith("wsmap"):
                continue
            for a in node.names:
                sub = f"{target}.{a.name}"
                found.add(sub if _is_module(sub) else target)
    return found


def _is_module(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except ModuleNotFoundError:  # a name inside a module, not a submodule
        return False


def test_no_import_circle_among_the_paper_modules_and_the_cli():
    """``wsmap.cli`` and every ``wsmap.paper`` module: no module reaches itself through imports,
    those inside functions included (``python -m wsmap paper full``, not a ``__main__`` block in
    ``paper/full.py`` importing the command line)."""
    import pkgutil

    import wsmap.paper
    import wsmap.paper.parts

    mods = {"wsmap.cli", "wsmap.paper", "wsmap.paper.parts"}
    mods |= {f"wsmap.paper.{m.name}" for m in pkgutil.iter_modules(wsmap.paper.__path__)}
    mods |= {f"wsmap.paper.parts.{m.name}" for m in pkgutil.iter_modules(wsmap.paper.parts.__path__)}
    graph = {m: {i for i in _imports(m) if i in mods and i != m} for m in mods}

    def reach(start):
        seen, todo = set(), list(graph[start])
        while todo:
            m = todo.pop()
            if m not in seen:
                seen.add(m)
                todo += graph[m]
        return seen

    circles = sorted(m for m in mods if m in reach(m))
    assert not circles, f"import circles through {circles}: " + "; ".join(f"{m} -> {sorted(graph[m])}" for m in circles)


def test_building_the_datasets_checks_every_entry_before_the_first_build(tmp_path):
    import yaml

    from wsmap import paths as project_paths
    from wsmap.paper import pipeline

    params = yaml.safe_load((project_paths.ROOT / "params.smoke.yaml").read_text())
    params["datasets"]["panda7_tooldown"].pop("samples")  # the last entry: the first ones would be built before
    path = tmp_path / "p.yaml"
    path.write_text(yaml.safe_dump(params))
    with pytest.raises(ValueError, match=r"^p.yaml section 'datasets', dataset 'panda7_tooldown' has no 'samples'"):
        next(pipeline.build_datasets(path, tmp_path / "data"))
    assert not (tmp_path / "data").exists()
