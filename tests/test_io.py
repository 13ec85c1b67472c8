"""Atomic writes: a reader sees the old file or the new one, never half of one."""

import os
import stat

import pytest

from wsmap.io import atomic_path


def test_success_replaces_and_leaves_no_temporary(tmp_path):
    target = tmp_path / "sub" / "table.csv"
    with atomic_path(target) as tmp:
        assert tmp.parent == target.parent and tmp.suffix == ".csv" and tmp != target
        tmp.write_text("new")
    assert target.read_text() == "new"
    assert os.listdir(target.parent) == ["table.csv"]


def test_failure_keeps_the_old_file(tmp_path):
    target = tmp_path / "data.npz"
    target.write_text("old")
    with pytest.raises(RuntimeError, match="interrupted"):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("interrupted")
    assert target.read_text() == "old"
    assert os.listdir(tmp_path) == ["data.npz"]


def test_written_file_gets_the_usual_mode(tmp_path):
    old = os.umask(0o022)
    try:
        with atomic_path(tmp_path / "m.pt") as tmp:
            tmp.write_bytes(b"x")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "m.pt").stat().st_mode) == 0o644


def test_outputs_of_one_run_appear_together_or_not_at_all(tmp_path, monkeypatch):
    from wsmap import io

    a, b = tmp_path / "map.npz", tmp_path / "map.png"
    a.write_text("old map")
    real_replace = os.replace

    def failing_replace(src, dst):
        if str(dst) == str(b):
            raise OSError(28, "No space left on device")
        return real_replace(src, dst)

    monkeypatch.setattr(io.os, "replace", failing_replace)
    with pytest.raises(OSError, match="cannot write .*map.png.*No space left"):
        with io.atomic_paths([a, b]) as (ta, tb):
            ta.write_text("new map")
            tb.write_text("new png")
    # the first rename had happened: it is undone
    assert a.read_text() == "old map"
    assert sorted(os.listdir(tmp_path)) == ["map.npz"]


def test_a_new_first_output_is_removed_when_the_second_fails(tmp_path, monkeypatch):
    from wsmap import io

    a, b = tmp_path / "new.npz", tmp_path / "new.png"
    real_replace = os.replace
    monkeypatch.setattr(io.os, "replace", lambda s, d: (_ for _ in ()).throw(OSError(13, "Permission denied"))
                        if str(d) == str(b) else real_replace(s, d))
    with pytest.raises(OSError):
        with io.atomic_paths([a, b]) as (ta, tb):
            ta.write_text("x")
            tb.write_text("y")
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("bad, message", [("", "is empty"), (".", "is a directory"), ("d/", "is a directory")])
def test_check_output_path(tmp_path, monkeypatch, bad, message):
    from wsmap.io import OutputPathError, check_output_path

    monkeypatch.chdir(tmp_path)
    with pytest.raises(OutputPathError, match=message):
        check_output_path(bad, "--out")
    assert check_output_path("new/sub/file.npz", "--out").name == "file.npz"
    assert os.listdir(tmp_path) == []  # checking creates nothing


def test_sigterm_leaves_no_temporary_file_and_no_new_output(tmp_path):
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "m.npz"
    # a numerical SO3 map on a fine grid runs for a while; terminate it once its progress bar shows
    p = subprocess.Popen([sys.executable, "-m", "wsmap", "map", "--scope", "SO3", "--step", "pi/80",
                          "--method", "numerical", "--out", str(out)],
                         stderr=subprocess.PIPE, text=True, bufsize=1)
    seen = ""
    t0 = time.monotonic()
    # the progress bar's first line (after a compile, when the kernel's cache is cold)
    while "numerical map" not in seen and time.monotonic() - t0 < 300:
        c = p.stderr.read(1)
        if not c:
            break
        seen += c
    p.send_signal(signal.SIGTERM)
    err = seen + p.communicate(timeout=60)[1]
    assert p.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    assert os.listdir(tmp_path) == []


