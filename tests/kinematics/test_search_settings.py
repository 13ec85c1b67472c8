"""`SearchSettings`, the numerical map search's settings as one record, and the `Solver` interface
that the maps, the orientation maps and base placement call (wsmap.kinematics.ik.settings,
wsmap.kinematics.ik.solver, wsmap.kinematics.ik.solvers)."""

import dataclasses

import numpy as np
import pytest

import wsmap.workspace as ws
from wsmap import robots
from wsmap.kinematics.ik import solvers
from wsmap.kinematics.ik.search import map_search
from wsmap.kinematics.ik.settings import DEFAULT_ILIMIT, DEFAULT_STARTS, MAP_SETTINGS, SearchSettings
from wsmap.kinematics.ik.solver import SOLVERS, Solver, get_solver, numerical_solvers, solver_for
from wsmap.workspace.kinds import MapRequest


def test_the_defaults_are_each_solvers_own():
    s = SearchSettings()
    assert s.solver == "search" and {k: getattr(s, k) for k in MAP_SETTINGS} == MAP_SETTINGS
    assert (s.seed, s.tol, s.lam, s.confirm_tol, s.limit_bound, s.accept_retry) == (0, 1e-10, 0.1, 1e-6, True, 16)
    ind = SearchSettings(solver="independent")
    assert (ind.starts, ind.ilimit, ind.seeds) == (DEFAULT_STARTS, DEFAULT_ILIMIT, None)
    paper = SearchSettings(solver="paper")
    assert (paper.ilimit, paper.rlimit, paper.starts, paper.seed) == (500, 100, None, None)
    # a field left None is its solver's default: the same search, equal and hashed alike
    assert SearchSettings(ilimit=60) == s and SearchSettings(ilimit=60).digest() == s.digest()
    assert SearchSettings(retry=5).digest() != s.digest()
    assert SearchSettings.from_dict({"retry": 2}, MAP_SETTINGS) == s.replace(retry=2)
    assert dataclasses.is_dataclass(s) and hash(s) == hash(SearchSettings())
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.retry = 3


def test_the_maps_dicts_convert_as_the_maps_read_them():
    # the paper's solver accepts and drops a seed and starts=1, the search a chunk
    assert SearchSettings.from_dict({"solver": "paper", "seed": 3, "starts": 1}) == SearchSettings(solver="paper")
    assert SearchSettings.from_dict({"chunk": 99}) == SearchSettings()
    assert SearchSettings(q0=[0, 0.5, 0, 0, 0, 0]).q0 == (0.0, 0.5, 0.0, 0.0, 0.0, 0.0)
    assert SearchSettings(solver="independent").replace(solver="search") == SearchSettings()
    assert SearchSettings(q0=[0.1] * 6).to_dict()["q0"] == [0.1] * 6


@pytest.mark.parametrize("fields, message", [
    (dict(solver="fast"), "unknown solver 'fast'; choose one of search, independent, paper"),
    (dict(retry=-1), "retry must be an integer >= 0"),
    (dict(border_starts=2.5), "border_starts must be an integer >= 0"),
    (dict(tol=0.0), "tol must be positive and finite"),
    (dict(tol=1e-16), "tol must be at least 1e-14"),
    (dict(confirm_tol=1e-12), r"confirm_tol \(1e-12\) must be at least tol"),
    (dict(gtol=-1.0), "gtol must be non-negative and finite"),
    (dict(seed=-1), "seed must be a non-negative integer"),
    (dict(joint_limits="yes"), "joint_limits must be True or False"),
    (dict(q0=[0.0, np.nan]), "q0 must be a finite joint vector"),
    (dict(solver="paper", starts=4), "the paper's solver has one start"),
    (dict(solver="paper", seeds=2), "solver 'paper' takes no seeds"),
    (dict(solver="independent", border_starts=2), "solver 'independent' takes no border_starts"),
])
def test_bad_settings_are_one_line_errors(fields, message):
    with pytest.raises(ValueError, match=message):
        SearchSettings(**fields)


def test_an_unknown_key_of_a_dict_names_the_fields():
    with pytest.raises(ValueError, match="unknown IK setting\\(s\\) 'retries'; settings: "):
        SearchSettings.from_dict({"retries": 3})


def test_the_solvers_are_one_registry():
    assert SOLVERS.names() == ["closed_form", "search", "independent", "paper"]
    assert numerical_solvers() == ("search", "independent", "paper") == ws.SOLVERS
    assert all(isinstance(s, Solver) for s in SOLVERS)
    assert solver_for("exact").name == "closed_form" and solver_for("numerical").name == "search"
    assert solver_for("numerical", SearchSettings(solver="paper")).name == "paper"
    assert solvers.get_solver is get_solver
    with pytest.raises(ValueError, match="unknown IK solver 'x'"):
        get_solver("x")


def test_map_search_takes_settings_and_overrides():
    arm = robots.load("panda")
    nodes = ws.cartesian_grid(-0.6, 0.6, 0.3)
    T = ws.target_poses(nodes, (np.pi, 0, 0))
    nb = ws.node_neighbours(nodes)
    a = map_search(arm, T, nb, SearchSettings(retry=2, border_starts=0))
    b = map_search(arm, T, nb, retry=2, border_starts=0)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.success, b.success)
    with pytest.raises(ValueError, match="map_search runs the solver 'search'"):
        map_search(arm, T, nb, SearchSettings(solver="paper"))


