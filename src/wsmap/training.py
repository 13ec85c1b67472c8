"""Compatibility module: training now lives in :mod:`wsmap.learn.training`; every old name is re-exported here."""

from .learn.training import (
    LOSSES,
    LR_DECAYS,
    MINIBATCH_OPTIMIZERS,
    STOP_REASONS,
    History,
    Loss,
    Split,
    TrainConfig,
    TrainResult,
    make_loss,
    optimizer_name,
    split_indices,
    train,
    train_sessions,
)

__all__ = [
    "LOSSES",
    "Loss",
    "make_loss",
    "Split",
    "split_indices",
    "TrainConfig",
    "History",
    "TrainResult",
    "train",
    "train_sessions",
    "STOP_REASONS",
    "MINIBATCH_OPTIMIZERS",
    "LR_DECAYS",
    "optimizer_name",
]
