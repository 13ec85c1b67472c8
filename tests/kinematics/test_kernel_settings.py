"""The LM settings at the kernel boundary: `lm_compiled.lm_settings` builds `LMSettings` by field
name, casting each value to the exact Python type both kernels read, and `kernel.run_compiled`
passes any field by name, so that a new LM setting is a field of `LMSettings` (with its default)
and a line of the lane table (`_lanes/lanes.hpp`), with no edit of `run_compiled`."""

import inspect
import re

import numpy as np
import pytest

from wsmap import robots
from wsmap.kinematics import as_chain, lm_compiled, lm_lanes
from wsmap.kinematics.ik import kernel
from wsmap.kinematics.lm_compiled import LMSettings, lm_settings

FIELDS = dict(mode=0, k_first=1, k_last=4, ilimit=60, rlimit=10, tol=1e-10, lam0=0.1, gtol=1e-4, confirm_tol=1e-6,
              free_pass=False)


def test_lm_settings_casts_each_field_to_its_type():
    given = dict(mode=np.int8(2), k_first=np.int64(1), k_last=4.0, ilimit=np.uint16(60), rlimit=10, tol=np.float32(0.5),
                 lam0=1, gtol=np.float64(0.0), confirm_tol=1, free_pass=np.bool_(False))
    s = lm_settings(**given)
    assert s == LMSettings(mode=2, k_first=1, k_last=4, ilimit=60, rlimit=10, tol=0.5, lam0=1.0, gtol=0.0,
                           confirm_tol=1.0, free_pass=False)
    # exact Python types: the lane extension refuses a numpy scalar or an int where it reads a float
    assert {f: type(getattr(s, f)).__name__ for f in LMSettings._fields} == {
        "mode": "int", "k_first": "int", "k_last": "int", "ilimit": "int", "rlimit": "int", "tol": "float",
        "lam0": "float", "gtol": "float", "confirm_tol": "float", "free_pass": "bool"}
    assert lm_compiled.SETTING_TYPES == {f: type(v) for f, v in FIELDS.items()}


def test_lm_settings_refuses_unknown_and_missing_fields():
    with pytest.raises(TypeError, match=re.escape("unknown LM setting(s) lam, tolerance; LMSettings has mode, "
                                                  "k_first, k_last, ilimit, rlimit, tol, lam0, gtol, confirm_tol, "
                                                  "free_pass")):
        lm_settings(**FIELDS, lam=0.1, tolerance=1e-9)
    partial = {k: v for k, v in FIELDS.items() if k not in ("tol", "gtol")}
    with pytest.raises(TypeError, match=re.escape("LM setting(s) tol, gtol not given (they have no default)")):
        lm_settings(**partial)


def test_every_field_reaches_run_compiled_by_name():
    """A field of `LMSettings` is a parameter of `run_compiled` (`lam` is `lam0`) or, from now on,
    has a default and passes through its `**more`: a new field needs no edit of `run_compiled`,
    and no caller that does not name it changes."""
    params = inspect.signature(kernel.run_compiled).parameters
    assert any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())
    named = {"lam0" if name == "lam" else name for name in params}
    loose = [f for f in LMSettings._fields if f not in named and f not in LMSettings._field_defaults]
    assert not loose, f"LMSettings fields {loose} need a default (or a parameter of run_compiled)"


def _puma_call(**settings):
    chain = as_chain(robots.load("puma560"))
    rng = np.random.default_rng(5)
    T = chain.fkine(rng.uniform(-2.0, 2.0, (40, 6)))
    aa = kernel.arm_arrays(chain)
    M = len(T)
    return kernel.run_compiled(lm_compiled.MODE_SEARCH, aa, np.zeros(M, dtype=np.int64), T,
                               kernel.pose_keys(0, T), np.zeros((M, 1, 6)), np.ones(M, dtype=np.int64), **settings)


@pytest.mark.parametrize("name", lm_lanes.KERNELS)
def test_run_compiled_takes_the_settings_by_name(name):
    if name == "lanes" and not lm_lanes.available():
        pytest.skip("the lane kernel is not built")
    with lm_lanes.use_kernel(name):
        named = _puma_call(k_first=1, k_last=6, ilimit=60, rlimit=10, tol=1e-10, lam=0.1, confirm_tol=1e-6, gtol=1e-4,
                           free_pass=False)
        chain = as_chain(robots.load("puma560"))
        T = chain.fkine(np.random.default_rng(5).uniform(-2.0, 2.0, (40, 6)))
        positional = kernel.run_compiled(lm_compiled.MODE_SEARCH, kernel.arm_arrays(chain), np.zeros(40, dtype=np.int64),
                                         T, kernel.pose_keys(0, T), np.zeros((40, 1, 6)), np.ones(40, dtype=np.int64),
                                         1, 6, 60, 10, 1e-10, 0.1, 1e-6, 1e-4, False)
    for a, b in zip(named, positional):
        np.testing.assert_array_equal(a, b)
    q, ok, iterations, residual, start = named
    assert ok.sum() >= 35 and np.all(residual[ok] <= 1e-10) and np.all(start[ok] >= 0)
    # every success is a solution: forward kinematics within the confirmation tolerance
    err = np.abs(chain.fkine(q[ok]) - T[ok]).max()
    assert err <= 1e-6


def test_run_compiled_refuses_an_unknown_setting_before_the_kernel_runs():
    with pytest.raises(TypeError, match=r"^unknown LM setting\(s\) seed_count; LMSettings has mode, "):
        _puma_call(k_first=1, k_last=6, ilimit=60, rlimit=10, tol=1e-10, lam=0.1, confirm_tol=1e-6, seed_count=3)
