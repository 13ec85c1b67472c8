"""The numerical reachability index on two threads (two orientations solved at once, the kernel's
threads shared between them) gives the one-thread answers bit for bit."""

import numpy as np
import pytest

from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import lm_compiled, lm_lanes
from wsmap.kinematics.ik.memo import Memo


@pytest.fixture(autouse=True)
def _restore():
    threads = lm_compiled.threads()
    yield
    lm_compiled.set_threads(threads)


@pytest.mark.skipif(not lm_lanes.available(), reason="the lane kernel is not built")
@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_two_orientations_at_once_give_the_same_index(name):
    if lm_compiled.set_threads(2) < 2:
        pytest.skip("one thread only (NUMBA_NUM_THREADS)")
    arm = robots.load(name)
    nodes, R = ws.cartesian_grid(-0.9, 0.9, 0.15), ws.orientation_samples(12)
    two = ws.reachability_index(arm, nodes, R, return_bits=True, return_q=True, method="numerical")
    lm_compiled.set_threads(1)
    one = ws.reachability_index(arm, nodes, R, return_bits=True, return_q=True, method="numerical")
    assert one[1].sum() > 1000
    for a, b in zip(one, two):
        np.testing.assert_array_equal(a, b)
    assert lm_lanes._busy == 0  # every call gave its threads back


def test_a_memo_shared_by_threads_keeps_one_value_per_key():
    from concurrent.futures import ThreadPoolExecutor

    memo, made = Memo(4), []

    def make(k):
        made.append(k)
        return k * 10

    with ThreadPoolExecutor(4) as pool:
        got = list(pool.map(lambda i: memo.get(i % 6, lambda: make(i % 6)), range(600)))  # noqa: B023
    assert got == [10 * (i % 6) for i in range(600)]
    assert len(memo.items) == 4 and all(memo.items[k] == 10 * k for k in memo.items)
