"""Model files (wsmap.learn.files): the checksum, corrupt and foreign files, old files, OS errors."""

import os
import pickle
import warnings

import numpy as np
import pytest
import torch
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from wsmap import learn
from wsmap.learn.files import FORMAT_VERSION, ModelFileError, UnverifiedModelWarning, load, payload_checksum, save
from wsmap.learn.network import MLPConfig, SubspaceMLP

torch.set_num_threads(1)  # tiny models; the CPU is shared


def small_model(seed=0) -> SubspaceMLP:
    x = np.random.default_rng(seed).uniform(-1, 1, (20, 6))
    torch.manual_seed(seed)
    return SubspaceMLP(MLPConfig(n_inputs=6, n_outputs=3, hidden=[4])).configure(x)


def same_model(a: SubspaceMLP, b: SubspaceMLP) -> bool:
    sa, sb = a.state_dict(), b.state_dict()
    return (a.config == b.config and sa.keys() == sb.keys()
            and all(sa[k].dtype == sb[k].dtype and torch.equal(sa[k], sb[k]) for k in sa)
            and a.map_spec == b.map_spec and a.training_range == b.training_range)


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    model = small_model()
    path = save(model, tmp_path_factory.mktemp("files") / "m.pt", extra={"note": "x"})
    return model, path, path.read_bytes()


