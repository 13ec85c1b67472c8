"""Dataset files: every corruption is a DatasetError; building training and test files is all or nothing."""

import io
import json
import os
import re
import struct
import zipfile

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from wsmap import datasets
from wsmap import io as wio
from wsmap.datasets import store
from wsmap.paper.specs import PAPER_SPECS as P


def small(key, n, **changes):
    return datasets.scaled(P[key], n).replace(**changes)


# --------------------------------------------------------------------------- corrupt files
@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """A small dataset file (the `good_file` of test_data.py: 30 arms, 125 nodes), its bytes and contents."""
    path = tmp_path_factory.mktemp("ref") / "good.npz"
    spec = small("table1_r3_step05", 30)
    datasets.build_dataset(spec, path, progress=False)
    ds = datasets.load_dataset(path)
    return spec, path.read_bytes(), ds.features.copy(), ds.labels.copy()


def _outcome(path, reference):
    """'error' for a DatasetError naming the path, 'same' for a load identical to the reference;
    anything else (another exception, different data) fails the test."""
    spec, _, X, L = reference
    try:
        ds = datasets.load_dataset(path)
    except datasets.DatasetError as e:
        assert str(path) in str(e)
        return "error"
    assert ds.spec == spec
    np.testing.assert_array_equal(ds.features, X)
    np.testing.assert_array_equal(ds.labels, L)
    return "same"


def _flip(raw, offset, xor):
    b = bytearray(raw)
    b[offset] ^= xor
    return bytes(b)


def _data_start(raw, info):
    """Offset of an entry's compressed data: after its local header, name and extra field."""
    n, m = struct.unpack("<HH", raw[info.header_offset + 26 : info.header_offset + 30])
    return info.header_offset + 30 + n + m


def _central_directory(raw, name):
    """Offset of the central-directory record of entry ``name``."""
    pos = 0
    while True:
        pos = raw.index(b"PK\x01\x02", pos)
        n = struct.unpack("<H", raw[pos + 28 : pos + 30])[0]
        if raw[pos + 46 : pos + 46 + n] == name.encode():
            return pos
        pos += 4


def test_flip_in_the_npy_header_is_a_dataset_error(reference, tmp_path):
    # byte 173, bit 3: inside the deflate stream of features.npy; it still inflates, to a garbled
    # .npy header, and numpy's header parser raised tokenize.TokenError (before the zip CRC was checked)
    raw = reference[1]
    info = zipfile.ZipFile(io.BytesIO(raw)).getinfo("features.npy")
    assert _data_start(raw, info) <= 173 < _data_start(raw, info) + info.compress_size
    path = tmp_path / "flipped.npz"
    path.write_bytes(_flip(raw, 173, 0x08))
    with pytest.raises(datasets.DatasetError, match=re.escape(f"dataset file {path} is corrupt")):
        datasets.load_dataset(path)


@pytest.mark.parametrize(
    "field, offset, xor",
    [
        ("version needed to extract", 6, 0xFF),  # was NotImplementedError: zip file version 21.0
        ("flags: encrypted", 8, 0x01),  # was RuntimeError: ... is encrypted, password required
        ("compression method", 10, 0x08),  # deflate (8) -> stored (0): raw deflate bytes as data
        ("compression method", 10, 0x04),  # 12 (bzip2)
        ("CRC-32", 16, 0x01),
        ("uncompressed size", 24, 0x01),
    ],
)
@pytest.mark.parametrize("entry", ["features.npy", "labels_packed.npy", "header.npy"])
def test_flip_in_the_central_directory_is_a_dataset_error(reference, tmp_path, entry, field, offset, xor):
    raw = reference[1]
    pos = _central_directory(raw, entry)
    path = tmp_path / "flipped.npz"
    path.write_bytes(_flip(raw, pos + offset, xor))
    assert _outcome(path, reference) == "error", field


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_any_flipped_byte_is_an_error_or_harmless(reference, tmp_path, data):
    raw = reference[1]
    offset = data.draw(st.integers(0, len(raw) - 1), label="offset")
    xor = data.draw(st.integers(1, 255), label="xor")
    path = tmp_path / "flipped.npz"
    path.write_bytes(_flip(raw, offset, xor))
    _outcome(path, reference)  # never another exception, never different data


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_any_truncation_is_an_error(reference, tmp_path, data):
    raw = reference[1]
    n = data.draw(st.integers(0, len(raw) - 1), label="length")
    path = tmp_path / "truncated.npz"
    path.write_bytes(raw[:n])
    assert _outcome(path, reference) == "error"


