"""Hostile inputs of issue 41 that ended in a raw error (numpy, h5py, OverflowError, RecursionError,
an allocation after the work had started): each is now one line, before any work."""

import os
import re
import tracemalloc

import numpy as np
import pytest

from wsmap import load
from wsmap.workspace import grids, orientation_samples, reachability_index
from wsmap.workspace.orientations import continuation_bytes, continuation_order, rotation_angle


def test_the_grid_peak_is_what_the_memory_check_counts():
    axes = grids.grid_axes(-1, 1, 0.013)
    zz, yy, xx = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    reference = np.stack([xx.ravel(), yy.ravel(), zz.ravel()], axis=-1)
    del zz, yy, xx
    tracemalloc.start()
    nodes = grids.cartesian_grid(-1, 1, 0.013)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    np.testing.assert_array_equal(nodes, reference)
    assert peak < 1.02 * 24 * len(nodes)  # the 24 N bytes grid_axes counts (meshgrid and stack took 48 N)


def test_the_continuation_order_by_blocks_is_the_whole_matrix_order():
    R = orientation_samples(700)  # two blocks of rows
    d = rotation_angle(R[:, None], R[None, :])
    order, parent, left, best, near = [0], [-1], np.ones(700, bool), d[0].copy(), np.zeros(700, np.int64)
    left[0] = False
    for _ in range(699):
        j = int(np.argmin(np.where(left, best, np.inf)))
        order.append(j)
        parent.append(int(near[j]))
        left[j] = False
        near, best = np.where(d[j] < best, j, near), np.minimum(best, d[j])
    o, p = continuation_order(R)
    np.testing.assert_array_equal(o, order)
    np.testing.assert_array_equal(p, parent)


def test_an_index_whose_orientation_matrix_does_not_fit_is_refused_before_any_work(monkeypatch):
    monkeypatch.setattr(grids, "available_memory", lambda: 4 * 2**30)
    R = orientation_samples(20000)  # 3.2 GB of angles: once "Unable to allocate" after the positions' search
    assert continuation_bytes(20000) > 2 * 2**30
    with pytest.raises(MemoryError, match="an index of 1 nodes x 20000 orientations needs .* use fewer orientations"):
        reachability_index(load("panda"), np.array([[0.3, 0.0, 0.3]]), R, method="numerical",
                           progress=lambda n: pytest.fail("work started"))


def _h5(path, spheres=None, poses=None, sphere_shape=None, sphere_dtype="f8"):
    h5py = pytest.importorskip("h5py")
    with h5py.File(path, "w") as f:
        if sphere_shape is not None:  # declared, never written: a few kB of file
            s = f.create_dataset("/Spheres/sphere_dataset", shape=sphere_shape, dtype="f8")
        else:
            s = f.create_dataset("/Spheres/sphere_dataset", data=spheres if spheres is not None
                                 else np.array([[0.2, 0, 0, 50.0]]), dtype=sphere_dtype)
        s.attrs["Resolution"] = np.float32(0.1)
        f.create_dataset("/Poses/poses_dataset", dtype="f4", data=poses if poses is not None
                         else np.array([[0.2, 0, 0, 0.2, 0, 0, 0, 0, 0, 1]]))
    return path


@pytest.mark.parametrize("kw, message", [
    (dict(sphere_shape=(2_000_000_000, 4)), "/Spheres/sphere_dataset of shape (2000000000, 4) needs 59.60 GiB"),
    (dict(spheres=np.array([[b"a", b"b", b"c", b"d"]]), sphere_dtype="S1"), "holds byte strings, not numbers"),
    (dict(spheres=np.zeros(1, dtype=[("a", "f8"), ("b", "f8")]), sphere_dtype=[("a", "f8"), ("b", "f8")]),
     "holds compound records, not numbers"),
    (dict(poses=np.array([[0.2, 0, 0, 0.2, 0, 0, 0, 0, 0, 0]])), "pose 0 has norm 0): not rotations"),
])
def test_a_hostile_reuleaux_file_is_one_reuleaux_file_error(tmp_path, monkeypatch, kw, message):
    from wsmap.workspace import load_reuleaux
    from wsmap.workspace.reuleaux import ReuleauxFileError

    monkeypatch.setattr(grids, "available_memory", lambda: 16 * 2**30)  # the same on a larger machine
    path = _h5(tmp_path / "r.h5", **kw)
    assert path.stat().st_size < 20_000
    with pytest.raises(ReuleauxFileError, match=re.escape(message)) as err:
        load_reuleaux(path)
    assert "\n" not in str(err.value)