def flip(data: bytes, bit: int) -> bytes:
    b = bytearray(data)
    b[bit // 8] ^= 1 << (bit % 8)
    return bytes(b)


def test_round_trip_records_checksum_and_range(saved):
    model, path, _ = saved
    loaded, meta = load(path)
    assert same_model(loaded, model)
    assert meta["version"] == FORMAT_VERSION == 2
    payload = torch.load(path, weights_only=True)
    assert payload["checksum"] == meta["checksum"] == payload_checksum(payload)
    assert meta["training_range"] == model.training_range.to_dict()


def test_checksum_is_canonical_and_sensitive():
    p = {"a": 1, "b": [1.5, "x", None, True], "t": torch.arange(3.0)}
    q = {"t": torch.arange(3.0), "b": [1.5, "x", None, True], "a": 1}  # other key order
    assert payload_checksum(p) == payload_checksum(q) == payload_checksum({**p, "checksum": "whatever"})
    for changed in ({**p, "a": 2}, {**p, "a": 1.0}, {**p, "a": True}, {**p, "b": [1.5, "x", None, 1]},
                    {**p, "t": torch.arange(3.0).double()}, {**p, "t": torch.arange(3.0).reshape(3, 1)},
                    {**p, "t": torch.tensor([0.0, 1.0, 2.0000002])}, {**p, "c": None}):
        assert payload_checksum(changed) != payload_checksum(p)
    with pytest.raises(ValueError, match="unexpected content of type set"):
        payload_checksum({"a": {1, 2}})


def test_every_flipped_bit_of_the_weights_is_caught(saved, tmp_path):
    """Before the checksum, 197 of 200 single-bit flips in the weights loaded silently."""
    model, _, data = saved
    weights = model.weights[0].detach().numpy().tobytes()
    start = data.index(weights)
    bits = np.random.default_rng(0).choice(len(weights) * 8, size=200, replace=False)
    q = tmp_path / "f.pt"
    for bit in bits:
        q.write_bytes(flip(data, 8 * start + int(bit)))
        with pytest.raises(ModelFileError, match="checksum mismatch: the file is corrupt"):
            load(q)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_corruption_is_an_error_or_changes_nothing(saved, tmp_path, data):
    """Random bit flips and truncations: ModelFileError, or the very same model -- never a silently
    different one, never another exception."""
    model, _, raw = saved
    if data.draw(st.booleans(), label="truncate"):
        corrupt = raw[:data.draw(st.integers(0, len(raw) - 1), label="length")]
    else:
        bits = data.draw(st.lists(st.integers(0, len(raw) * 8 - 1), min_size=1, max_size=3, unique=True),
                         label="bits")
        corrupt = raw
        for bit in bits:
            corrupt = flip(corrupt, bit)
    q = tmp_path / "corrupt.pt"
    q.write_bytes(corrupt)
    try:
        loaded, meta = load(q)
    except ModelFileError as e:
        assert str(q) in str(e)
        return
    assert same_model(loaded, model)
    assert meta["extra"] == {"note": "x"}


def test_bad_paths_and_foreign_files(tmp_path, saved):
    _, _, data = saved
    cases = {
        "missing.pt": (None, "no such file"),
        "empty.pt": (b"", "the file is empty (0 bytes)"),
        "text.pt": (b"not a model\n", "not a wsmap model file (not a torch zip archive"),
        "half.pt": (data[: len(data) // 2], "not a readable torch file (truncated or corrupt)"),
    }
    for name, (content, message) in cases.items():
        p = tmp_path / name
        if content is not None:
            p.write_bytes(content)
        with pytest.raises(ModelFileError) as e:
            load(p)
        assert str(e.value).startswith(f"cannot load model {p}: {message}")
    with pytest.raises(ModelFileError, match="it is a directory, not a model file"):
        load(tmp_path)
    npz = tmp_path / "x.npz"
    np.savez(npz, a=np.zeros(3))
    with pytest.raises(ModelFileError, match="not a readable torch file"):
        load(npz)

    class Evil:
        def __reduce__(self):
            return (print, ("this must never run",))

    evil = tmp_path / "evil.pt"
    torch.save({"format": learn.FORMAT, "x": Evil()}, evil)  # a pickle that would run code
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ModelFileError, match="not a readable torch file"):
            load(evil)
    plain = tmp_path / "plain.pkl"
    plain.write_bytes(pickle.dumps({"format": learn.FORMAT}))
    with pytest.raises(ModelFileError, match="not a torch zip archive"):
        load(plain)
    with pytest.raises(TypeError, match="path must be a str or os.PathLike; got NoneType"):
        load(None)
    assert issubclass(ModelFileError, ValueError)


def test_unreadable_file_names_the_path(tmp_path, saved, monkeypatch):
    p = tmp_path / "locked.pt"
    p.write_bytes(saved[2])

    def refuse(self):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(type(p), "read_bytes", refuse)  # chmod 0 does not stop root
    with pytest.raises(ModelFileError, match=rf"cannot load model {p}: cannot read it \(Permission denied\)"):
        load(p)


def test_missing_or_bad_checksum(tmp_path, saved):
    payload = torch.load(saved[1], weights_only=True)
    p = tmp_path / "m.pt"
    torch.save({k: v for k, v in payload.items() if k != "checksum"}, p)
    with pytest.raises(ModelFileError, match="it has no valid checksum"):
        load(p)
    torch.save({**payload, "checksum": "sha256:" + "0" * 64}, p)
    with pytest.raises(ModelFileError, match="checksum mismatch"):
        load(p)
    torch.save({**payload, "extra": {"note": "y"}}, p)  # edited content, old checksum
    with pytest.raises(ModelFileError, match="checksum mismatch"):
        load(p)


def test_format_1_files_need_allow_unverified(tmp_path, saved):
    model, path, _ = saved
    payload = torch.load(path, weights_only=True)
    old = {k: v for k, v in payload.items() if k not in ("checksum", "training_range")}
    p = tmp_path / "v1.pt"
    torch.save({**old, "version": 1}, p)
    with pytest.raises(ModelFileError, match=r"format version 1\) without a checksum.*re-save it"):
        load(p)
    with pytest.warns(UnverifiedModelWarning, match="loaded anyway"):
        loaded, meta = load(p, allow_unverified=True)
    assert meta["version"] == 1 and meta["checksum"] is None and loaded.training_range is None
    assert torch.equal(loaded.weights[0], model.weights[0])
    # re-saved in the current format, with the training data it came from: verified again
    again = save(loaded, tmp_path / "v2.pt", training_data=model.training_range)
    assert load(again)[1]["version"] == 2


def test_save_refuses_bad_targets_naming_the_path(tmp_path):
    model = small_model()
    with pytest.raises(ModelFileError, match=rf"cannot save model to {tmp_path}: it is a directory"):
        save(model, tmp_path)
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(ModelFileError, match=rf"cannot save model to {f}/m.pt: {f} is a file, not a directory"):
        save(model, f / "m.pt")
    with pytest.raises(ModelFileError, match="the path is empty"):
        save(model, "")
    with pytest.raises(TypeError, match="save needs a SubspaceMLP; got Linear"):
        save(torch.nn.Linear(2, 2), tmp_path / "lin.pt")
    with pytest.raises(ValueError, match="training data has 5 features, the model expects 6"):
        save(model, tmp_path / "m.pt", training_data=np.zeros((3, 5)))
    with pytest.raises(ValueError, match="NaN"):
        save(model, tmp_path / "m.pt", training_data=np.full((3, 6), np.nan))
    assert sorted(os.listdir(tmp_path)) == ["file"]  # nothing half-written


def test_write_errors_name_the_users_path(tmp_path, monkeypatch):
    import errno

    def full_disk(obj, f, *args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", str(f))

    monkeypatch.setattr(torch, "save", full_disk)
    target = tmp_path / "sub" / "m.pt"
    with pytest.raises(OSError, match=rf"cannot save model to {target}: No space left on device") as e:
        save(small_model(), target)
    assert e.value.errno == errno.ENOSPC
    assert os.listdir(tmp_path / "sub") == []  # the temporary file is gone
