"""What a user of any command line expects: --version, -q, help without noise, outputs chosen freely
and checked, options a kind does not read refused, missing optional parts named with their extra."""

from __future__ import annotations

import argparse
import sys

import numpy as np
import pytest

from wsmap import __version__, cli, paths
from wsmap import workspace as ws
from wsmap._optional import EXTRAS, MissingDependency, require
from wsmap.workspace.kinds import INPUTS, kinds


def _subparsers(parser, prefix=()):
    yield prefix, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _subparsers(sub, prefix + (name,))


def test_version(capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(["--version"])
    assert e.value.code == 0 and capsys.readouterr().out.strip() == f"wsmap {__version__}"


def test_no_help_line_says_default_none():
    seen = 0
    for prefix, parser in _subparsers(cli._parser()):
        text = parser.format_help()
        assert "(default: None)" not in text and "(default: False)" not in text, " ".join(prefix)
        seen += 1
    assert seen >= 10  # wsmap, map, place, robots, data (build, list, audit), paper (run, list, full)


def test_quiet_has_a_short_form():
    for prefix, parser in _subparsers(cli._parser()):
        for action in parser._actions:
            if "--quiet" in action.option_strings:
                assert "-q" in action.option_strings, " ".join(prefix)


def test_library_and_cli_default_to_the_standard_convention(tmp_path):
    out = tmp_path / "m.npz"
    rpy = ["0.3", "0.2", "0.1"]
    assert cli.main(["map", "--robot", "puma560", "--step", "0.25", "--rpy", *rpy, "--out", str(out), "-q"]) == 0
    flat, nodes, _, settings = ws.load_map(out)
    assert settings["convention"] == "standard"
    from wsmap.cli.arguments import arm_source

    arm = arm_source(cli._parser().parse_args(["map", "--robot", "puma560"])).build()
    standard = ws.constant_orientation_map(arm, nodes, (0.3, 0.2, 0.1), convention="standard")
    np.testing.assert_array_equal(flat, standard)
    np.testing.assert_array_equal(ws.constant_orientation_map(arm, nodes, (0.3, 0.2, 0.1)), standard)
    paper = ws.constant_orientation_map(arm, nodes, (0.3, 0.2, 0.1), convention="paper")
    assert np.any(paper != standard)  # the default is a real choice here
    T = ws.target_poses(nodes[:3], (0.3, 0.2, 0.1))
    np.testing.assert_allclose(T[:, :3, 3], nodes[:3])  # transl(p)·R: the tool is at p


def test_the_paper_specs_keep_the_paper_convention():
    from wsmap.paper.runtime import grid_spec
    from wsmap.paper.specs import PAPER_SPECS

    for name, spec in PAPER_SPECS.items():
        assert spec.convention == "paper", name
    assert grid_spec(0.5).convention == "paper"


@pytest.mark.parametrize("name", INPUTS)
def test_an_input_a_kind_does_not_read_is_refused(name, tmp_path, capsys):
    value = {"rpy": ["0", "0", "1"], "point": ["0.1", "0.2", "0.3"], "orientations": ["5"],
             "convention": ["paper"]}[name]
    for kind in kinds():
        if name in kind.inputs:
            continue
        out = tmp_path / "x.npz"
        assert cli.main(["map", "--kind", kind.name, f"--{name}", *value, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"wsmap: error: --kind {kind.name} does not read --{name} (it is read by --kind ")
        assert len(err.strip().splitlines()) == 1 and not out.exists()


@pytest.mark.parametrize("argv, message", [
    (["--out", "m.txt"], "--out 'm.txt': a map file is .npz"),
    (["--png", "m.jpg"], "--png 'm.jpg': the file name must end in .png"),
    (["--h5", "m.hdf5"], "the file name must end in .h5"),
    ([], "nothing to write: give --out FILE.npz and/or --png, --html, --ply, --glb, --h5"),
])
def test_outputs_are_checked_before_any_work(argv, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["map", "--robot", "puma560", *argv]) == 2
    assert message in capsys.readouterr().err and not list(tmp_path.iterdir())


def test_a_picture_alone_needs_no_out(tmp_path, capsys):
    png = tmp_path / "m.png"
    assert cli.main(["map", "--robot", "puma560", "--step", "0.5", "--png", str(png), "-q"]) == 0
    assert png.read_bytes()[:4] == b"\x89PNG" and sorted(p.name for p in tmp_path.iterdir()) == ["m.png"]


def test_a_missing_optional_module_names_its_extra(monkeypatch, tmp_path, capsys):
    with pytest.raises(MissingDependency, match=r"^--html needs plotly_not_here, which is not installed: "
                                                r"pip install 'wsmap\[views\]'$"):
        require("plotly_not_here", extra="views", why="--html")
    assert issubclass(MissingDependency, ValueError) and issubclass(MissingDependency, ImportError)
    assert EXTRAS["yourdfpy"] == "urdf" and EXTRAS["h5py"] == "h5" and EXTRAS["torch"] == "learn"
    # the command line: one line, exit 2, before any work (plotly made unimportable: None in sys.modules)
    monkeypatch.setitem(sys.modules, "plotly", None)
    out = tmp_path / "m.npz"
    assert cli.main(["map", "--robot", "puma560", "--out", str(out), "--html", str(tmp_path / "v.html")]) == 2
    assert capsys.readouterr().err == ("wsmap: error: --html needs plotly, which is not installed: "
                                       "pip install 'wsmap[views]'\n")
    assert not out.exists()
    monkeypatch.setitem(sys.modules, "yourdfpy", None)
    urdf = tmp_path / "a.urdf"
    urdf.write_text("<robot name='a'><link name='b'/><link name='c'/><joint name='j' type='revolute'>"
                    "<parent link='b'/><child link='c'/><axis xyz='0 0 1'/>"
                    "<limit lower='-1' upper='1' effort='1' velocity='1'/></joint></robot>")
    assert cli.main(["map", "--urdf", str(urdf), "--out", str(out)]) == 2
    assert "a URDF arm needs yourdfpy, which is not installed: pip install 'wsmap[urdf]'" in capsys.readouterr().err


def test_paper_commands_need_a_checkout(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(paths, "ROOT", tmp_path)
    monkeypatch.setattr(paths, "NOTEBOOKS", tmp_path / "notebooks")
    for argv in (["paper", "list"], ["paper", "run", "classical_workspace"], ["paper", "full", "--list"]):
        assert cli.main(argv) == 2
        err = capsys.readouterr().err
        assert "needs a checkout of the wsmap repository (dvc.yaml, params.yaml and notebooks/" in err, argv


def test_dask_missing_is_named_before_any_work(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)
    out = tmp_path / "d.npz"
    assert cli.main(["data", "build", "sec61", "--samples", "10", "--workers", "2", "--out", str(out), "-q"]) == 2
    assert capsys.readouterr().err == ("wsmap: error: building on Dask (workers or a scheduler) needs "
                                       "dask[distributed], which is not installed: pip install 'wsmap[cluster]'\n")
    assert not list(tmp_path.iterdir())
