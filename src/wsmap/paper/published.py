"""The paper's published numbers, in one place (`../shared/paper/NOTES.md`, "Published figures").

Everything that compares with the paper (the table notebooks, the report, the run-time comparison,
the benchmarks) reads these. F-measures are pooled over all test arms and nodes (micro), times in
seconds (MATLAB R2017b on a Xeon E3-1505M, the classical map one node at a time).
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["PAPER_TABLE1", "PAPER_TABLE2", "PAPER_TABLE3", "SEC61", "SEC62", "RUNTIME_SECONDS", "PAPER"]

_NAN = math.nan

#: Section 6.1 (one subspace, block 5): F over 10 sessions and the best threshold of the sweep.
SEC61: dict[str, float] = {"f_mean": 0.9665, "f_std": 0.0045, "best_threshold": 0.5, "best_threshold_f": 0.9714,
                           "sessions": 10, "samples": 100_000, "epochs": 1000}

#: Section 6.2 (PUMA560 from 7 block subspaces): the training set-up (NOTES: 1e5 arms, training
#: stops after 100 validation failures). The paper prints no F-measure for the assembled map.
SEC62: dict[str, float] = {"samples": 100_000, "max_fail": 100}

#: The run-time figure: nodes -> (classical seconds, network seconds) for the PUMA560 map.
RUNTIME_SECONDS: dict[int, tuple[float, float]] = {
    27: (19.5, 0.0313),
    125: (107.3, 0.0610),
    9261: (5227.8, 0.2238),
}

#: Table 1 of the paper: dataset -> workspace, delta, output size, F-measure +- sigma_f, batch size.
#: The "3086" row is the crop of 3087 nodes (NOTES "Datasets").
PAPER_TABLE1: dict[str, dict[str, Any]] = {
    "table1_r3_step1": dict(workspace="R3", delta="1", paper_nodes=27, paper_f=1.000, paper_f_std=0.00, paper_samples=60_000),
    "table1_r3_step05": dict(workspace="R3", delta="0.5", paper_nodes=125, paper_f=0.9967, paper_f_std=0.03, paper_samples=60_000),
    "table1_r3_block5": dict(workspace="R3", delta="0.1", paper_nodes=1323, paper_f=0.9221, paper_f_std=0.14, paper_samples=60_000),
    "table1_r3_crop3087": dict(workspace="R3", delta="0.1", paper_nodes=3086, paper_f=0.8493, paper_f_std=0.19, paper_samples=30_000),
    "table1_r3_full": dict(workspace="R3", delta="0.1", paper_nodes=9261, paper_f=0.9038, paper_f_std=0.15, paper_samples=15_000),
    "table1_so3_pi3": dict(workspace="SO3", delta="pi/3", paper_nodes=343, paper_f=0.9981, paper_f_std=0.01, paper_samples=60_000),
    "table1_so3_pi8": dict(workspace="SO3", delta="pi/8", paper_nodes=4913, paper_f=0.9779, paper_f_std=0.13, paper_samples=15_000),
    "table1_so3_pi10": dict(workspace="SO3", delta="pi/10", paper_nodes=9261, paper_f=0.9920, paper_f_std=0.03, paper_samples=15_000),
}

#: Table 2 of the paper: (optimizer, loss) -> (F mean, sigma); 6e4 samples, [125, 100, 100, 125].
PAPER_TABLE2: dict[tuple[str, str], tuple[float, float]] = {
    ("cgb", "crossentropy"): (0.3661, 0.2031),
    ("gdx", "crossentropy"): (0.3547, 0.2323),
    ("oss", "crossentropy"): (0.3574, 0.2337),
    ("rprop", "crossentropy"): (0.3573, 0.2337),
    ("scg", "crossentropy"): (0.3186, 0.1802),
    ("cgb", "mse"): (0.6686, 0.3068),
    ("gdx", "mse"): (0.2398, 0.1081),
    ("oss", "mse"): (0.6228, 0.2624),
    ("rprop", "mse"): (0.9298, 0.1258),
    ("scg", "mse"): (0.5938, 0.3131),
    ("cgb", "mae"): (0.3658, 0.1629),
    ("gdx", "mae"): (0.2256, 0.1011),
    ("oss", "mae"): (0.2778, 0.1178),
    ("rprop", "mae"): (0.6573, 0.2388),
    ("scg", "mae"): (0.3543, 0.1366),
}

#: Table 3 of the paper: (model's embedding, test set) -> precision, recall, F (each +- sigma);
#: NaN where the paper printed NaN (every model on the no-subspace test set).
PAPER_TABLE3: dict[tuple[str, str], dict[str, float]] = {
    ("nosubspace", "nosubspace"): dict(precision=_NAN, precision_std=_NAN, recall=_NAN, recall_std=_NAN, f=_NAN, f_std=_NAN),
    ("nosubspace", "workspace"): dict(precision=0.22, precision_std=0.18, recall=0.35, recall_std=0.13, f=0.24, f_std=0.14),
    ("nosubspace", "subspace"): dict(precision=0.01, precision_std=0.23, recall=0.00, recall_std=0.00, f=0.01, f_std=0.01),
    ("workspace", "workspace"): dict(precision=0.01, precision_std=0.23, recall=0.00, recall_std=0.00, f=0.01, f_std=0.01),
    ("workspace", "subspace"): dict(precision=0.85, precision_std=0.17, recall=0.58, recall_std=0.42, f=0.81, f_std=0.21),
    ("workspace", "nosubspace"): dict(precision=_NAN, precision_std=_NAN, recall=_NAN, recall_std=_NAN, f=_NAN, f_std=_NAN),
    ("subspace", "subspace"): dict(precision=0.93, precision_std=0.13, recall=0.76, recall_std=0.37, f=0.91, f_std=0.17),
    ("subspace", "workspace"): dict(precision=0.81, precision_std=0.17, recall=0.72, recall_std=0.35, f=0.82, f_std=0.18),
    ("subspace", "nosubspace"): dict(precision=_NAN, precision_std=_NAN, recall=_NAN, recall_std=_NAN, f=_NAN, f_std=_NAN),
}


def _flat() -> dict[str, Any]:
    """The headline numbers under the keys the report uses, derived from the tables above."""
    flat: dict[str, Any] = {}
    for n, (classical, network) in RUNTIME_SECONDS.items():
        flat[f"classical_time_{n}"] = classical
        flat[f"network_time_{n}"] = network
    flat["sec61_f_mean"] = SEC61["f_mean"]
    flat["sec61_f_std"] = SEC61["f_std"]
    flat["sec61_best_threshold_f"] = SEC61["best_threshold_f"]
    for name, row in PAPER_TABLE1.items():
        flat[name] = row["paper_f"]
    flat["table2_rprop_mse_f_mean"], flat["table2_rprop_mse_f_std"] = PAPER_TABLE2[("rprop", "mse")]
    sub = PAPER_TABLE3[("subspace", "subspace")]
    flat["table3_subspace_precision"] = sub["precision"]
    flat["table3_subspace_recall"] = sub["recall"]
    flat["table3_subspace_f"] = sub["f"]
    flat["table3_subspace_f_std"] = sub["f_std"]
    # the other two models on their own test sets (the no-subspace one: NaN, as printed)
    for emb in ("workspace", "nosubspace"):
        flat[f"table3_{emb}_f"] = PAPER_TABLE3[(emb, emb)]["f"]
    return flat


#: Flat view for the report: key -> published number.
PAPER: dict[str, Any] = _flat()
