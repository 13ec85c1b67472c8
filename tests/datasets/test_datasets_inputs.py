"""Bad inputs of the datasets API: each a ValueError (or TypeError for a wrong object) naming the field,
raised before any work; and the package's layout (names, import hygiene)."""

import math
import re
import subprocess
import sys

import numpy as np
import pytest

from wsmap import datasets
from wsmap.paper.specs import PAPER_SPECS as P

BASE = datasets.scaled(P["table1_r3_step1"], 5)


# --------------------------------------------------------------------------- spec fields
@pytest.mark.parametrize(
    "changes, message",
    [
        # integers: NaN, inf, huge, wrong types -- each names the field (before: raw numpy/Python errors or accepted)
        (dict(samples=math.nan), "samples must be an integer, got nan"),
        (dict(samples=math.inf), "samples must be an integer, got inf"),
        (dict(samples=1e30), "samples must be at most 1000000000"),
        (dict(samples=2**40), "samples must be at most 1000000000"),
        (dict(samples=np.bool_(True)), "samples must be an integer"),
        (dict(seed=math.nan), "seed must be an integer, got nan"),
        (dict(seed=math.inf), "seed must be an integer, got inf"),
        (dict(seed=-1), "seed must be at least 0, got -1"),
        (dict(seed="0"), "seed must be an integer, got '0'"),
        (dict(seed=[0]), "seed must be an integer, got [0]"),
        (dict(seed=None), "seed must be an integer, got None"),
        (dict(ilimit=math.inf), "ilimit must be an integer, got inf"),
        (dict(ilimit=10**9), "ilimit must be at most 1000000"),
        (dict(rlimit=1.5), "rlimit must be an integer, got 1.5"),
        (dict(starts=200_000), "starts must be at most 1000"),
        (dict(select=(0, math.nan)), "select stop must be an integer, got nan"),
        (dict(select=(0, 5, 9)), "select must be 'all' or [start, stop]"),
        (dict(select=slice(0, 10, 2)), "select must be a contiguous range"),
        # reals: None, bool, strings that are not numerals, NaN
        (dict(beta=None), "beta must be a number, got None"),
        (dict(beta=True), "beta must be a number, got True"),
        (dict(beta="pi"), "beta must be a number, got the string 'pi'"),
        (dict(beta=math.inf), "beta must be finite, got inf"),
        (dict(tol=None), "tol must be a number, got None"),
        (dict(tol=math.nan), "tol must be finite, got nan"),
        (dict(tol=1e-3), "tol must be positive and at most 1e-06"),
        (dict(step="pi/10"), "step must be a number, got the string 'pi/10'"),
        (dict(step="__import__('os')"), "step must be a number, got the string"),
        (dict(lo={"a": 1}), "lo must be a number, got {'a': 1} (dict)"),
        (dict(lo=[0.0, 0.0]), "lo must be a number or 3 numbers, got [0.0, 0.0]"),
        (dict(hi=[1.0, "x", 1.0]), "hi[1] must be a number, got the string 'x'"),
        (dict(hi=np.ones((3, 1))), "hi must be a number or 3 numbers"),
        (dict(fixed=(math.nan, 0.0, 0.0)), "fixed[0] must be finite, got nan"),
        (dict(fixed=(0.0, None, 0.0)), "fixed[1] must be a number, got None"),
        (dict(fixed=np.zeros((1, 3))), "fixed must be 3 finite numbers or 'random'"),
        # grids: empty, huge, overflowing
        (dict(lo=1.0, hi=-1.0), "empty or invalid grid (lo=1.0, hi=-1.0, step=1.0): lo must not exceed hi"),
        (dict(lo=(0.0, 0.0, 1.0), hi=(1.0, 1.0, 0.0)), "lo must not exceed hi on any axis"),
        (dict(step=(0.1, 0.0, 0.1)), "step must be positive"),
        (dict(step=1e-4), "has about 8e+12 nodes, more than the 1.68e+07 a dataset may have"),
        (dict(step=1e-300), "has about inf nodes"),
        (dict(lo=-1e300, hi=1e300, step=1e-10), "has about inf nodes"),
        # choices of the wrong type
        (dict(family=["spherical_wrist"]), "unknown family ['spherical_wrist']"),
        (dict(scope="r3"), "unknown scope 'r3'; choose one of R3, SO3"),
        (dict(method=None), "unknown method None"),
        (dict(convention=1), "unknown convention 1"),
        (dict(stream="TRAIN"), "unknown stream 'TRAIN'"),
        (dict(name="   "), "name must be a non-empty string"),
        (dict(name=None), "name must be a non-empty string"),
    ],
)
def test_bad_spec_fields(changes, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        BASE.replace(**changes)


def test_replace_and_from_dict_refuse_unknown_fields():
    with pytest.raises(ValueError, match=re.escape("unknown dataset spec field(s) bogus; known: beta")):
        BASE.replace(bogus=1)
    with pytest.raises(ValueError, match=re.escape("unknown dataset spec field(s) 3")):
        datasets.DatasetSpec.from_dict({"name": "x", 3: 4})
    with pytest.raises(ValueError, match="must be a mapping, got NoneType"):
        datasets.DatasetSpec.from_dict(None)


def test_good_edge_values_still_work():
    assert BASE.replace(samples=1e3).samples == 1000 and isinstance(BASE.replace(samples=1e3).samples, int)
    assert BASE.replace(samples=np.int64(7)).samples == 7
    assert BASE.replace(tol="1e-10").tol == 1e-10  # YAML reads 1e-10 as a string
    assert BASE.replace(seed=2**70).seed == 2**70  # SeedSequence takes big seeds
    assert BASE.replace(lo=np.array([-1.0, -1.0, -1.0])).lo == (-1.0, -1.0, -1.0)
    assert BASE.replace(lo=np.float64(-1.0)).lo == -1.0
    one = BASE.replace(lo=0.0, hi=0.0)
    assert one.grid_shape == (1, 1, 1) and one.n_features == 18 + 3 + 3
    assert datasets.DatasetSpec("x", step=0.5).replace(fixed=np.array([0.1, 0.2, 0.3])).fixed == (0.1, 0.2, 0.3)


# --------------------------------------------------------------------------- functions
ARMS, FIXED = datasets.draw_samples(BASE)


@pytest.mark.parametrize(
    "call, error, message",
    [
        (lambda: datasets.test_spec(BASE, 0), ValueError, "samples must be at least 1, got 0"),
        (lambda: datasets.test_spec("sec61"), TypeError, "spec must be a DatasetSpec, got str"),
        (lambda: datasets.scaled(BASE, None), ValueError, "samples must be an integer, got None"),
        (lambda: datasets.draw_samples(BASE, 0), ValueError, "count must be at least 1, got 0"),
        (lambda: datasets.start_configurations(BASE, count=-1), ValueError, "count must be at least 0, got -1"),
        (lambda: datasets.start_configurations(BASE, count=2.5), ValueError, "count must be an integer, got 2.5"),
        (lambda: datasets.start_configurations(BASE, starts=5000), ValueError, "starts must be at most 1000"),
        (lambda: datasets.uniform_rotations(-1, 0), ValueError, "count must be at least 0, got -1"),
        (lambda: datasets.rotation_to_rpy(np.eye(4)), ValueError, "R must have shape (..., 3, 3), got (4, 4)"),
        (lambda: datasets.rotation_to_rpy(np.full((3, 3), np.nan)), ValueError, "R contains NaN"),
        (lambda: datasets.possibly_reachable(ARMS, np.zeros((3, 3))), ValueError, "T must have shape (..., 4, 4), got (3, 3)"),
        (lambda: datasets.possibly_reachable(ARMS, np.eye(4), margin=-1.0), ValueError, "margin must be a non-negative number"),
        (lambda: datasets.possibly_reachable("puma", np.eye(4)), TypeError, "arms must be a DHRobot"),
        (lambda: datasets.labels_for(ARMS, BASE, nodes=np.zeros((3, 2))), ValueError, "nodes must have shape (N, 3), got (3, 2)"),
        (lambda: datasets.labels_for(ARMS, BASE, nodes=[[math.nan, 0, 0]]), ValueError, "nodes contain NaN"),
        (lambda: datasets.labels_for(ARMS, BASE, method="lm"), ValueError, "unknown method 'lm'"),
        (lambda: datasets.labels_for(ARMS, BASE, method="numerical", q0=np.full((1, 6), np.nan)), ValueError,
         "q0 contains NaN or infinite values"),
        (lambda: datasets.labels_for(ARMS, BASE, method="numerical", q0=np.zeros((5, 0, 6))), ValueError, "with S >= 1"),
        (lambda: datasets.labels_for(ARMS, BASE, fixed=(0.0, 0.0)), ValueError, "fixed must have shape (3,) or (5, 3)"),
        (lambda: datasets.features_for(ARMS, BASE, fixed="up"), ValueError, "fixed must be numbers of shape (3,) or (5, 3)"),
        (lambda: datasets.arms_from_features(np.zeros((2, 5))), ValueError, "features must have shape (count, >= 18)"),
        (lambda: datasets.arms_from_features(np.full((2, 30), np.nan)), ValueError, "features contain NaN"),
        (lambda: datasets.fixed_from_features(np.zeros((2, 3)), BASE), ValueError, "must have shape (count, 30), got (2, 3)"),
        (lambda: datasets.feature_names("sec61"), TypeError, "spec must be a DatasetSpec"),
        (lambda: datasets.starts_recall(BASE, n_poses=0), ValueError, "n_poses must be at least 1, got 0"),
        (lambda: datasets.starts_recall(BASE, counts=()), ValueError, "counts must name at least one number of starts"),
        (lambda: datasets.starts_recall(BASE, counts=5), ValueError, "counts must be a list of start counts, got 5"),
        (lambda: datasets.starts_study(BASE, n_arms=0), ValueError, "n_arms must be at least 1, got 0"),
        (lambda: datasets.starts_study(BASE, counts=(1, 0)), ValueError, "counts entry must be at least 1, got 0"),
        (lambda: datasets.audit_labels(BASE, n_arms=0), ValueError, "n_arms must be at least 1, got 0"),
        (lambda: datasets.audit_labels(BASE, n_arms=1, ik=dict(stars=3)), ValueError, "ik must be a dict with keys among"),
        (lambda: datasets.audit_table(["sec61"]), TypeError, "audit_table takes DatasetSpecs, got 'sec61'"),
        (lambda: datasets.audit_table(BASE), ValueError, "specs must be a list of DatasetSpecs"),
    ],
)
def test_bad_function_arguments(call, error, message):
    with pytest.raises(error, match=re.escape(message)):
        call()


def test_dataset_head_checks_n(tmp_path):
    ds = datasets.load_dataset(datasets.build_dataset(BASE, tmp_path / "b.npz", progress=False))
    with pytest.raises(ValueError, match=re.escape("n must be an integer, got '3'")):  # was TypeError from '>='
        ds.head("3")
    with pytest.raises(ValueError, match="n must be at least 1, got 0"):
        ds.head(0)
    assert len(ds.head(3)) == 3 and ds.head(None) is ds and ds.head(99) is ds


def test_more_than_127_starts_label_correctly():
    # the first solving start was kept as int8: start 128 and later overflowed (numpy 2: OverflowError)
    spec = datasets.scaled(P["table3_nosubspace"], 1).replace(starts=200, ilimit=1)
    arms, _ = datasets.draw_samples(spec)
    q = np.array([[0.3, -0.5, 0.7, 0.2, -0.4, 0.6]])
    T = arms.fkine(q)
    rpy = datasets.rotation_to_rpy(T[:, :3, :3])
    p = np.einsum("bji,bj->bi", T[:, :3, :3], T[:, :3, 3])  # paper convention: the tested position is R·p
    q0 = np.tile(q + 1.0, (1, 200, 1))  # one LM iteration from 1 rad away does not converge ...
    q0[0, 150] = q[0]  # ... start 150 is the solution itself
    labels = datasets.labels_for(arms, spec, fixed=rpy[0], nodes=p, q0=q0)
    assert labels.tolist() == [[True]]
    q0[0, 150] = q[0] + 1.0  # without it, no start solves the node
    assert datasets.labels_for(arms, spec, fixed=rpy[0], nodes=p, q0=q0).tolist() == [[False]]


# --------------------------------------------------------------------------- layout
def test_datasets_imports_no_higher_layer():
    code = "import sys, wsmap.datasets; print(' '.join(sorted(m for m in sys.modules if m.startswith('wsmap'))))"
    mods = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert "wsmap.datasets.store" in mods
    for banned in ("wsmap.cli", "wsmap.paper", "wsmap.learn"):
        assert banned not in mods


def test_public_names():
    for name in datasets.__all__:
        assert hasattr(datasets, name), name
    assert len(set(datasets.__all__)) == len(datasets.__all__)


def test_paper_catalogue():
    from wsmap.paper import specs

    assert specs.paper_spec("sec61") is P["sec61"]
    with pytest.raises(ValueError, match="unknown dataset 'sec99'"):
        specs.paper_spec("sec99")
    names = [s.name for s in specs.audit_specs()]
    assert names[0] == "sec61" and "table3_nosubspace" not in names and "table2" not in names
    assert specs.STARTS_STUDY_SPEC.family == "arbitrary_6dof"


def test_build_pair_refuses_before_writing(tmp_path):
    from wsmap.paper import specs

    for kwargs, message in [(dict(samples=0), "samples must be at least 1"),
                            (dict(samples=3, test_samples=0), "test_samples must be at least 1"),
                            (dict(samples=3, test_samples=None), "test_samples must be a positive integer")]:
        with pytest.raises(ValueError, match=message):
            specs.build_pair("table1_r3_step1", tmp_path / "d", progress=False, **kwargs)
    assert list(tmp_path.iterdir()) == []  # before: the training file stayed behind after test_samples=0
    with pytest.raises(ValueError, match="unknown dataset"):
        specs.dataset_paths("nope", tmp_path)
    train, test = specs.build_pair("table1_r3_step1", tmp_path / "d", samples=3, test_samples=2, progress=False)
    a, b = specs.load_pair("table1_r3_step1", tmp_path / "d")
    assert (len(a), len(b)) == (3, 2)