def test_every_solver_answers_what_the_maps_answer():
    """Each solver called through the interface gives the map the map functions give with it."""
    puma = robots.puma560()
    nodes = ws.cartesian_grid(-0.8, 0.8, 0.4)
    T = ws.target_poses(nodes, (0, 0, 0))
    nb = ws.node_neighbours(nodes)
    exact = get_solver("closed_form").solve(puma, T)
    np.testing.assert_array_equal(exact.success, ws.constant_orientation_map(puma, nodes, (0, 0, 0)))
    np.testing.assert_array_equal(get_solver("closed_form").reachable(puma, T), exact.success)
    assert np.all(np.isfinite(exact.q[exact.success])) and np.all(np.isnan(exact.q[~exact.success]))
    for settings in (SearchSettings(), SearchSettings(solver="independent", starts=4), SearchSettings(solver="paper")):
        solver = solver_for("numerical", settings)
        sol = solver.solve(puma, T, settings, neighbours=nb)
        expected = ws.constant_orientation_map(puma, nodes, (0, 0, 0), method="numerical", ik=settings)
        np.testing.assert_array_equal(sol.success, expected)
        np.testing.assert_array_equal(solver.reachable(puma, T, settings, neighbours=nb), expected)
        assert not (sol.success & ~exact.success).any()  # True is never wrong
        assert sol.success.sum() > exact.success.sum() // 2


def test_a_kind_s_defaults_are_settings():
    from wsmap.workspace.kinds import get_kind

    assert get_kind("constant").settings == SearchSettings()
    assert get_kind("index").settings == SearchSettings(retry=2, border_starts=0, fk_seeds=0)


def test_a_map_request_carries_settings():
    assert MapRequest().settings is None and MapRequest(ik={}).settings is None
    r = MapRequest(ik={"solver": "paper", "tol": 1e-9})
    assert r.settings == SearchSettings(solver="paper", tol=1e-9) and r.ik == {"solver": "paper", "tol": 1e-9}
    s = SearchSettings(retry=1)
    assert MapRequest(ik=s).settings is s and MapRequest(ik=s).search is s
    with pytest.raises(ValueError, match="retry must be an integer >= 0"):
        MapRequest(ik={"retry": -2})


# --- the kernels' own settings, by name (`SearchSettings.kernel`) ---------------------------------------------------

#: `SearchSettings().digest()` and the independent solver's as the record hashed them before `kernel` existed
#: (commit f7ae773): an empty `kernel` leaves them as they were.
DIGESTS = {"search": "e75943f5b6441b97773fd1edd449b702cc8431061a192bf00a167d89bcf5d410",
           "independent": "b589c05bab5c3553b8f802f5ac33eb6775ae2fa83e4fb6d3f50c5d85f4b6174b",
           "paper": "09dae3c6188d92f19210f69b8966adf97dd8f21445ba3c106dfa8c5f72da55b7"}


@pytest.mark.parametrize("solver", sorted(DIGESTS))
def test_an_empty_kernel_keeps_every_digest(solver):
    s = SearchSettings(solver=solver)
    assert s.digest() == DIGESTS[solver] and "kernel" not in s.to_dict()
    assert SearchSettings(solver=solver, kernel={}) == s and SearchSettings(solver=solver, kernel=()) == s


def test_kernel_names_only_the_kernels_own_settings():
    from wsmap.kinematics.ik import settings
    from wsmap.kinematics.lm_compiled import LMSettings

    # every LMSettings field is driven by a field of the record or by the call, or settable by name
    assert set(settings.KERNEL_FIELDS) | settings._DRIVEN == set(LMSettings._fields)
    with pytest.raises(ValueError, match=r"^unknown kernel setting\(s\) lam0, tol; the kernels' own settings: "):
        SearchSettings(kernel={"tol": 1e-9, "lam0": 0.2})
    with pytest.raises(ValueError, match=r"^solver 'paper' takes no kernel \(it reads "):
        SearchSettings(solver="paper", kernel={"tol": 1e-9})
    with pytest.raises(ValueError, match=r"^kernel must map LM setting names to values, got 3"):
        SearchSettings(kernel=3)


@pytest.fixture
def probe_setting(monkeypatch):
    """A kernel setting `probe` (float, default 0) as a new `LMSettings` field would be: allowed by
    `SearchSettings.kernel` and taken out again before the real kernel runs, where each call records it."""
    from wsmap.kinematics.ik import kernel as kernel_module
    from wsmap.kinematics.ik import search, settings

    monkeypatch.setattr(settings, "KERNEL_FIELDS", settings.KERNEL_FIELDS + ("probe",))
    monkeypatch.setitem(settings.SETTING_TYPES, "probe", float)
    seen = []

    def run_compiled(*args, probe=0.0, **kwargs):
        seen.append(probe)
        return kernel_module.run_compiled(*args, **kwargs)

    monkeypatch.setattr(search, "run_compiled", run_compiled)
    return seen


def test_a_kernel_setting_reaches_every_kernel_call(probe_setting):
    s = SearchSettings(kernel={"probe": 3})
    assert s.kernel == (("probe", 3.0),) and s.to_dict()["kernel"] == {"probe": 3.0}
    assert s.digest() != SearchSettings().digest() and SearchSettings.from_dict(s.to_dict()) == s
    with pytest.raises(ValueError, match=r"^kernel setting probe must be a finite float, got nan"):
        SearchSettings(kernel={"probe": float("nan")})
    puma = robots.puma560()
    nodes = ws.cartesian_grid(-0.8, 0.8, 0.4)
    T = ws.target_poses(nodes, (0, 0, 0))
    map_search(puma, T, ws.node_neighbours(nodes), s)
    assert probe_setting and set(probe_setting) == {3.0}
    probe_setting.clear()
    get_solver("independent").solve(puma, T[:8], SearchSettings(solver="independent", starts=2, kernel={"probe": 2}))
    assert probe_setting and set(probe_setting) == {2.0}
