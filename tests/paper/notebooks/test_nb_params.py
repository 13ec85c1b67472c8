"""Notebook parameters come from the params files only (no notebook runs here: these read sources).

Every notebook's papermill parameters cell holds exactly ``params_file`` and ``output_root``; the
notebook reads its section with ``paths.notebook_params(NAME, params_file)`` and holds no defaults
of its own; it hands the section to its part (``wsmap.paper.parts.NAME``), so every key the two
read must be in the committed, smoke and paper-scale files alike, and a missing key is an error,
not a silent default.
"""

import ast
import re

import nbformat
import pytest
import yaml

from wsmap import paths
from wsmap.paper import published

PARAMS_FILES = ("params.yaml", "params.smoke.yaml", "params.full.yaml")
#: cfg["key"] / cfg['key'] in a notebook's source
CFG_KEY = re.compile(r"""\bcfg\[\s*(['"])([^'"\]]+)\1\s*\]""")


def _notebooks():
    return sorted(p.stem for p in paths.NOTEBOOKS.glob("*.ipynb"))


def _source(name):
    return (paths.NOTEBOOKS / "py" / f"{name}.py").read_text()


def _part_source(name):
    """The source of the notebook's part, ``src/wsmap/paper/parts/NAME.py``."""
    return (paths.ROOT / "src" / "wsmap" / "paper" / "parts" / f"{name}.py").read_text()


def _code(name):
    """The code cells of the built notebook (what papermill runs), joined."""
    nb = nbformat.read(paths.NOTEBOOKS / f"{name}.ipynb", as_version=4)
    return "\n\n".join(c.source for c in nb.cells if c.cell_type == "code")


def _sections(name):
    return {f: paths.load_params(name, paths.ROOT / f) for f in PARAMS_FILES}


def _shared_readers() -> dict[str, set[str]]:
    """The functions of :mod:`wsmap.paper.fitting` that take a section as ``cfg``: name -> the keys
    each reads (a part that passes its ``cfg`` to one reads those keys too)."""
    tree = ast.parse((paths.ROOT / "src" / "wsmap" / "paper" / "fitting.py").read_text())
    return {f.name: {m.group(2) for m in CFG_KEY.finditer(ast.unparse(f))}
            for f in tree.body if isinstance(f, ast.FunctionDef) and any(a.arg == "cfg" for a in f.args.args)}


def _passed_on(src: str) -> set[str]:
    """The keys read by the shared functions that ``src`` calls with ``cfg`` (``fitting.f(cfg, ...)``)."""
    readers = _shared_readers()
    keys = set()
    for node in ast.walk(ast.parse(src)):
        if isinstance(node, ast.Call) and any(isinstance(a, ast.Name) and a.id == "cfg" for a in node.args):
            fn = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", None)
            keys |= readers.get(fn, set())
    return keys


def _read_keys(name):
    """The keys the notebook and its part read (``cfg[...]``, directly or through a shared function of
    :mod:`wsmap.paper.fitting` they pass ``cfg`` to; a part reads nothing else of it)."""
    direct = {m.group(2) for src in (_source(name), _part_source(name)) for m in CFG_KEY.finditer(src)}
    return direct | _passed_on(_part_source(name))


@pytest.mark.parametrize("name", _notebooks())
def test_parameters_cell_holds_only_params_file_and_output_root(name):
    nb = nbformat.read(paths.NOTEBOOKS / f"{name}.ipynb", as_version=4)
    cells = [c for c in nb.cells if "parameters" in c.metadata.get("tags", [])]
    assert len(cells) == 1, f"{name}: {len(cells)} cells tagged parameters"
    body = ast.parse(cells[0].source).body
    assigned = []
    for stmt in body:
        assert isinstance(stmt, ast.Assign) and len(stmt.targets) == 1 and isinstance(stmt.targets[0], ast.Name), (
            f"{name}: the parameters cell may only assign names: {ast.unparse(stmt)}")
        assert isinstance(stmt.value, ast.Constant) and stmt.value.value is None, (
            f"{name}: {stmt.targets[0].id} must default to None (the params file holds the values)")
        assigned.append(stmt.targets[0].id)
    assert assigned == ["params_file", "output_root"]


