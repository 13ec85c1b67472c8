"""Study files: a reach study's results as one `.npz` (REACH's "database"), loadable and comparable.

Arrays (M targets, n joints, K orientation variants, A arms, and per arm the B best bases):

* `targets/poses` (M, 4, 4), `targets/points` (M, 3), `targets/normals` (M, 3), `targets/moved` (M,)
  (world frame, m; `moved` how much orthonormalising each pose moved it), `targets/vertices`,
  `targets/faces` of the workpiece where it was a mesh;
* `variants` (K, 4, 4), the tool-frame rotations of the orientation freedom;
* per arm `a` and ranked base `b`: `arm{a}/base{b}/base` (4, 4), `.../status` (M,) int8 (0 reached,
  1 certified unreachable, 2 not found; `wsmap.workspace.study.STATUS`), `.../q` (M, n_a) rad,
  `.../variant` (M,), `.../score` (M,), `.../score_<name>` (M,) each score;
* `study` — JSON: the arms' names, the settings the job recorded, and per arm and base the coverage,
  the mean score and the count of each answer.

The file is written deterministically (zip members in a fixed order with a fixed time stamp, no
timings inside): the same study gives the same bytes.
"""

from __future__ import annotations

import io as _bytes_io
import json
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..io import atomic_path, jsonable
from .study import REACHED, STATUS, TargetResults

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .workpiece import TargetSet

__all__ = ["StudyResult", "LoadedStudy", "save_study", "load_study", "compare_studies", "StudyFileError"]

#: The zip members' time stamp (the earliest a zip file can hold): no wall time in the file.
_EPOCH = (1980, 1, 1, 0, 0, 0)
#: The largest array a study file's member may declare (elements), checked before it is read.
MAX_ELEMENTS = 10**9


class StudyFileError(ValueError):
    """A file that is not a readable wsmap study file."""


@dataclass
class StudyResult:
    """A study's results: `names` of the arms, the `targets`, `results[a]` the `TargetResults` of arm
    `a` at each of its ranked bases (best first), the `variants` and the job's `settings`."""

    names: list
    targets: TargetSet
    results: list
    variants: np.ndarray
    settings: dict

    def summary(self) -> list[dict]:
        """Per arm, its best base: coverage, mean score and the count of each answer."""
        rows = []
        for name, ranked in zip(self.names, self.results):
            best = ranked[0]
            counts = np.bincount(best.status, minlength=3)
            rows.append({"arm": name, "coverage": best.coverage, "mean_score": best.mean_score,
                         "base_xyz": best.base[:3, 3].tolist(),
                         **{STATUS[i]: int(counts[i]) for i in range(3)}, "unconfirmed": best.unconfirmed})
        return rows


def _write_member(zf: zipfile.ZipFile, name: str, array: np.ndarray) -> None:
    buf = _bytes_io.BytesIO()
    np.lib.format.write_array(buf, np.ascontiguousarray(array), allow_pickle=False)
    info = zipfile.ZipInfo(f"{name}.npy", date_time=_EPOCH)
    info.compress_type = zipfile.ZIP_DEFLATED
    info.external_attr = 0o644 << 16
    zf.writestr(info, buf.getvalue())


def _arrays(result: StudyResult) -> dict[str, np.ndarray]:
    t = result.targets
    out = {"targets/poses": t.poses, "targets/points": t.points, "targets/normals": t.normals,
           "targets/moved": t.moved, "variants": result.variants}
    if t.vertices is not None:
        out["targets/vertices"], out["targets/faces"] = t.vertices, np.asarray(t.faces, dtype=np.int64)
    for a, ranked in enumerate(result.results):
        for b, res in enumerate(ranked):
            key = f"arm{a}/base{b}"
            out.update({f"{key}/base": res.base, f"{key}/status": res.status, f"{key}/q": res.q,
                        f"{key}/variant": res.variant, f"{key}/score": res.score})
            out.update({f"{key}/score_{k}": v for k, v in res.scores.items()})
    return out


