import pytest
from gaitcap.acquisition.fileio import atomic_write_text


def test_writes_and_replaces(tmp_path):
    path = atomic_write_text(tmp_path / "sub" / "a.txt", "one")
    assert path.read_text() == "one"
    atomic_write_text(path, "two")
    assert path.read_text() == "two" and sorted(p.name for p in path.parent.iterdir()) == ["a.txt"]


def test_failure_keeps_the_old_file_and_leaves_no_temp(tmp_path):
    path = atomic_write_text(tmp_path / "a.txt", "old")

    with pytest.raises(TypeError):
        atomic_write_text(path, 123)  # not text: the write fails midway
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]


def test_atomic_path_keeps_the_suffix_and_cleans_up_on_error(tmp_path):
    import numpy as np
    from gaitcap.acquisition.fileio import atomic_path, atomic_write_bytes

    target = tmp_path / "r.npz"
    with atomic_path(target, fsync=True) as tmp:
        assert tmp.suffix == ".npz" and tmp.parent == tmp_path and not target.exists()
        np.savez(tmp, a=np.arange(3))
    assert np.load(target)["a"].tolist() == [0, 1, 2]
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_bytes(b"half")
        raise RuntimeError("killed midway")
    assert np.load(target)["a"].tolist() == [0, 1, 2] and [p.name for p in tmp_path.iterdir()] == ["r.npz"]
    assert atomic_write_bytes(tmp_path / "b.bin", b"\x00\x01").read_bytes() == b"\x00\x01"


def test_atomic_savez_round_trips_and_keeps_the_old_file_on_error(tmp_path):
    import numpy as np
    from gaitcap.acquisition.fileio import atomic_savez

    path = atomic_savez(tmp_path / "a.npz", x=np.arange(4.0), names=np.array(["l", "r"]))
    with np.load(path) as data:
        assert data["x"].tolist() == [0.0, 1.0, 2.0, 3.0] and data["names"].tolist() == ["l", "r"]
    with pytest.raises(TypeError):
        atomic_savez(path, file=np.arange(2))  # a name np.savez refuses: the write fails
    with np.load(path) as data:
        assert data["x"].shape == (4,) and [p.name for p in tmp_path.iterdir()] == ["a.npz"]
