"""dv-processing's own background-activity filter over an event CSV, to cross-check
`encoders::denoise` event for event (tests/interop.rs).

    dv_denoise.py IN.csv OUT.csv WIDTH HEIGHT WINDOW_US

IN.csv: `t_us,x,y,p` rows (lines starting with `#` or `t_us` skipped); OUT.csv: the events
`dv.noise.BackgroundActivityNoiseFilter` keeps, in the same form, after a `t_us,x,y,p` header.
"""
import sys
from datetime import timedelta

import dv_processing as dv
import numpy as np

src, out = sys.argv[1], sys.argv[2]
width, height, window_us = (int(v) for v in sys.argv[3:6])
rows = [l for l in open(src).read().splitlines() if l and not l.startswith(("#", "t_us"))]
a = np.array([[int(v) for v in l.split(",")] for l in rows], dtype=np.int64).reshape(-1, 4)
store = dv.EventStore()
for t, x, y, p in a:
    store.push_back(int(t), int(x), int(y), bool(p))
noise = dv.noise.BackgroundActivityNoiseFilter((width, height), backgroundActivityDuration=timedelta(microseconds=window_us))
noise.accept(store)
kept = noise.generateEvents()
with open(out, "w") as f:
    f.write("t_us,x,y,p\n")
    for e in kept:
        f.write(f"{e.timestamp()},{e.x()},{e.y()},{int(e.polarity())}\n")
print(f"{len(a)} events in, {len(kept)} kept")
