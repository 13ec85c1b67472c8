"""Dataset files: building them (all or nothing) and reading them back (checked).

File format
-----------
A zip archive readable by `numpy.load` (an `.npz`) with exactly three entries, in this order:
`features` (float64), `labels_packed` (uint8, `np.packbits(labels, axis=1)`: nodes
big-endian within each byte, rows padded to whole bytes with zero bits) and `header` (UTF-8 JSON
as uint8): the spec dict, the format name and version, the wsmap version, shapes, feature names,
and the SHA-256 of `features.tobytes() + labels_packed.tobytes()` (C order, little-endian). The
zip is written with fixed entry timestamps (`np.savez_compressed` stamps the current time, which
would make rebuilds differ byte-wise), streamed chunk by chunk into a temporary file beside the
target, and renamed over it only when complete.

Reading
-------
`load_dataset` trusts nothing in the file: every entry is read whole and checked against
its zip CRC-32 before it is parsed, the header is checked field by field, the array sizes are
compared with the header before any memory is allocated for them, and the arrays with the header's
SHA-256. Whatever is wrong -- a flipped byte anywhere, a truncation, a foreign or tampered file --
is a `DatasetError` naming the path and the problem; a file that loads is the file that
was written (a flip in zip metadata that is never read leaves the data as it was).

Writing
-------
`build_dataset` writes one spec's file. `build_dataset_files` is what a command line
calls: a training file and/or its independent test file, every input checked before any work and
before any file is touched, both files written to temporary files and renamed into place only when
both succeeded (an existing file at either path stays as it was if anything fails). OS errors name
the user's path, never a temporary file.

Where the labels are computed
-----------------------------
The arms are drawn, and the features computed, in the calling process; the labels are computed
chunk by chunk (`chunk` arms each). By default every chunk runs in the calling process (the
*single-process build*). With `workers=K` the chunks are tasks on a Dask
`distributed.LocalCluster` of `K` worker processes with one thread each, started for the
build and closed after it; with `scheduler="tcp://host:port"` (or a `distributed.Client`)
they are tasks on that cluster (its workers need this wsmap installed). Each task gets the spec
and its chunk's inputs (a chain family's scale factors, a DH chunk's arms, orientations and LM
starts: small arrays), sets the compiled kernels to one thread
(`wsmap.kinematics.lm_compiled.set_threads`) and returns the chunk's packed labels; at most
two tasks per worker thread are in flight, and the results are written in chunk order as they
come. A task computes exactly what the single-process build computes for its chunk (an arm's labels
depend neither on the other arms of its chunk nor on the thread count), so the file is
byte-identical to the single-process build's, on workers with the same wsmap, numpy and numba and
the same kind of CPU (the compiled kernels may contract to fused multiply-adds where the CPU has
them, which can move a borderline node). A scheduler that does not answer within
`connect_timeout` seconds (`CONNECT_TIMEOUT`) is a `SchedulerError` before any file
is touched; so is a scheduler without a worker after `WORKER_TIMEOUT` seconds.
"""

from __future__ import annotations

import hashlib
import io
import json
import logging
import math
import os
import zipfile
from collections import deque
from collections.abc import Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from .._version import __version__
from ..io import OutputPathError, atomic_paths, check_output_path
from .features import feature_names, features_for
from .labels import labels_for
from .sampling import draw_fixed, draw_samples, draw_scales, start_configurations, stream_rng
from .spec import DatasetSpec, check_int, check_spec, scaled, test_spec
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import Any, ArrayLike, PathLike

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "DatasetError",
    "SchedulerError",
    "CONNECT_TIMEOUT",
    "WORKER_TIMEOUT",
    "Dataset",
    "build_dataset",
    "build_dataset_files",
    "load_dataset",
    "load_dataset_files",
    "test_path_for",
]

FORMAT = "wsmap-dataset"
FORMAT_VERSION = 1
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)  # fixed entry timestamps: byte-identical rebuilds
_ENTRIES = ("features", "labels_packed", "header")
#: the JSON header entry is small (a spec, shapes and feature names); a bigger one is not ours
_MAX_HEADER_BYTES = 64 << 20
#: largest .npy header (version 2.0 may hold up to 4 GiB, but ours are version 1.0, < 64 KiB)
_MAX_NPY_HEADER = 1 << 16
_READ_CHUNK = 1 << 24