# ------------------------------------------------------------------ check_outputs: real files, not inputs, writable
def test_check_outputs_compares_real_files_and_refuses_an_input(tmp_path):
    from wsmap.io import OutputPathError, check_outputs

    (tmp_path / "real").mkdir()
    (tmp_path / "alias").symlink_to(tmp_path / "real")
    with pytest.raises(OutputPathError, match=r"^--out '.*real/m.npz' and --html '.*alias/m.npz' are the same file"):
        check_outputs({"--out": tmp_path / "real" / "m.npz", "--html": tmp_path / "alias" / "m.npz"})
    (tmp_path / "a.npz").write_text("x")
    os.link(tmp_path / "a.npz", tmp_path / "b.npz")  # two names of one inode
    with pytest.raises(OutputPathError, match="are the same file"):
        check_outputs({"--out": tmp_path / "a.npz", "--png": tmp_path / "b.npz"})
    arm = tmp_path / "arm.urdf"
    arm.write_text("<robot/>")
    with pytest.raises(OutputPathError, match=r"^--out '.*arm.urdf' is the input --urdf '.*arm.urdf': writing it"):
        check_outputs({"--out": tmp_path / "alias" / ".." / "arm.urdf"}, inputs={"--urdf": arm, "--model": None})
    got = check_outputs({"--out": tmp_path / "m.npz", "--png": None, "--html": tmp_path / "new" / "m.html"},
                        inputs={"--urdf": arm})
    assert got == {"--out": tmp_path / "m.npz", "--html": tmp_path / "new" / "m.html"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.npz", "alias", "arm.urdf", "b.npz", "real"]


def test_writability_is_tested_by_writing_not_by_os_access(tmp_path, monkeypatch):
    from wsmap import io
    from wsmap.io import OutputPathError, check_output_path

    # root passes os.access on a read-only folder: only creating a file tells
    monkeypatch.setattr(io.os, "access", lambda *a, **k: True)
    real = io.tempfile.mkstemp

    def refuse(*a, dir=None, **k):
        if str(dir) == str(tmp_path / "ro"):
            raise PermissionError(13, "Permission denied")
        return real(*a, dir=dir, **k)

    (tmp_path / "ro").mkdir()
    monkeypatch.setattr(io.tempfile, "mkstemp", refuse)
    with pytest.raises(OutputPathError, match=r"^--out path '.*ro/m.npz': no permission to write in '.*ro' "
                                              r"\(Permission denied\)$"):
        check_output_path(tmp_path / "ro" / "m.npz", "--out")
    assert check_output_path(tmp_path / "m.npz", "--out") == tmp_path / "m.npz"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ro"]  # the probe is removed


def test_atomic_paths_refuses_two_names_of_one_file(tmp_path):
    from wsmap.io import OutputPathError, atomic_paths

    (tmp_path / "real").mkdir()
    (tmp_path / "alias").symlink_to(tmp_path / "real")
    with pytest.raises(OutputPathError, match="share a path"):
        with atomic_paths([tmp_path / "real" / "m.npz", tmp_path / "alias" / "m.npz"]):
            pass


def test_read_text_names_a_binary_file_and_drops_a_bom_when_asked(tmp_path):
    from wsmap.io import read_text

    p = tmp_path / "f.txt"
    p.write_bytes("\ufeffx,y\n".encode("utf-8"))
    assert read_text(p, "f is", "hint", encoding="utf-8-sig") == "x,y\n"
    assert read_text(p, "f is", "hint").startswith("\ufeff")
    p.write_bytes(b"ab\xff")
    with pytest.raises(ValueError, match=r"^f is not a text file \(byte 2 is not UTF-8\); give text$"):
        read_text(p, "f is", "give text")
    p.write_bytes(b"a\x00b")
    with pytest.raises(ValueError, match=r"^--x f: not a text file \(it holds NUL bytes\); give text$"):
        read_text(p, "--x f:", "give text")
