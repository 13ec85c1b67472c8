"""The morphology models on real arms from URDFs that are not among the six named arms.

Loads the model files of the ``morphologies`` stage (``models/morph.pt``, map-search labels, and
``models/morph_fk.pt``, forward-kinematics labels) and scores each on the tool-down map (``R = Rx(pi)``,
``standard`` convention) of every 6R/7R arm of ``bench_recall_arms.ARMS`` (PyBullet's and rtb-data's
URDFs, xacro expanded; test-only packages), against the map search on the model's own training
grid; beside them the arm's own forward-kinematics-sampled map with the stage's samples. An arm the
model would refuse (outside its families' range) is predicted anyway (``allow_extrapolation``)
and the first reason is printed: that is where the model has no business being right.

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 nice -n 10 .venv/bin/python benchmarks/learn/bench_morph_urdf.py \\
        [--models models | --files A.pt B.pt ...] [--samples 50000] [--json bench/morph_urdf.json]
"""

from __future__ import annotations

import math
import os
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "maps"))  # bench_recall_arms: its arms and URDFs


def main(argv=None) -> int:
    p = harness.parser(__doc__)
    p.add_argument("--models", default="models", help="folder of morph.pt and morph_fk.pt")
    p.add_argument("--files", nargs="+", metavar="FILE",
                   help="score these morphology model files instead (each named by its file's stem; the first "
                        "one's grid is the truth's), e.g. the models of learn/bench_morph_scale.py")
    p.add_argument("--samples", type=int, default=50_000, help="FK samples of the sampled map")
    p.add_argument("--angle-tol", type=float, default=0.4, help="rad, of the sampled map")
    args = p.parse_args(argv)

    import torch

    torch.set_num_threads(1)
    from bench_recall_arms import ARMS, urdf_text

    from wsmap import workspace as ws
    from wsmap.kinematics.morphology import MorphologyError
    from wsmap.kinematics.urdf import from_urdf
    from wsmap.learn import morph_model as mm
    from wsmap.learn.training_range import ExtrapolationWarning
    from wsmap.metrics import score_maps

    files = args.files or [os.path.join(args.models, f"{name}.pt") for name in ("morph", "morph_fk")]
    models = {os.path.splitext(os.path.basename(f))[0]: mm.load_morph_model(f)[0] for f in files}
    model = next(iter(models.values()))
    nodes = model.nodes.numpy().astype(np.float64)
    step = float(np.diff(np.unique(nodes[:, 0]))[0])
    rows = []
    for name, source, base, ee in ARMS:
        chain = from_urdf(urdf_text(source), ee_link=ee, base_link=base, name=name)
        row = {"arm": name, "joints": chain.n}
        try:
            truth = ws.constant_orientation_map(chain, nodes, mm.TOOL_DOWN, convention="standard")
            for key, mdl in models.items():
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always", ExtrapolationWarning)
                    pred = mm.predict_morph_map(mdl, chain, nodes, allow_extrapolation=True)
                s = score_maps(pred[None], truth[None])
                row.update({f"{key}_f": float(s["f"]), f"{key}_p": float(s["precision"]),
                            f"{key}_r": float(s["recall"])})
                if key == next(iter(models)):
                    out = [str(w.message) for w in caught if issubclass(w.category, ExtrapolationWarning)]
                    row["in range"] = "yes" if not out else out[0].split(": ", 1)[-1].split(";")[0]
            sampled = ws.fk_sampled_maps(chain, -model.box, model.box, step, mm.TOOL_DOWN, samples=args.samples,
                                         angle_tol=args.angle_tol)
            row["fk_sampled_f"] = float(score_maps(sampled[None], truth[None])["f"])
            row["reachable"] = int(truth.sum())
        except MorphologyError as e:
            row["in range"] = f"no morphology: {e}"
        rows.append(row)
        print(row, flush=True, file=sys.stderr)

    def cell(v):
        return "—" if v is None else (f"{v:.3f}" if isinstance(v, float) and math.isfinite(v) else
                                      ("none predicted" if isinstance(v, float) else str(v)))

    cols = ["arm", "joints", "reachable", *(f"{k}_{x}" for k in models for x in "fpr"), "fk_sampled_f", "in range"]
    print("| " + " | ".join(cols) + " |")
    print("|" + "---|" * len(cols))
    for r in rows:
        print("| " + " | ".join(cell(r.get(c)) for c in cols) + " |")
    harness.write_json(args, {"rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