def save_study(path, result: StudyResult) -> Path:
    """Write `result` to `path` (`.npz`) atomically and deterministically; returns the path."""
    meta = {"format": "wsmap study 1", "arms": result.names, "settings": jsonable(result.settings),
            "ranked": [[{"coverage": r.coverage, "mean_score": r.mean_score, "unconfirmed": r.unconfirmed,
                         "counts": np.bincount(r.status, minlength=3).tolist(), "scores": list(r.scores)}
                        for r in ranked] for ranked in result.results],
            "source": result.targets.source}
    with atomic_path(path, suffix=".npz") as tmp:
        with zipfile.ZipFile(tmp, "w") as zf:
            for name, array in sorted(_arrays(result).items()):
                _write_member(zf, name, np.asarray(array))
            info = zipfile.ZipInfo("study.json", date_time=_EPOCH)
            info.compress_type = zipfile.ZIP_DEFLATED
            zf.writestr(info, json.dumps(meta, sort_keys=True))
    return Path(path)


@dataclass
class LoadedStudy:
    """A study file read back: `meta` (the JSON record) and `arrays` by member name; `results(a, b)`
    rebuilds arm `a`'s answers at its `b`-th base."""

    meta: dict
    arrays: dict

    @property
    def arms(self) -> list[str]:
        return list(self.meta["arms"])

    def results(self, arm: int = 0, base: int = 0) -> TargetResults:
        key = f"arm{arm}/base{base}"
        if f"{key}/status" not in self.arrays:
            raise StudyFileError(f"the study has no arm {arm} base {base}")
        names = self.meta["ranked"][arm][base]["scores"]
        return TargetResults(status=self.arrays[f"{key}/status"], q=self.arrays[f"{key}/q"],
                             variant=self.arrays[f"{key}/variant"],
                             scores={k: self.arrays[f"{key}/score_{k}"] for k in names},
                             score=self.arrays[f"{key}/score"], base=self.arrays[f"{key}/base"],
                             unconfirmed=self.meta["ranked"][arm][base]["unconfirmed"])


def _read_member(zf: zipfile.ZipFile, info: zipfile.ZipInfo, label: str) -> np.ndarray:
    with zf.open(info) as f:
        version = np.lib.format.read_magic(f)
        header = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
        shape, _, dtype = header(f)
        if dtype.hasobject or int(np.prod(shape, dtype=np.float64)) > MAX_ELEMENTS:
            raise StudyFileError(f"{label}: member {info.filename!r} declares {shape} {dtype}, not a study array")
    with zf.open(info) as f:
        return np.lib.format.read_array(f, allow_pickle=False)


def load_study(path) -> LoadedStudy:
    """Read a study file written by `save_study`; anything else is a one-line `StudyFileError`."""
    label = f"study file {str(path)!r}"
    if not Path(path).is_file():
        raise StudyFileError(f"{label}: no such file")
    try:
        with zipfile.ZipFile(path) as zf:
            members = {i.filename: i for i in zf.infolist()}
            if "study.json" not in members:
                raise StudyFileError(f"{label}: not a wsmap study file (no study.json)")
            meta = json.loads(zf.read("study.json"))
            arrays = {n[:-4]: _read_member(zf, i, label) for n, i in members.items() if n.endswith(".npy")}
    except (zipfile.BadZipFile, OSError, ValueError, KeyError, EOFError) as e:
        if isinstance(e, StudyFileError):
            raise
        raise StudyFileError(f"{label}: not a readable study file ({type(e).__name__}: {str(e)[:120]})") from None
    if not isinstance(meta, dict) or meta.get("format") != "wsmap study 1":
        raise StudyFileError(f"{label}: not a wsmap study file (format {str(meta.get('format'))[:40]!r})")
    return LoadedStudy(meta=meta, arrays=arrays)


def compare_studies(a: LoadedStudy, b: LoadedStudy, arm: int = 0) -> dict:
    """Targets gained and lost from study `a` to study `b` (arm `arm`, best base of each), and the
    change of the combined score on the targets both reach. The two must have the same targets."""
    pa, pb = a.arrays["targets/poses"], b.arrays["targets/poses"]
    if pa.shape != pb.shape or not np.allclose(pa, pb, atol=1e-9):
        raise StudyFileError("the two studies have different targets; compare studies of the same targets")
    ra, rb = a.results(arm), b.results(arm)
    ha, hb = ra.status == REACHED, rb.status == REACHED
    both = ha & hb
    delta = rb.score[both] - ra.score[both]
    return {"targets": int(len(ha)), "reached_a": int(ha.sum()), "reached_b": int(hb.sum()),
            "gained": np.flatnonzero(hb & ~ha).tolist(), "lost": np.flatnonzero(ha & ~hb).tolist(),
            "score_change_mean": float(delta.mean()) if delta.size else 0.0,
            "score_better": int((delta > 0).sum()), "score_worse": int((delta < 0).sum())}