def _rewrite(src, dst, change):
    """Copy dataset ``src`` to ``dst`` as a well-formed zip after ``change(arrays, header)``."""
    with np.load(src) as z:
        arrays = {k: z[k].copy() for k in z.files}
    header = json.loads(arrays["header"].tobytes())
    change(arrays, header)
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    np.savez_compressed(dst, **arrays)
    return dst


def _rehash(arrays, header):
    header["sha256"] = store.hashlib.sha256(arrays["features"].tobytes() + arrays["labels_packed"].tobytes()).hexdigest()


@pytest.mark.parametrize(
    "what, change, message",
    [
        ("header field missing", lambda a, h: h.pop("features_shape"), "header field features_shape is None"),
        ("header shape not a list", lambda a, h: h.update(labels_shape="30x125"), "header field labels_shape"),
        ("header not an object", lambda a, h: (h.clear(), h.update({"format": "wsmap-dataset", "format_version": 1})),
         "header field features_shape"),
        ("newer format", lambda a, h: h.update(format_version=2), "has format version 2"),
        ("foreign format", lambda a, h: h.update(format="other"), "is not a wsmap dataset (header format 'other')"),
        ("bad digest", lambda a, h: h.update(sha256="x"), "header field sha256"),
        ("spec not a dict", lambda a, h: h.update(spec=[1]), "holds no spec"),
        ("invalid spec", lambda a, h: h["spec"].update(step=-1), "holds an invalid spec"),
        ("spec for other sizes", lambda a, h: h["spec"].update(samples=31), "its spec has 31 samples"),
        ("labels of a wrong dtype", lambda a, h: a.update(labels_packed=a["labels_packed"].astype(np.int16)),
         "entry labels_packed has dtype int16, expected uint8"),
        ("padding bits set", lambda a, h: (a["labels_packed"].__setitem__((0, -1), a["labels_packed"][0, -1] | 1),
                                           _rehash(a, h)), "padding bits"),
        ("features transposed", lambda a, h: a.update(features=np.asfortranarray(a["features"])), "not a C-order"),
    ],
)
def test_tampered_files_are_dataset_errors(reference, tmp_path, what, change, message):
    good = tmp_path / "good.npz"
    good.write_bytes(reference[1])
    bad = _rewrite(good, tmp_path / "bad.npz", change)
    with pytest.raises(datasets.DatasetError, match=re.escape(f"dataset file {bad} ")) as e:
        datasets.load_dataset(bad)
    assert message in str(e.value), what


def test_extra_or_missing_entries(reference, tmp_path):
    good = tmp_path / "good.npz"
    good.write_bytes(reference[1])
    with zipfile.ZipFile(good, "a") as zf:
        zf.writestr("extra.npy", b"hello")
    with pytest.raises(datasets.DatasetError, match="unexpected entries"):
        datasets.load_dataset(good)


def test_load_bad_arguments(reference, tmp_path):
    with pytest.raises(datasets.DatasetError, match=re.escape(f"dataset file {tmp_path} is a directory")):
        datasets.load_dataset(tmp_path)
    good = tmp_path / "good.npz"
    good.write_bytes(reference[1])
    with pytest.raises(TypeError, match="spec must be a DatasetSpec, got str"):
        datasets.load_dataset(good, expect_spec="table1_r3_step05")
    empty = tmp_path / "empty.npz"
    empty.write_bytes(b"")
    with pytest.raises(datasets.DatasetError, match=re.escape(f"dataset file {empty} is truncated or not a dataset file")):
        datasets.load_dataset(empty)


