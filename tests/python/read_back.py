"""Independent readers for files the project writes: PyPI `aedat` (iniVation AEDAT 4.0) and
NumPy (.npy in Tonic's layout). Usage: read_back.py EXPECTED.csv FILE...

Each FILE must hold exactly the events of EXPECTED.csv (t_us,x,y,p). Exits non-zero otherwise.
"""
import sys

import numpy as np


def expected(path):
    rows = np.loadtxt(path, delimiter=",", comments="#", skiprows=1, dtype=np.int64, ndmin=2)
    return rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3]


def read_aedat(path):
    import aedat

    decoder = aedat.Decoder(path)
    streams = decoder.id_to_stream()
    chunks = [p["events"] for p in decoder if "events" in p]
    e = np.concatenate(chunks) if chunks else np.zeros(0, dtype=[("t", "<u8"), ("x", "<u2"), ("y", "<u2"), ("on", "?")])
    return streams, (e["t"].astype(np.int64), e["x"].astype(np.int64), e["y"].astype(np.int64), e["on"].astype(np.int64))


def read_npy(path):
    e = np.load(path)
    assert set(e.dtype.names) >= {"x", "y", "t", "p"}, e.dtype
    return e.dtype, (e["t"].astype(np.int64), e["x"].astype(np.int64), e["y"].astype(np.int64), e["p"].astype(np.int64))


def main():
    want = expected(sys.argv[1])
    for path in sys.argv[2:]:
        meta, got = read_aedat(path) if path.endswith(".aedat4") else read_npy(path)
        for name, a, b in zip("t x y p".split(), want, got):
            if len(a) != len(b) or not np.array_equal(a, b):
                sys.exit(f"{path}: field {name} differs from {sys.argv[1]} ({len(b)} events read, {len(a)} expected)")
        print(f"{path}: {len(want[0])} events identical ({meta})")


if __name__ == "__main__":
    main()