def _npz_with_header(path, good, member, header):
    """`good`'s members, with `member` replaced by a .npy of `header` and 100 bytes of data."""
    import zipfile

    with zipfile.ZipFile(good) as zin, zipfile.ZipFile(path, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == member + ".npy":
                header = header + " " * (118 - len(header)) + "\n"
                data = b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header.encode() + b"\0" * 100
            zout.writestr(item, data)
    return path


def test_npz_headers_and_json_text_are_checked_before_numpy_and_json_read_them(tmp_path):
    from wsmap.safe_load import ConfigError, check_npz, loads_json

    good = tmp_path / "good.npz"
    np.savez(good, map=np.zeros(27, bool), grid='{"a": 1}')
    assert check_npz(good, text=("grid",)) == {"map": ((27,), np.dtype(bool)), "grid": ((), np.dtype("<U8"))}
    huge = _npz_with_header(tmp_path / "huge.npz", good, "map",
                            "{'descr': '|b1', 'fortran_order': False, 'shape': (1000000000000,), }")
    with pytest.raises(ConfigError, match=r"member 'map' declares \(1000000000000,\) bool values \(1000000000000 bytes\) "
                                          "but holds 100 bytes"):
        check_npz(huge, text=("grid",))
    for bad, message in ((dict(map=np.array(["a"] * 27)), "member 'map' holds strings, not numbers"),
                         (dict(map=np.zeros(2, dtype=[("a", "f8")])), "member 'map' holds compound records"),
                         (dict(map=np.zeros(2), grid=np.array([1, 2])), "member 'grid' must be one string, got (2,)")):
        np.savez(tmp_path / "bad.npz", **{"grid": "{}", **bad})
        with pytest.raises(ConfigError, match=re.escape(message)):
            check_npz(tmp_path / "bad.npz", text=("grid",))
    assert loads_json('{"qlim": [[-Infinity, Infinity]], "n": 7}') == {"qlim": [[-np.inf, np.inf]], "n": 7}
    for text, message in (("[" * 100000 + "]" * 100000, "nested deeper than 32 levels"),  # was RecursionError
                          ('{"a": ' * 100000 + "1" + "}" * 100000, "nested deeper than 32 levels"),
                          ('{"lo": [' + "9" * 400 + "]}", "an integer of 400 digits"),
                          ('{"lo": [1,', "not valid JSON")):
        with pytest.raises(ConfigError, match=re.escape(message)):
            loads_json(text)


@pytest.mark.parametrize("payload, message", [
    ({"format": list(range(100000))}, "format tag [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 1... (a list) is not"),
    ({"format": "FORMAT", "version": 10**400}, "format version an integer of about 401 digits is not supported"),
])
def test_a_model_file_names_a_bad_tag_in_one_short_line(tmp_path, payload, message):
    torch = pytest.importorskip("torch")
    from wsmap.learn.files import FORMAT, ModelFileError, load

    payload = {k: (FORMAT if v == "FORMAT" else v) for k, v in payload.items()}
    torch.save(payload, tmp_path / "m.pt")
    with pytest.raises(ModelFileError, match=re.escape(message)) as err:
        load(tmp_path / "m.pt")
    assert len(str(err.value)) < 300  # the list's repr made a 700 kB line


@pytest.mark.parametrize("text", ["inf", "-inf", "1e308", "nan", "-5", "\xff\xfe", "9" * 10**6])
def test_a_hostile_compile_estimate_file_gives_the_default(tmp_path, monkeypatch, text):
    from wsmap.kinematics import lm_compiled

    monkeypatch.setattr(lm_compiled, "cache_dir", lambda: str(tmp_path))
    (tmp_path / lm_compiled._ESTIMATE_FILE).write_bytes(text.encode("latin-1"))
    assert lm_compiled.estimate() == lm_compiled.COLD_COMPILE_SECONDS  # inf was an OverflowError
    (tmp_path / lm_compiled._ESTIMATE_FILE).write_text("12.4\n")
    assert lm_compiled.estimate() == 12


def test_a_full_disk_names_the_output(tmp_path):
    from wsmap.io import atomic_path

    out = tmp_path / "m.npz"
    out.write_text("old")
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    with pytest.raises(OSError, match=re.escape(f"No space left on device (writing {out})")) as err:
        with atomic_path(out):
            with open("/dev/full", "w") as f:  # every write: ENOSPC, with no file name, as a full disk's
                f.write("x" * 100000)
                f.flush()
    assert err.value.errno == 28 and out.read_text() == "old" and os.listdir(tmp_path) == ["m.npz"]


def test_sighup_leaves_no_temporary_file_and_no_new_output(tmp_path):
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "m.npz"
    p = subprocess.Popen([sys.executable, "-m", "wsmap", "map", "--scope", "SO3", "--step", "pi/80",
                          "--method", "numerical", "--out", str(out)], stderr=subprocess.PIPE, text=True, bufsize=1)
    seen, t0 = "", time.monotonic()
    while "numerical map" not in seen and time.monotonic() - t0 < 300:  # the progress bar is up
        c = p.stderr.read(1)
        if not c:
            break
        seen += c
    p.send_signal(signal.SIGHUP)  # the terminal closed: its default ended the process on the spot
    err = seen + p.communicate(timeout=60)[1]
    assert p.returncode == 130 and "interrupted" in err and "Traceback" not in err, err
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("where", ["origin", "limit", "name"])
def test_a_20_mb_urdf_attribute_is_a_short_line(tmp_path, capsys, where):
    from wsmap import cli

    big = "0 " * 10_000_000
    origin, lower, jname = (big, "-1", "j") if where == "origin" else (("0 0 0.1", big, "j") if where == "limit"
                                                                        else ("0 0 0.1", "-1", big))
    (tmp_path / "a.urdf").write_text(
        f'<robot name="r"><link name="a"/><link name="b"/><joint name="{jname}" type="revolute"><parent link="a"/>'
        f'<child link="b"/><origin xyz="{origin}"/><axis xyz="0 0 1"/>'
        f'<limit lower="{lower}" upper="1" effort="1" velocity="1"/></joint>'
        + (f'<joint name="{jname}" type="fixed"><parent link="a"/><child link="b"/></joint>' if where == "name" else "")
        + '</robot>')
    assert cli.main(["map", "--urdf", str(tmp_path / "a.urdf"), "--out", str(tmp_path / "o.npz")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("wsmap: error: ") and err.count("\n") == 1 and len(err) < 400, err[:400]
    assert "(20000000 characters)" in err


def test_a_hostile_map_file_is_one_map_file_error(tmp_path):
    import json

    from wsmap.workspace import MapFileError, load_map, save_map

    grid = {"scope": "R3", "lo": [-1] * 3, "hi": [1] * 3, "step": [1] * 3, "shape": [3, 3, 3]}
    save_map(tmp_path / "ok.npz", np.zeros(27, bool), grid, {"kind": "constant", "qlim": [[-np.inf, np.inf]]})
    assert load_map(tmp_path / "ok.npz")[3]["qlim"] == [[-np.inf, np.inf]]  # json.dumps' Infinity still reads

    def variant(name, **members):
        z = dict(np.load(tmp_path / "ok.npz", allow_pickle=False))
        z.update(members)
        np.savez(tmp_path / name, **z)
        return tmp_path / name

    cases = [
        (_npz_with_header(tmp_path / "huge.npz", tmp_path / "ok.npz", "map",
                          "{'descr': '|b1', 'fortran_order': False, 'shape': (1000000000000,), }"),
         "member 'map' declares (1000000000000,) bool values"),  # was numpy's "Unable to allocate 931 GiB"
        (variant("deep.npz", grid="[" * 100000 + "]" * 100000), "nested deeper than 32 levels"),  # RecursionError
        (variant("deep2.npz", settings='{"a":' * 100000 + "1" + "}" * 100000), "nested deeper than 32 levels"),
        (variant("sn.npz", nodes=np.array([["a", "b", "c"]] * 27)), "member 'nodes' holds strings"),  # UFuncTypeError
        (variant("cn.npz", nodes=np.zeros((27, 3), dtype=[("a", "f8")])), "member 'nodes' holds compound records"),
        (variant("big.npz", grid=json.dumps({**grid, "lo": [10**400, 0, 0]})), "an integer of 401 digits"),
    ]
    for path, message in cases:
        with pytest.raises(MapFileError, match=re.escape(message)) as err:
            load_map(path)
        assert "\n" not in str(err.value) and str(path) in str(err.value)