def test_loaded_arrays_are_writable(reference, tmp_path):
    good = tmp_path / "good.npz"
    good.write_bytes(reference[1])
    ds = datasets.load_dataset(good)
    assert ds.features.flags.writeable and ds.labels_packed.flags.writeable
    assert ds.features.flags.c_contiguous and ds.features.dtype == np.float64


# --------------------------------------------------------------------------- build_dataset_files
SPEC = small("table1_r3_step1", 4)


def _listing(d):
    return sorted(p.name for p in d.iterdir())


def test_build_files_writes_both(tmp_path):
    out = tmp_path / "t.npz"
    written = datasets.build_dataset_files(SPEC, out, test_samples=3, progress=False)
    assert written == [out, tmp_path / "t.test.npz"] and _listing(tmp_path) == ["t.npz", "t.test.npz"]
    train, test = datasets.load_dataset_files(out)
    assert (len(train), len(test)) == (4, 3) and test.spec == datasets.test_spec(SPEC, 3)
    # only the training file; only a test file (test_only: `samples` arms, default 1000 -> here 2)
    assert datasets.build_dataset_files(SPEC, tmp_path / "u.npz", progress=False) == [tmp_path / "u.npz"]
    assert datasets.build_dataset_files(SPEC, tmp_path / "v.npz", samples=2, test_only=True, progress=False) == [tmp_path / "v.npz"]
    assert datasets.load_dataset(tmp_path / "v.npz").spec == datasets.test_spec(SPEC, 2)
    # by name, in a catalogue; a test set at a path of one's own
    written = datasets.build_dataset_files("table1_r3_step1", tmp_path / "w.npz", samples=2, test_out=tmp_path / "w_t.npz",
                                    catalogue=P, progress=False)
    assert written == [tmp_path / "w.npz", tmp_path / "w_t.npz"] and len(datasets.load_dataset(written[1])) == 1000


@pytest.mark.parametrize(
    "kwargs, error, message",
    [
        # the old CLI: `--samples 0` ended in a traceback
        (dict(samples=0), ValueError, "samples must be at least 1, got 0"),
        (dict(samples=-5), ValueError, "samples must be at least 1, got -5"),
        (dict(samples=2.5), ValueError, "samples must be an integer, got 2.5"),
        (dict(samples=True), ValueError, "samples must be an integer, got True"),
        (dict(samples="10"), ValueError, "samples must be an integer, got '10'"),
        # the old CLI: `--test-samples 0` left the training file behind
        (dict(test_samples=0), ValueError, "test_samples must be at least 1, got 0"),
        (dict(test_samples=-1), ValueError, "test_samples must be at least 1, got -1"),
        # the old CLI: `--test --test-samples N` wrote a file, then failed
        (dict(test_only=True, test_samples=5), ValueError, "test_only builds only a test set"),
        (dict(test_only=True, test_out="x.npz"), ValueError, "test_only builds only a test set"),
        (dict(test_only="yes"), ValueError, "test_only must be True or False"),
        (dict(chunk=0), ValueError, "chunk must be at least 1, got 0"),
    ],
)
def test_build_files_refuses_bad_counts_before_any_work(tmp_path, monkeypatch, kwargs, error, message):
    monkeypatch.setattr(store, "_write_dataset", lambda *a, **k: pytest.fail("work started"))
    with pytest.raises(error, match=re.escape(message)):
        datasets.build_dataset_files(SPEC, tmp_path / "t.npz", progress=False, **kwargs)
    assert _listing(tmp_path) == []


def test_build_files_refuses_bad_specs_and_names(tmp_path):
    with pytest.raises(ValueError, match=re.escape("unknown dataset 'sec99'; choose one of sec61, sec62")):
        datasets.build_dataset_files("sec99", tmp_path / "t.npz", catalogue=P)
    with pytest.raises(ValueError, match="needs a catalogue"):
        datasets.build_dataset_files("sec61", tmp_path / "t.npz")
    with pytest.raises(TypeError, match="spec must be a DatasetSpec, got int"):
        datasets.build_dataset_files(61, tmp_path / "t.npz")
    with pytest.raises(ValueError, match="already a test spec"):
        datasets.build_dataset_files(datasets.test_spec(SPEC), tmp_path / "t.npz", test_samples=3)
    assert _listing(tmp_path) == []


