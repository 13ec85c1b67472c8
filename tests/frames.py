"""Homogeneous-transform helpers shared by the tests that compare arms with other implementations."""

import numpy as np


def inv(T):
    """Inverse of a rigid transform (4, 4)."""
    out = np.eye(4)
    out[:3, :3] = T[:3, :3].T
    out[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return out


def hom(R=np.eye(3), p=(0, 0, 0)):
    """The rigid transform with rotation ``R`` and translation ``p``."""
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


def max_err_up_to_tool(ours, theirs, qs, B=np.eye(4)):
    """Largest entry of ``ours(q) - B · theirs(q) · C`` over ``qs``, and ``C``.

    ``B`` (the relation of the two base frames) is given; ``C`` (tool) is estimated from q = 0, so
    every other configuration is a check of joint zeros, signs, axes and lengths.
    """
    z = np.zeros(qs.shape[-1])
    C = inv(B @ theirs(z)) @ ours(z)
    return max(np.abs(ours(q) - B @ theirs(q) @ C).max() for q in qs), C


def random_rotations(rng, count=None):
    """Random rotations ``(count, 3, 3)`` (one ``(3, 3)`` when ``count`` is None) from normalised
    quaternions drawn from ``rng``."""
    qt = rng.normal(size=(count or 1, 4))
    qt /= np.linalg.norm(qt, axis=-1, keepdims=True)
    w, x, y, z = qt.T
    R = np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
                  2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                  2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1).reshape(-1, 3, 3)
    return R if count else R[0]


def random_rigid(rng, count, scale):
    """``count`` random rigid transforms ``(count, 4, 4)``, translations normal with ``scale`` (m)."""
    T = np.zeros((count, 4, 4))
    T[:, :3, :3] = random_rotations(rng, count)
    T[:, :3, 3] = rng.normal(scale=scale, size=(count, 3))
    T[:, 3, 3] = 1.0
    return T


def random_chain(rng, n, unlimited=None):
    """A :class:`wsmap.kinematics.SerialChain` of ``n`` revolute joints about random axes (half of
    them the DH form's z), random fixed transforms (some with a DH link's exact zeros), limits
    inside [-4, 4] rad, a base and a tool. ``unlimited``: the share of joints drawn without limits
    (None: none, and no draw for it, so the stream stays that of the chains without)."""
    from wsmap.kinematics import SerialChain

    fixed = random_rigid(rng, n + 1, 0.3)
    for i in range(n + 1):
        if rng.random() < 0.3:
            fixed[i, :3, :3] = np.eye(3)
        if rng.random() < 0.3:
            fixed[i, :3, 3] = [0.0, 0.0, rng.normal(scale=0.3)]
    axes = rng.normal(size=(n, 3))
    axes[rng.random(n) < 0.5] = [0.0, 0.0, 1.0]
    lim = np.sort(rng.uniform(-4, 4, size=(n, 2)), axis=1)
    if unlimited is not None:
        lim[rng.random(n) < unlimited] = [-np.inf, np.inf]
    return SerialChain(fixed, axes, "R" * n, offset=rng.normal(size=n), qlim=lim,
                       base=random_rigid(rng, 1, 0.2)[0], tool=random_rigid(rng, 1, 0.1)[0])
