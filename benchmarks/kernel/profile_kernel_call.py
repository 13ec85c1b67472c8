"""Where one ikine_search call on the 2648 reachable PUMA560 poses (R = I) spends its time: the
compiled kernel (``run_compiled``) against the Python around it, best of 15 calls on 2 threads, and
a cProfile of 20 calls.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/profile_kernel_call.py
"""
import cProfile, pstats, time, numpy as np
from wsmap import robots, workspace as ws
from wsmap.kinematics import ikine_search, lm_compiled
from wsmap.kinematics.ik import search
lm_compiled.set_threads(2)
puma = robots.puma560()
nodes = ws.cartesian_grid(-1, 1, 0.1)
reach = ws.constant_orientation_map(puma, nodes, (0, 0, 0), method="exact")
T = ws.target_poses(nodes[reach], (0, 0, 0), "paper")
for _ in range(3): ikine_search(puma, T)
ts = []
for _ in range(15):
    t0 = time.perf_counter(); ikine_search(puma, T); ts.append(time.perf_counter() - t0)
print("best ms", min(ts) * 1e3)
orig = search.run_compiled
kt = []
def timed(*a, **k):
    t0 = time.perf_counter(); r = orig(*a, **k); kt.append(time.perf_counter() - t0); return r
search.run_compiled = timed
ts = []
for _ in range(15):
    kt.clear(); t0 = time.perf_counter(); ikine_search(puma, T); ts.append((time.perf_counter() - t0, sum(kt)))
b = min(ts)
print("total %.2f ms, kernel %.2f ms, python %.2f ms" % (b[0] * 1e3, b[1] * 1e3, (b[0] - b[1]) * 1e3))
search.run_compiled = orig
pr = cProfile.Profile(); pr.enable()
for _ in range(20): ikine_search(puma, T)
pr.disable(); pstats.Stats(pr).sort_stats("tottime").print_stats(12)