@pytest.mark.parametrize(
    "out, test_out, message",
    [
        ("", None, "dataset path is empty"),
        (".", None, "is a directory"),
        ("adir", None, "is a directory"),
        ("adir/", None, "is a directory"),
        ("afile/t.npz", None, "is not a directory"),
        ("t.npz", "adir", "test set path"),
        ("t.npz", "t.npz", "would both be written to"),
        ("t.npz", "./sub/../t.npz", "would both be written to"),
        ("t.npz", "link.npz", "would both be written to"),
        ("tdir.npz", None, "is a directory"),  # the default test path tdir.test.npz is fine, but out is not
        ("t2.npz", None, "test set path"),  # out is fine, its default test path t2.test.npz is a directory
    ],
)
def test_build_files_refuses_bad_paths_before_any_work(tmp_path, monkeypatch, out, test_out, message):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "adir").mkdir()
    (tmp_path / "sub").mkdir()
    (tmp_path / "tdir.npz").mkdir()
    (tmp_path / "t2.test.npz").mkdir()
    (tmp_path / "afile").write_text("x")
    os.symlink(tmp_path / "t.npz", tmp_path / "link.npz")
    before = _listing(tmp_path)
    monkeypatch.setattr(store, "_write_dataset", lambda *a, **k: pytest.fail("work started"))
    with pytest.raises(wio.OutputPathError, match=re.escape(message)):
        datasets.build_dataset_files(SPEC, out, test_samples=2, test_out=test_out, progress=False)
    assert _listing(tmp_path) == before


def test_build_files_refuses_an_unwritable_folder(tmp_path, monkeypatch):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    if os.geteuid() == 0:  # root writes anywhere: make the permission check see what a user would
        real = os.access
        monkeypatch.setattr(os, "access", lambda p, mode, **k: False if str(p) == str(ro) else real(p, mode, **k))
    try:
        with pytest.raises(wio.OutputPathError, match=re.escape(f"no permission to write in {str(ro)!r}")):
            datasets.build_dataset_files(SPEC, ro / "t.npz", test_samples=2, progress=False)
    finally:
        ro.chmod(0o700)


def test_build_files_creates_missing_folders(tmp_path):
    # the project's rule (wsmap.io.check_output_path): missing folders are created, on success only
    out = tmp_path / "new" / "deeper" / "t.npz"
    datasets.build_dataset_files(SPEC, out, test_samples=2, progress=False)
    assert _listing(out.parent) == ["t.npz", "t.test.npz"]


@pytest.mark.parametrize("fail_on", ["train", "test"])
def test_build_files_is_all_or_nothing(tmp_path, monkeypatch, fail_on):
    out, test_out = tmp_path / "t.npz", tmp_path / "t.test.npz"
    out.write_bytes(b"old training file")
    test_out.write_bytes(b"old test file")
    real = store.labels_for

    def failing(arms, spec, *a, **k):
        if spec.stream == fail_on:
            raise RuntimeError("labelling failed")
        return real(arms, spec, *a, **k)

    monkeypatch.setattr(store, "labels_for", failing)
    with pytest.raises(RuntimeError, match="labelling failed"):
        datasets.build_dataset_files(SPEC, out, test_samples=2, progress=False)
    assert out.read_bytes() == b"old training file" and test_out.read_bytes() == b"old test file"
    assert _listing(tmp_path) == ["t.npz", "t.test.npz"]  # no temporary files left