#: Seconds to wait for a Dask scheduler (`scheduler=`, `--scheduler`) to answer.
CONNECT_TIMEOUT = 5.0
#: Seconds to wait for a scheduler without workers to get its first one.
WORKER_TIMEOUT = 60.0
#: The longest `connect_timeout`: a scheduler that has not answered in an hour will not (and Dask
#: retries a connection until its timeout, so 1e308 s would retry forever).
MAX_CONNECT_TIMEOUT = 3600.0
#: A local cluster has at most this many worker processes per core of the machine: each is one
#: single-threaded process, so beyond the cores they only share them and multiply the memory.
WORKERS_PER_CORE = 4


def _cores() -> int:
    """The cores this process may run on (its affinity where the OS has one)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


class DatasetError(ValueError):
    """A dataset file that cannot be used: truncated, corrupt, not a dataset, or for another spec."""


class SchedulerError(ConnectionError):
    """The Dask scheduler of a build did not answer (or has no workers); nothing was written."""


class _Corrupt(Exception):
    """Internal: a problem found while reading; `load_dataset` turns it into a DatasetError."""


# --------------------------------------------------------------------------- writing
def _npy_header(shape, dtype) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf, {"descr": np.lib.format.dtype_to_descr(np.dtype(dtype)), "fortran_order": False, "shape": tuple(shape)}
    )
    return buf.getvalue()


def _zip_entry(zf: zipfile.ZipFile, name: str):
    info = zipfile.ZipInfo(name + ".npy", date_time=_ZIP_TIME)
    info.compress_type = zipfile.ZIP_DEFLATED
    info.external_attr = 0o644 << 16
    return zf.open(info, "w", force_zip64=True)


def _default_chunk(spec: DatasetSpec) -> int:
    n = spec.n_nodes
    if spec.method == "numerical":
        return max(1, (1 << 16) // n)  # LM is slow per node; small chunks keep the bar moving
    return max(1, (1 << 21) // n)


def _draw_inputs(spec: DatasetSpec):
    """`(X, arms, fixed, q0)`: the features and what the labels of every arm need -- `arms` the
    DH arms, or a chain family's scale factors (the chains are built per chunk, where they are
    labelled); `q0` the LM starts of the numerical DH path, else `None`."""
    if spec.is_chain_family:
        arms = draw_scales(spec)
        fixed = draw_fixed(spec, spec.samples, stream_rng(spec, "fixed"))
        q0 = None
    else:
        arms, fixed = draw_samples(spec)
        q0 = start_configurations(spec) if spec.method == "numerical" else None
    return features_for(arms, spec, fixed), arms, fixed, q0


def _label_chunk(spec: DatasetSpec, arms, fixed, q0, version: str | None = None) -> np.ndarray:
    """The packed labels `(rows, ceil(N / 8))` uint8 of one chunk of arms (what a Dask task runs).

    `version` is the builder's wsmap version: a task sets the compiled kernels to one thread and
    refuses to run on a worker with another wsmap (its labels could differ)."""
    if version is not None:
        if version != __version__:
            raise RuntimeError(f"a Dask worker runs wsmap {__version__}, the build wsmap {version}: install the "
                               "same wsmap on every worker (labels could differ)")
        from ..kinematics import lm_compiled

        lm_compiled.set_threads(1)
    return np.packbits(labels_for(arms, spec, fixed, q0=q0), axis=1)


def _dask_chunks(client, spec: DatasetSpec, inputs, chunks):
    """The packed labels of each chunk in order, computed as tasks on `client`'s cluster (at most
    two per worker thread in flight); a generator, whose `close` cancels what is still pending."""
    window = max(2, 2 * sum(client.nthreads().values()))
    pending: deque = deque()
    nxt = 0
    try:
        while nxt < len(chunks) or pending:
            while nxt < len(chunks) and len(pending) < window:
                pending.append(client.submit(_label_chunk, spec, *inputs(chunks[nxt]), __version__, pure=False))
                nxt += 1
            yield pending.popleft().result()
    finally:
        if pending:
            client.cancel(list(pending))


def _write_dataset(spec: DatasetSpec, tmp: Path, chunk: int, progress: bool, client=None) -> None:
    """Generate `spec`'s dataset into the (temporary) file `tmp`; labels on `client`'s Dask
    cluster when given, else in this process."""
    X, arms, fixed, q0 = _draw_inputs(spec)
    S, N = spec.samples, spec.n_nodes
    width = (N + 7) // 8
    digest = hashlib.sha256(X.tobytes())
    chunks = [slice(s, min(s + chunk, S)) for s in range(0, S, chunk)]

    def inputs(sl):
        return arms[sl], fixed[sl], None if q0 is None else q0[sl]

    if client is None:
        results = (_label_chunk(spec, *inputs(sl)) for sl in chunks)
    else:
        results = _dask_chunks(client, spec, inputs, chunks)

    from tqdm.auto import tqdm

    try:
        with tqdm(total=S, unit="arm", desc=spec.name, disable=not progress, leave=False) as bar:
            with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as zf:
                with _zip_entry(zf, "features") as fid:
                    np.lib.format.write_array(fid, X)
                with _zip_entry(zf, "labels_packed") as fid:
                    fid.write(_npy_header((S, width), np.uint8))
                    for sl, packed in zip(chunks, results):
                        if packed.shape != (sl.stop - sl.start, width) or packed.dtype != np.uint8:
                            raise RuntimeError(f"labels of arms {sl.start}..{sl.stop - 1} came back with shape "
                                               f"{packed.shape} {packed.dtype}, expected {(sl.stop - sl.start, width)}")
                        packed = np.ascontiguousarray(packed)
                        digest.update(packed.tobytes())
                        fid.write(packed.tobytes())
                        bar.update(sl.stop - sl.start)
                header = {
                    "format": FORMAT,
                    "format_version": FORMAT_VERSION,
                    "wsmap_version": __version__,
                    "spec": spec.to_dict(),
                    "features_shape": list(X.shape),
                    "labels_shape": [S, N],
                    "labels_packed_shape": [S, width],
                    "feature_names": feature_names(spec),
                    "sha256": digest.hexdigest(),
                }
                raw = json.dumps(header, sort_keys=True, separators=(",", ":")).encode("utf-8")
                with _zip_entry(zf, "header") as fid:
                    np.lib.format.write_array(fid, np.frombuffer(raw, dtype=np.uint8))
    finally:
        if client is not None:
            results.close()  # cancels the tasks still pending (an error, an interrupt)


def _is_client(x) -> bool:
    try:
        from distributed import Client
    except ImportError:  # pragma: no cover - a dependency of wsmap's environment
        return False
    return isinstance(x, Client)


def _check_cluster(workers, scheduler, connect_timeout):
    """Checked `(workers, scheduler, connect_timeout)` of a build (see the module notes)."""
    if workers is not None:
        workers = check_int("workers", workers, 1)
        cores = _cores()
        if workers > WORKERS_PER_CORE * cores:
            raise ValueError(f"workers must be at most {WORKERS_PER_CORE * cores} ({WORKERS_PER_CORE} per core of the "
                             f"{cores} here): each is a single-threaded process, so more than the cores only share "
                             f"them; got {workers}")
    if scheduler is not None:
        if isinstance(scheduler, str):
            scheduler = scheduler.strip()
            if not scheduler:
                raise ValueError("scheduler must be a Dask scheduler address such as 'tcp://host:8786', got ''")
        elif not _is_client(scheduler):
            raise ValueError(f"scheduler must be a Dask scheduler address ('tcp://host:8786') or a "
                             f"distributed.Client, got {type(scheduler).__name__}")
        if workers is not None:
            raise ValueError("workers sizes the local Dask cluster a build starts; a scheduler's cluster has its own "
                             "workers: give one or the other")
    if workers is not None or isinstance(scheduler, str):
        from .._optional import require

        require("distributed", why="building on Dask (workers or a scheduler)")  # before any work
    try:
        connect_timeout = float(connect_timeout)
    except (TypeError, ValueError):
        raise ValueError(f"connect_timeout must be a positive number of seconds, got {connect_timeout!r}") from None
    if not (connect_timeout > 0 and math.isfinite(connect_timeout)):
        raise ValueError(f"connect_timeout must be a positive number of seconds, got {connect_timeout!r}")
    if connect_timeout > MAX_CONNECT_TIMEOUT:
        raise ValueError(f"connect_timeout must be at most {MAX_CONNECT_TIMEOUT:g} s (a scheduler that has not "
                         f"answered in an hour will not), got {connect_timeout:g}")
    return workers, scheduler, connect_timeout


def _connect(scheduler: str, timeout: float):
    """A `distributed.Client` of the scheduler at `scheduler`, or the exception of the try.

    A Client whose address is bad (`tcp://`, `http://x`, `tcp://[::1`) raises from inside its
    constructor and is left half built; its `__del__` then prints a `TimeoutError` traceback
    seconds later. So the Client that failed to start is found and closed here.
    """
    from distributed import Client

    class _ClosingClient(Client):
        def start(self, **kwargs):
            try:
                return super().start(**kwargs)
            except BaseException:
                try:
                    self.close(timeout=1)
                except Exception:  # noqa: BLE001 - closing what never opened; the first error is the one to tell
                    pass
                raise

    return _ClosingClient(scheduler, timeout=timeout, set_as_default=False)


@contextmanager
def _dask_client(workers, scheduler, connect_timeout):
    """`None` (single process), or a `distributed.Client` of a LocalCluster of `workers`
    single-threaded processes (closed on exit), of the scheduler at the address `scheduler`, or
    `scheduler` itself when it is a Client (left open)."""
    if workers is None and scheduler is None:
        yield None
        return
    if scheduler is not None and not isinstance(scheduler, str):
        yield scheduler
        return
    from .._optional import require

    distributed = require("distributed", why="building on Dask (workers or a scheduler)")
    Client, LocalCluster = distributed.Client, distributed.LocalCluster
    if scheduler is not None:
        try:
            client = _connect(scheduler, connect_timeout)
        except (ValueError, TypeError, ImportError) as e:  # Dask's own words on an address it cannot use
            raise SchedulerError(
                f"{scheduler!r} is not a Dask scheduler address this machine can use ({e}); give one such as "
                "'tcp://head:8786'; nothing was written"
            ) from None
        except (OSError, TimeoutError) as e:
            raise SchedulerError(
                f"no Dask scheduler answered at {scheduler!r} within {connect_timeout:g} s ({e}); start one with "
                f"`dask scheduler` and workers with `dask worker {scheduler}`, or check the address; nothing was "
                "written"
            ) from None
        with client:
            try:
                client.wait_for_workers(1, timeout=WORKER_TIMEOUT)
            except (OSError, TimeoutError) as e:
                raise SchedulerError(
                    f"the Dask scheduler at {scheduler!r} has no workers (none joined within {WORKER_TIMEOUT:g} s: "
                    f"{e}); start some with `dask worker {scheduler}`; nothing was written"
                ) from None
            yield client
        return
    # one thread per worker process, and one numba thread in it (tasks also call set_threads(1))
    env = {"NUMBA_NUM_THREADS": "1", "WSMAP_THREADS": "1", "OMP_NUM_THREADS": "1"}
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.ERROR, env=env) as cluster, \
            Client(cluster, set_as_default=False) as client:
        yield client


def _write_all(jobs, chunk, progress, workers=None, scheduler=None, connect_timeout=CONNECT_TIMEOUT) -> None:
    """Write `jobs` (`(spec, path)` pairs) all or nothing; OS errors name the user's path. The
    Dask cluster (if any) is reached before any file is touched."""
    with _dask_client(workers, scheduler, connect_timeout) as client, atomic_paths([path for _, path in jobs]) as tmps:
        for (spec, path), tmp in zip(jobs, tmps):
            size = chunk
            if size is None:
                size = _default_chunk(spec)
                if client is not None:
                    # at least ~4 tasks per worker thread, so that the last ones do not leave most idle
                    threads = max(1, sum(client.nthreads().values()))
                    size = max(1, min(size, -(-spec.samples // (4 * threads))))
            try:
                _write_dataset(spec, tmp, size, progress, client)
            except OSError as e:
                # e.g. no space left: the error would name the temporary file, or nothing
                message = f"cannot write {str(path)!r}: {e.strerror or e}"
                raise (OSError(e.errno, message) if e.errno is not None else OSError(message)) from None


def build_dataset(spec: DatasetSpec, path: PathLike, chunk: int | None = None, progress: bool = True, *,
                  workers: int | None = None, scheduler: Any | None = None, connect_timeout: float = CONNECT_TIMEOUT
                 ) -> Path:
    """Generate `spec`'s dataset into `path` (see the module docstring for the format).

    Arms are labelled `chunk` at a time (default: about 2 million node evaluations per chunk
    for exact labels, 65,536 for numerical ones), each chunk's labels bit-packed and streamed into
    the compressed file, so memory stays bounded by the features (`samples x n_features`
    float64) plus a few chunks. The same spec always gives a byte-identical file, whatever
    `chunk`, `workers` or `scheduler`. `workers` (a LocalCluster of that many processes) or
    `scheduler` (an address `"tcp://host:port"`, or a `distributed.Client`) compute the
    labels on Dask (module notes, "Where the labels are computed"); neither: in this process.
    The path is checked before any work (`wsmap.io.check_output_path`: not empty, not a
    directory, in a folder that can be written or created) and the scheduler reached before any
    file is touched (`SchedulerError` after `connect_timeout` seconds); the file appears
    only when complete. Returns the path.
    """
    check_spec(spec)
    path = check_output_path(path, "dataset")
    chunk = None if chunk is None else check_int("chunk", chunk, 1)
    workers, scheduler, connect_timeout = _check_cluster(workers, scheduler, connect_timeout)
    _write_all([(spec, path)], chunk, progress, workers, scheduler, connect_timeout)
    return path


def test_path_for(path: PathLike) -> Path:
    """Where the test set of the training file `path` goes: `NAME.npz` → `NAME.test.npz`."""
    path = Path(path)
    return path.with_name(path.name.removesuffix(".npz") + ".test.npz")


test_path_for.__test__ = False  # not a pytest test, despite the name


def _same_file(a: Path, b: Path) -> bool:
    if os.path.abspath(a) == os.path.abspath(b):
        return True
    try:
        return a.resolve() == b.resolve() or os.path.samefile(a, b)
    except (OSError, RuntimeError):  # one of them does not exist yet (or a symlink loop)
        return False


def _named_spec(spec: DatasetSpec | str, catalogue: Mapping[str, DatasetSpec] | None) -> DatasetSpec:
    """`spec` itself, or the spec of that name in `catalogue`."""
    if not isinstance(spec, str):
        return spec
    if catalogue is None:
        raise ValueError(f"a dataset given by name ({spec!r}) needs a catalogue of specs to look it up in")
    if spec not in catalogue:
        raise ValueError(f"unknown dataset {spec!r}; choose one of {', '.join(sorted(catalogue))}")
    return catalogue[spec]


def _file_jobs(spec: DatasetSpec, out: PathLike, samples: int | None, test_samples: int | None,
               test_out: PathLike | None, test_only: bool) -> list[tuple[DatasetSpec, Path]]:
    """The `(spec, path)` pairs `build_dataset_files` writes (training file first), every path
    checked (`check_output_path`; the two outputs not the same file); `samples` and
    `test_samples` are counts already checked (or `None`)."""
    if test_only:
        if test_samples is not None or test_out is not None:
            raise ValueError(
                "test_only builds only a test set (of `samples` arms) into `out`; test_samples and test_out "
                "build one beside a training set: give one or the other"
            )
        return [(test_spec(spec, 1000 if samples is None else samples), check_output_path(out, "dataset"))]
    train = spec if samples is None else scaled(spec, samples)
    out = check_output_path(out, "dataset")
    jobs = [(train, out)]
    if test_samples is not None or test_out is not None:
        test_out = check_output_path(test_path_for(out) if test_out is None else test_out, "test set")
        if _same_file(out, test_out):
            raise OutputPathError(f"the dataset and its test set would both be written to {str(out)!r}")
        jobs.append((test_spec(train, 1000 if test_samples is None else test_samples), test_out))
    return jobs


def build_dataset_files(
    spec: DatasetSpec,
    out: PathLike,
    *,
    samples: int | None = None,
    test_samples: int | None = None,
    test_out: PathLike | None = None,
    test_only: bool = False,
    catalogue: Mapping[str, DatasetSpec] | None = None,
    chunk: int | None = None,
    progress: bool = True,
    workers: int | None = None,
    scheduler: Any | None = None,
    connect_timeout: float = CONNECT_TIMEOUT,
) -> list[Path]:
    """Build a training file and/or its independent test file, all or nothing.

    Parameters
    ----------
    spec : DatasetSpec or str
        The spec, or its name in `catalogue` (e.g. `wsmap.paper.specs.PAPER_SPECS`).
    out : path
        The training file; with `test_only` the test file.
    samples : int, optional
        Arms of the file at `out` (the first `samples` of the spec's streams): the training
        set's (default `spec.samples`) or, with `test_only`, the test set's (default 1000).
    test_samples : int, optional
        Also build the independent test set (`test_spec`) of this many arms.
        `None` (the default): no test file, unless `test_out` is given (then 1000 arms).
    test_out : path, optional
        Where the test set goes; default `test_path_for` `(out)`, `NAME.test.npz`.
    test_only : bool
        Build only the test set, into `out`; `test_samples` and `test_out` are then refused.
    catalogue : mapping of name to DatasetSpec, optional
        Where a `spec` given by name is looked up.
    chunk, progress, workers, scheduler, connect_timeout :
        As for `build_dataset`: by default the labels are computed in this process;
        `workers=K` on a Dask LocalCluster of `K` single-threaded processes,
        `scheduler="tcp://host:port"` on that Dask cluster (one connection for both files).
        The files are byte-identical either way.

    Returns
    -------
    list of Path
        The written paths, training file first.

    Notes
    -----
    Every input is checked before any work and before any file is touched: a bad count (0,
    negative, not an integer), an unknown name, an output path that is empty, a directory, or in a
    folder that cannot be written or created, two outputs at the same path, and both `workers`
    and `scheduler` are each a `ValueError` (`wsmap.io.OutputPathError` for the paths)
    naming the argument; a scheduler that does not answer is a `SchedulerError`. Both files
    are then written to temporary files beside their targets and renamed into place only when both
    are complete; if anything fails (or the run is interrupted), no temporary file is left behind
    and an existing file at either path is untouched.
    """
    # ---- what to build (no work, no files yet)
    spec = _named_spec(spec, catalogue)
    check_spec(spec)
    if not isinstance(test_only, bool):
        raise ValueError(f"test_only must be True or False, got {test_only!r}")
    if samples is not None:
        samples = check_int("samples", samples, 1)
    if test_samples is not None:
        test_samples = check_int("test_samples", test_samples, 1)
    if chunk is not None:
        chunk = check_int("chunk", chunk, 1)
    workers, scheduler, connect_timeout = _check_cluster(workers, scheduler, connect_timeout)
    jobs = _file_jobs(spec, out, samples, test_samples, test_out, test_only)
    # ---- the work, all or nothing (the Dask scheduler, if any, reached first)
    _write_all(jobs, chunk, progress, workers, scheduler, connect_timeout)
    return [path for _, path in jobs]


# --------------------------------------------------------------------------- reading
@dataclass
class Dataset:
    """A loaded dataset: `features` `(samples, F)` float64, `labels` `(samples, nodes)` bool.

    `labels` is unpacked from `labels_packed` on first access (1 byte per label: 0.9 GB for
    1e5 x 9261); `label_rows(idx)` unpacks only some rows.
    """

    spec: DatasetSpec
    features: np.ndarray
    labels_packed: np.ndarray
    header: dict = field(repr=False)
    path: Path | None = None

    @cached_property
    def labels(self) -> np.ndarray:
        return self.label_rows(slice(None))

    def label_rows(self, idx: ArrayLike) -> np.ndarray:
        n = self.header["labels_shape"][1]
        # unpackbits gives 0/1 bytes: viewing them as bool avoids a second 1-byte-per-label copy
        return np.unpackbits(self.labels_packed[idx], axis=-1, count=n).view(bool)

    @property
    def feature_names(self) -> list[str]:
        return feature_names(self.spec)

    @property
    def n_nodes(self) -> int:
        """Labelled nodes per sample."""
        return int(self.header["labels_shape"][1])

    def head(self, n: int | None) -> "Dataset":
        """The first `n` samples (all when `n` is `None` or at least `len(self)`): what a
        reduced training run uses, the same arms a smaller build would have drawn."""
        if n is None:
            return self
        n = check_int("n", n, 1)
        if n >= len(self):
            return self
        header = {**self.header, "features_shape": [n, self.features.shape[1]],
                  "labels_shape": [n, self.n_nodes], "labels_packed_shape": [n, self.labels_packed.shape[1]]}
        return Dataset(spec=scaled(self.spec, n), features=self.features[:n],
                       labels_packed=self.labels_packed[:n], header=header, path=self.path)

    def __len__(self):
        return self.features.shape[0]


def _spec_diff(a: dict, b: dict) -> list[str]:
    keys = sorted(set(a) | set(b))
    return [f"{k}: file has {a.get(k)!r}, expected {b.get(k)!r}" for k in keys if a.get(k) != b.get(k)]


def _read_entry(zf: zipfile.ZipFile, info: zipfile.ZipInfo) -> bytearray:
    """The whole entry, CRC-checked (zipfile checks the CRC-32 when the last byte is read)."""
    buf = bytearray(info.file_size)
    view = memoryview(buf)
    with zf.open(info) as f:
        n = 0
        while n < len(buf):
            k = f.readinto(view[n : n + _READ_CHUNK])
            if not k:
                raise _Corrupt(f"entry {info.filename} inflates to {n} bytes, the zip directory says {len(buf)}")
            n += k
        if f.read(1):
            raise _Corrupt(f"entry {info.filename} is longer than its directory says")
    return buf


def _parse_npy(buf: bytearray, name: str, shape=None, dtype=None) -> np.ndarray:
    """The array in a whole `.npy` buffer (no copy: a writable view of `buf`), checked against
    the expected `shape` and `dtype` when given."""
    bio = io.BytesIO(buf[: min(len(buf), _MAX_NPY_HEADER + 16)])
    version = np.lib.format.read_magic(bio)
    if version == (1, 0):
        got_shape, fortran, got_dtype = np.lib.format.read_array_header_1_0(bio)
    elif version == (2, 0):
        got_shape, fortran, got_dtype = np.lib.format.read_array_header_2_0(bio)
    else:
        raise _Corrupt(f"entry {name} has .npy format version {version}")
    if fortran or got_dtype.hasobject:
        raise _Corrupt(f"entry {name} is not a C-order numeric array")
    if shape is not None and tuple(got_shape) != tuple(shape):
        raise _Corrupt(f"entry {name} has shape {list(got_shape)}, the header says {list(shape)}")
    if dtype is not None and got_dtype != np.dtype(dtype):
        raise _Corrupt(f"entry {name} has dtype {got_dtype}, expected {np.dtype(dtype)}")
    count = math.prod(got_shape)
    offset = bio.tell()
    if offset + count * got_dtype.itemsize != len(buf):
        raise _Corrupt(f"entry {name} holds {len(buf) - offset} data bytes, its shape needs {count * got_dtype.itemsize}")
    return np.frombuffer(buf, dtype=got_dtype, count=count, offset=offset).reshape(got_shape)


def _shape(header, key, ndim=2) -> tuple[int, ...]:
    v = header.get(key)
    if not (isinstance(v, list) and len(v) == ndim and all(type(x) is int and x >= 0 for x in v)):
        raise _Corrupt(f"header field {key} is {v!r}, not a list of {ndim} counts")
    return tuple(v)


def _check_header(path: Path, header) -> tuple:
    if not isinstance(header, dict):
        raise _Corrupt(f"the header is a JSON {type(header).__name__}, not an object")
    if header.get("format") != FORMAT:
        raise DatasetError(f"dataset file {path} is not a wsmap dataset (header format {header.get('format')!r})")
    version = header.get("format_version")
    if version != FORMAT_VERSION:
        raise DatasetError(
            f"dataset file {path} has format version {version!r}; this wsmap ({__version__}) reads version "
            f"{FORMAT_VERSION}: rebuild the file"
        )
    fshape, lshape, pshape = (_shape(header, k) for k in ("features_shape", "labels_shape", "labels_packed_shape"))
    S, N = lshape
    if fshape[0] != S or pshape != (S, (N + 7) // 8):
        raise _Corrupt(f"header shapes disagree (features {list(fshape)}, labels {list(lshape)}, packed {list(pshape)})")
    sha = header.get("sha256")
    if not (isinstance(sha, str) and len(sha) == 64 and all(c in "0123456789abcdef" for c in sha)):
        raise _Corrupt(f"header field sha256 is {sha!r}, not a SHA-256 hex digest")
    if not isinstance(header.get("spec"), dict):
        raise _Corrupt("the header holds no spec")
    return fshape, lshape, pshape


def _read(path: Path, fh) -> Dataset:
    """The checked dataset in the open file `fh`; raises anything on a bad file (load_dataset maps it)."""
    try:
        zf = zipfile.ZipFile(fh)
    except (zipfile.BadZipFile, EOFError, OSError) as e:
        raise DatasetError(f"dataset file {path} is truncated or not a dataset file ({e or type(e).__name__})") from None
    with zf:
        infos = zf.infolist()
        names = [i.filename for i in infos]
        expected = [f"{k}.npy" for k in _ENTRIES]
        missing = sorted(set(expected) - set(names))
        if missing:
            raise DatasetError(
                f"dataset file {path} is not a wsmap dataset, or is corrupt: entries "
                f"{', '.join(m.removesuffix('.npy') for m in missing)} missing"
            )
        if len(names) != len(expected):
            extra = sorted(set(names) - set(expected)) or names
            raise DatasetError(f"dataset file {path} is not a wsmap dataset, or is corrupt: unexpected entries {extra}")
        info = dict(zip(names, infos))
        # the header first: it says how big the arrays must be, before any memory is allocated for them
        hinfo = info["header.npy"]
        if hinfo.file_size > _MAX_HEADER_BYTES:
            raise _Corrupt(f"header entry of {hinfo.file_size} bytes")
        raw = _parse_npy(_read_entry(zf, hinfo), "header", dtype=np.uint8)
        if raw.ndim != 1:
            raise _Corrupt(f"header entry of shape {list(raw.shape)}")
        header = json.loads(raw.tobytes().decode("utf-8"))
        fshape, lshape, pshape = _check_header(path, header)
        arrays = []
        for key, shape, dtype in (("features", fshape, np.float64), ("labels_packed", pshape, np.uint8)):
            i = info[f"{key}.npy"]
            nbytes = math.prod(shape) * np.dtype(dtype).itemsize
            if not 0 < i.file_size - nbytes <= _MAX_NPY_HEADER:
                raise _Corrupt(f"entry {key} holds {i.file_size} bytes; an array of shape {list(shape)} needs {nbytes} and a header")
            arrays.append(_parse_npy(_read_entry(zf, i), key, shape, dtype))
    X, P = arrays
    digest = hashlib.sha256(memoryview(np.ascontiguousarray(X)).cast("B"))
    digest.update(memoryview(np.ascontiguousarray(P)).cast("B"))
    if digest.hexdigest() != header["sha256"]:
        raise DatasetError(f"dataset file {path} is corrupt (SHA-256 of its arrays does not match its header)")
    N = lshape[1]
    if N % 8 and P.size and np.any(P[:, -1] & ((1 << (8 - N % 8)) - 1)):
        raise _Corrupt("padding bits of the packed labels are set")
    try:
        spec = DatasetSpec.from_dict(header["spec"])
    except Exception as e:  # noqa: BLE001 -- any invalid spec dict
        raise DatasetError(f"dataset file {path} holds an invalid spec ({e})") from None
    if (spec.samples, spec.n_features, spec.n_nodes) != (lshape[0], fshape[1], N):
        raise DatasetError(
            f"dataset file {path} is corrupt (its spec has {spec.samples} samples x {spec.n_features} features x "
            f"{spec.n_nodes} nodes; its arrays {lshape[0]} x {fshape[1]} x {N})"
        )
    return Dataset(spec=spec, features=X, labels_packed=P, header=header, path=path)


def load_dataset(path: PathLike, expect_spec: DatasetSpec | None = None) -> Dataset:
    """Read a dataset written by `build_dataset`, checking it (see the module docstring).

    Raises `FileNotFoundError` for a missing file, `OSError` when the file cannot be opened
    (permissions), and `DatasetError` (a `ValueError`) for anything wrong with its
    contents: a directory, a truncated or foreign file, a corrupt one (any flipped byte the data
    depends on: zip CRC, deflate stream, .npy header, JSON header, SHA-256), and, when
    `expect_spec` is given, a file built for another spec; every message names the path.
    """
    if expect_spec is not None:
        check_spec(expect_spec)
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"dataset file {path} does not exist")
    if path.is_dir():
        raise DatasetError(f"dataset file {path} is a directory, not a dataset file")
    with open(path, "rb") as fh:  # an OSError here (permission denied) names the path already
        try:
            ds = _read(path, fh)
        except DatasetError:
            raise
        except EOFError as e:
            raise DatasetError(f"dataset file {path} is truncated or not a dataset file ({e or 'end of file'})") from None
        except _Corrupt as e:
            raise DatasetError(f"dataset file {path} is corrupt ({e})") from None
        except Exception as e:  # noqa: BLE001 -- zip, zlib, .npy, JSON, UTF-8: every other way a byte can be wrong
            raise DatasetError(f"dataset file {path} is corrupt ({type(e).__name__}{': ' if str(e) else ''}{e})") from None
    if expect_spec is not None:
        diff = _spec_diff(ds.spec.to_dict(), expect_spec.to_dict())
        if diff:
            raise DatasetError(f"dataset file {path} was built for a different spec ({'; '.join(diff)}); rebuild it")
    return ds


def load_dataset_files(train_path: PathLike, test_path: PathLike | None = None) -> tuple[Dataset, Dataset]:
    """A training set and its test set (default `test_path_for` `(train_path)`), checked:
    the test set must be the training spec's test stream (same family, grid, orientation and
    labels; `test_spec`)."""
    train_path = Path(train_path)
    test_path = test_path_for(train_path) if test_path is None else Path(test_path)
    train, test = load_dataset(train_path), load_dataset(test_path)
    try:
        expected = test_spec(train.spec, len(test))
    except ValueError as e:
        raise DatasetError(f"{train_path} is not a training set ({e})") from None
    diff = _spec_diff(test.spec.to_dict(), expected.to_dict())
    if diff:
        raise DatasetError(f"{test_path} is not the test set of {train_path} ({'; '.join(diff)}); rebuild both")
    return train, test
