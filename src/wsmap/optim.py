"""Compatibility module: the paper's optimisers now live in :mod:`wsmap.learn.optim`.

Every old name is re-exported here.
"""

from .learn.optim import (
    ALIASES,
    CGB,
    ELEMENTWISE,
    GDX,
    OPTIMIZERS,
    OSS,
    RPROP_DEFAULTS,
    SCG,
    canonical_name,
    charalambous_search,
    make_optimizer,
    paper_rprop,
)

__all__ = [
    "OPTIMIZERS",
    "ALIASES",
    "ELEMENTWISE",
    "canonical_name",
    "make_optimizer",
    "paper_rprop",
    "SCG",
    "CGB",
    "OSS",
    "GDX",
    "charalambous_search",
    "RPROP_DEFAULTS",
]