@pytest.mark.parametrize("name", _notebooks())
def test_notebook_reads_its_section_and_holds_no_defaults(name):
    src = _code(name)
    tree = ast.parse(src)
    # cfg is bound once, to the notebook's own section of the params file it was given
    binds = [n for n in ast.walk(tree) if isinstance(n, (ast.Assign, ast.AnnAssign, ast.AugAssign))
             and any(isinstance(t, ast.Name) and t.id == "cfg"
                     for t in (n.targets if isinstance(n, ast.Assign) else [n.target]))]
    assert [ast.unparse(n) for n in binds] == [f"cfg = paths.notebook_params('{name}', params_file)"], (
        f"{name}: cfg must be bound once, to paths.notebook_params({name!r}, params_file)")
    for node in ast.walk(tree):
        # no cfg.get(key, default), cfg.setdefault, cfg.update, cfg | {...}
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "cfg":
            assert node.attr not in ("get", "setdefault", "update", "pop"), f"{name}: cfg.{node.attr}"
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.BitOr):
            assert "cfg" not in {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}, (
                f"{name}: merges cfg with a dict: {ast.unparse(node)}")
        if isinstance(node, ast.Subscript) and isinstance(node.ctx, ast.Store):
            assert not (isinstance(node.value, ast.Name) and node.value.id == "cfg"), (
                f"{name}: sets a parameter: {ast.unparse(node)}")
        # no {defaults..., **params} / dict(defaults, **cfg): the old scheme's merge
        if isinstance(node, ast.Dict):
            unpacked = [v for k, v in zip(node.keys, node.values) if k is None]
            assert not any(isinstance(v, ast.Name) and v.id in ("params", "cfg") for v in unpacked), (
                f"{name}: a defaults dict merged with the parameters")
        if isinstance(node, ast.keyword) and node.arg is None:
            assert not (isinstance(node.value, ast.Name) and node.value.id in ("params", "cfg")), (
                f"{name}: a defaults dict merged with the parameters")
        # the old parameters dict is gone
        assert not (isinstance(node, ast.Name) and node.id == "params"), f"{name}: uses the old `params` dict"
    assert "cfg.get(" not in _source(name) and "cfg.get(" not in _part_source(name)


@pytest.mark.parametrize("name", _notebooks())
def test_every_key_a_notebook_reads_is_in_every_params_file(name):
    keys = _read_keys(name)
    assert keys, f"{name} reads no cfg[...] key"
    for f, section in _sections(name).items():
        missing = sorted(keys - set(section))
        assert not missing, f"{f} section {name!r} lacks {missing}, which {name}'s notebook or part reads"
        unread = sorted(set(section) - keys)
        assert not unread, f"{f} section {name!r} has {unread}, which {name}'s notebook and part never read"


@pytest.mark.parametrize("name", _notebooks())
def test_params_files_agree_on_the_keys_of_each_section(name):
    sections = _sections(name)
    committed = set(sections["params.yaml"])
    for f, section in sections.items():
        assert set(section) == committed, f"{f} section {name!r} differs in keys from params.yaml"


def test_a_missing_parameter_is_an_error_naming_it(tmp_path):
    path = tmp_path / "params.yaml"
    path.write_text(yaml.safe_dump({"sec61_subspace": {"seed": 0}}))
    cfg = paths.notebook_params("sec61_subspace", path)
    assert cfg["seed"] == 0
    with pytest.raises(KeyError) as e:
        cfg["train_samples"]
    assert "train_samples" in str(e.value) and "sec61_subspace" in str(e.value) and "params.yaml" in str(e.value)
    with pytest.raises(TypeError):  # no defaults through the back door
        cfg.get("train_samples", 10)
    with pytest.raises(ValueError, match="table2_optimisers"):  # nor a whole missing section
        paths.notebook_params("table2_optimisers", path)


def _distinctive(value) -> bool:
    """A published number with at least 4 digits after any leading '0.' (0.9665, 5227.8, 0.0313):
    unlikely to appear in a notebook for any other reason."""
    if not isinstance(value, float) or value != value:
        return False
    text = repr(value)
    return len(text.removeprefix("0.").replace(".", "")) >= 4


@pytest.mark.parametrize("name", _notebooks())
def test_notebooks_take_the_papers_numbers_from_published(name):
    """The paper's numbers live in wsmap.paper.published only: no notebook repeats them."""
    numbers = sorted({repr(v) for v in published.PAPER.values() if _distinctive(v)})
    assert "0.9665" in numbers and "5227.8" in numbers  # the guard guards something
    for what, src in ((f"notebooks/py/{name}.py", _source(name)),
                      (f"src/wsmap/paper/parts/{name}.py", _part_source(name))):
        found = [n for n in numbers if re.search(rf"(?<![\d.]){re.escape(n)}(?!\d)", src)]
        assert not found, f"{what} repeats the paper's {found}: use wsmap.paper.published"
