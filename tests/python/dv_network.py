"""Both ends of DV's AEDAT 4.0 network stream, through iniVation's own dv-processing (PyPI), to
cross-check `braille replay` and `braille read/convert tcp://HOST:PORT` (tests/interop.rs).

    dv_network.py send PORT EVENTS.csv     serve the events (t_us,x,y,p) on 127.0.0.1:PORT to
                                           the first client, in packets of 500, then close
    dv_network.py receive HOST:PORT N OUT.csv  read a stream until N events (or its end) and
                                               write its events
"""
import os
import sys
import time

import dv_processing as dv
import numpy as np


def load(path):
    a = np.loadtxt(path, delimiter=",", skiprows=1, dtype=np.int64, ndmin=2)
    return a[:, 0], a[:, 1], a[:, 2], a[:, 3]


def send(port, csv, width=346, height=260):
    t, x, y, p = load(csv)
    stream = dv.io.Stream.EventStream(0, "events", "dv-processing", (width, height))
    writer = dv.io.NetworkWriter("127.0.0.1", port, stream)
    print("listening", flush=True)
    deadline = time.time() + 20
    while writer.getClientCount() == 0:
        if time.time() > deadline:
            sys.exit("no client connected within 20 s")
        time.sleep(0.01)
    for start in range(0, len(t), 500):
        store = dv.EventStore()
        for k in range(start, min(start + 500, len(t))):
            store.push_back(int(t[k]), int(x[k]), int(y[k]), bool(p[k]))
        writer.writeEvents(store)
    while writer.getQueuedPacketCount() > 0:
        time.sleep(0.01)
    time.sleep(0.2)
    print(f"sent {len(t)} events", flush=True)
    # dv-processing 2.0.4's NetworkWriter does not return from its destructor once its client has
    # closed the connection; leave without running it
    os._exit(0)


def receive(address, expected, out):
    host, port = address.rsplit(":", 1)
    reader = dv.io.NetworkReader(host, int(port))
    rows = []
    while len(rows) < expected:
        running = reader.isRunning()
        batch = reader.getNextEventBatch()
        if batch is None:
            if not running:
                break
            time.sleep(0.001)
            continue
        for e in batch:
            rows.append((e.timestamp(), e.x(), e.y(), int(e.polarity())))
    with open(out, "w") as f:
        f.write("t_us,x,y,p\n")
        for r in rows:
            f.write(f"{r[0]},{r[1]},{r[2]},{r[3]}\n")
    print(f"received {len(rows)} events, resolution {reader.getEventResolution()}", flush=True)


if __name__ == "__main__":
    if sys.argv[1] == "send":
        send(int(sys.argv[2]), sys.argv[3])
    else:
        receive(sys.argv[2], int(sys.argv[3]), sys.argv[4])