def test_build_files_interrupted_leaves_nothing(tmp_path, monkeypatch):
    def interrupt(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(store, "labels_for", interrupt)
    with pytest.raises(KeyboardInterrupt):
        datasets.build_dataset_files(SPEC, tmp_path / "t.npz", test_samples=2, progress=False)
    assert _listing(tmp_path) == []


def test_os_errors_name_the_users_path(tmp_path, monkeypatch):
    out = tmp_path / "t.npz"

    def disk_full(spec, tmp, *a):
        raise OSError(28, "No space left on device", str(tmp))

    monkeypatch.setattr(store, "_write_dataset", disk_full)
    with pytest.raises(OSError) as e:
        datasets.build_dataset_files(SPEC, out, test_samples=2, progress=False)
    assert str(out) in str(e.value) and "No space left on device" in str(e.value)
    assert ".t.npz." not in str(e.value)  # not the temporary file
    assert _listing(tmp_path) == []
    monkeypatch.undo()

    # permission denied creating the temporary file (simulated: root may write anywhere), after the
    # output check's probe file passed (a folder that turns read-only during the run)
    real_mkstemp = wio.tempfile.mkstemp

    def denied(*a, dir=None, **k):
        if k.get("prefix", "").startswith(".wsmap-probe-"):
            return real_mkstemp(*a, dir=dir, **k)
        raise PermissionError(13, "Permission denied", os.path.join(dir, ".t.npz.abc123.npz"))

    monkeypatch.setattr(wio.tempfile, "mkstemp", denied)
    with pytest.raises(PermissionError) as e:
        datasets.build_dataset_files(SPEC, out, progress=False)
    assert str(out) in str(e.value) and "abc123" not in str(e.value)


def test_build_dataset_checks_its_path_before_work(tmp_path, monkeypatch):
    monkeypatch.setattr(store, "_write_dataset", lambda *a, **k: pytest.fail("work started"))
    for bad in ("", tmp_path):
        with pytest.raises(wio.OutputPathError):
            datasets.build_dataset(SPEC, bad, progress=False)
    with pytest.raises(ValueError, match="chunk must be at least 1"):
        datasets.build_dataset(SPEC, tmp_path / "t.npz", chunk=0)
    with pytest.raises(TypeError, match="spec must be a DatasetSpec"):
        datasets.build_dataset("sec61", tmp_path / "t.npz")
    assert _listing(tmp_path) == []


def test_load_dataset_files_checks_the_pair(tmp_path):
    datasets.build_dataset_files(SPEC, tmp_path / "a.npz", test_samples=2, progress=False)
    datasets.build_dataset_files(SPEC.replace(seed=SPEC.seed + 1), tmp_path / "b.npz", test_samples=2, progress=False)
    with pytest.raises(datasets.DatasetError, match=re.escape(f"{tmp_path / 'b.test.npz'} is not the test set of {tmp_path / 'a.npz'}")):
        datasets.load_dataset_files(tmp_path / "a.npz", tmp_path / "b.test.npz")
    with pytest.raises(datasets.DatasetError, match="is not a training set"):
        datasets.load_dataset_files(tmp_path / "a.test.npz", tmp_path / "b.test.npz")


# --------------------------------------------------------------------------- the Dask cluster (issue 29)
def test_cluster_sizes_and_timeouts_are_bounded(tmp_path):
    spec = small("table1_r3_step05", 2)
    cores = store._cores()
    with pytest.raises(ValueError, match=rf"^workers must be at most {4 * cores} \(4 per core of the {cores} here\)"):
        datasets.build_dataset(spec, tmp_path / "d.npz", workers=4 * cores + 1, progress=False)
    with pytest.raises(ValueError, match=r"^connect_timeout must be at most 3600 s .* got 1e\+308$"):
        datasets.build_dataset(spec, tmp_path / "d.npz", scheduler="tcp://127.0.0.1:1", connect_timeout=1e308)
    assert list(tmp_path.iterdir()) == []


def test_a_bad_scheduler_address_is_named_and_its_half_built_client_closed(tmp_path, monkeypatch):
    import gc
    import sys

    spec = small("table1_r3_step05", 2)
    unraisable = []
    monkeypatch.setattr(sys, "unraisablehook", unraisable.append)
    for address in ("tcp://", "http://x", "tcp://[::1", "inproc://nothing"):
        with pytest.raises(datasets.SchedulerError,
                           match=rf"^{re.escape(repr(address))} is not a Dask scheduler address this machine can use"):
            datasets.build_dataset(spec, tmp_path / "d.npz", scheduler=address, connect_timeout=1, progress=False)
    gc.collect()  # a Client left half built would print "Exception ignored in: Client.__del__" here
    assert unraisable == []
    assert list(tmp_path.iterdir()) == []
