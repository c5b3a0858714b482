"""Event files and Tonic's arrays: round trips through every format, foreign dtypes, chunks, and
bad input named by file and place."""

import numpy as np
import pytest

import neurobraille


def sample_events(n=5000, seed=3, width=64, height=48):
    rng = np.random.default_rng(seed)
    ev = np.empty(n, dtype=neurobraille.EVENTS_DTYPE)
    ev["t"] = np.sort(rng.integers(0, 2_000_000, n))
    ev["x"] = rng.integers(0, width, n)
    ev["y"] = rng.integers(0, height, n)
    ev["p"] = rng.integers(0, 2, n)
    return ev


def test_dtype_is_tonics_fields():
    assert neurobraille.EVENTS_DTYPE.names == ("x", "y", "t", "p")
    assert neurobraille.EVENTS_DTYPE.itemsize == 13
    assert neurobraille.EVENTS_DTYPE["t"] == np.dtype("<i8")


@pytest.mark.parametrize("ext", ["npy", "csv", "aedat4"])
def test_round_trip_through_every_format(tmp_path, ext):
    ev = sample_events()
    path = tmp_path / f"events.{ext}"
    assert neurobraille.write_events(path, ev, resolution=(64, 48)) == len(ev)
    back = neurobraille.read_events(path)
    assert back.dtype == neurobraille.EVENTS_DTYPE
    np.testing.assert_array_equal(back, ev)
    info = neurobraille.event_file_info(path)
    assert info["format"] == ext
    if ext != "npy":
        assert info["resolution"] == {"width": 64, "height": 48}


def test_tonic_layouts_are_read_by_field_name(tmp_path):
    ev = sample_events(1000)
    # Tonic's datasets use int64 fields; others put t first and store p as bool
    tonic = np.empty(len(ev), dtype=[("x", "<i8"), ("y", "<i8"), ("t", "<i8"), ("p", "<i8")])
    other = np.empty(len(ev), dtype=[("t", "<u8"), ("x", "<i2"), ("y", "<i2"), ("p", "?")])
    for a in (tonic, other):
        for f in "xytp":
            a[f] = ev[f]
        path = tmp_path / "foreign.npy"
        np.save(path, a)
        np.testing.assert_array_equal(neurobraille.read_events(path), ev)
        # and taken from memory
        neurobraille.write_events(tmp_path / "mine.npy", a, overwrite=True)
        np.testing.assert_array_equal(np.load(tmp_path / "mine.npy"), ev)


def test_written_npy_is_plain_numpy(tmp_path):
    ev = sample_events(100)
    neurobraille.write_events(tmp_path / "e.npy", ev)
    loaded = np.load(tmp_path / "e.npy")
    assert loaded.dtype == neurobraille.EVENTS_DTYPE
    np.testing.assert_array_equal(loaded, ev)


def test_chunks_cover_the_file_in_order(tmp_path):
    ev = sample_events(20_000)
    path = tmp_path / "e.aedat4"
    neurobraille.write_events(path, ev, resolution=(64, 48))
    reader = neurobraille.iter_events(path, chunk_events=3000)
    assert reader.info["resolution"] == {"width": 64, "height": 48}
    chunks = list(reader)
    assert [len(c) for c in chunks[:-1]] == [3000] * (len(chunks) - 1)
    np.testing.assert_array_equal(np.concatenate(chunks), ev)


def test_existing_files_are_kept_unless_overwrite(tmp_path):
    ev = sample_events(10)
    path = tmp_path / "e.csv"
    neurobraille.write_events(path, ev)
    with pytest.raises(FileExistsError, match="e.csv"):
        neurobraille.write_events(path, ev[:5])
    assert len(neurobraille.read_events(path)) == 10
    neurobraille.write_events(path, ev[:5], overwrite=True)
    assert len(neurobraille.read_events(path)) == 5


def test_bad_files_name_the_file_and_place(tmp_path):
    with pytest.raises(FileNotFoundError, match="missing.aedat4"):
        neurobraille.read_events(tmp_path / "missing.aedat4")
    bad = tmp_path / "bad.csv"
    bad.write_text("t_us,x,y,p\n10,1,2,1\n5,1,2,0\n")
    with pytest.raises(neurobraille.BrailleError, match=r"bad.csv.*line 3"):
        neurobraille.read_events(bad)
    truncated = tmp_path / "cut.aedat4"
    neurobraille.write_events(truncated, sample_events(5000), resolution=(64, 48))
    data = truncated.read_bytes()
    truncated.write_bytes(data[: len(data) // 2])
    with pytest.raises(neurobraille.BrailleError, match="cut.aedat4"):
        neurobraille.read_events(truncated)
    with pytest.raises(neurobraille.BrailleError, match=r"bad.csv"):
        neurobraille.read_events(bad, resolution=(1, 1))


def test_bad_arrays_name_the_event():
    ev = sample_events(10)
    ev["t"][7] = 0
    with pytest.raises(neurobraille.BrailleError, match=r"events\[7\]"):
        neurobraille.write_events("/tmp/never.npy", ev)
    with pytest.raises(TypeError, match="structured array"):
        neurobraille.write_events("/tmp/never.npy", np.zeros(4))
    with pytest.raises(ValueError, match='no field "p"'):
        neurobraille.write_events("/tmp/never.npy", np.zeros(4, dtype=[("x", "i8"), ("y", "i8"), ("t", "i8")]))
    with pytest.raises(neurobraille.BrailleError, match=r"events\[1\].*outside"):
        a = np.zeros(3, dtype=[("x", "i8"), ("y", "i8"), ("t", "i8"), ("p", "i8")])
        a["x"][1] = -1
        neurobraille.write_events("/tmp/never.npy", a)
    with pytest.raises(ValueError, match="resolution"):
        neurobraille.read_events("/tmp/never.npy", resolution=(0, 3))
