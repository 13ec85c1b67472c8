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
