"""Neuromorphic Braille reading from event-based touch, from Python.

The Rust engine of the ``braille`` project, in process (the distribution and module are called
``neurobraille``: PyPI's ``braille`` is an unrelated package; the command line stays ``braille``):

* event files (AEDAT 4.0, CSV, NumPy) as NumPy structured arrays with Tonic's fields
  ``x, y, t, p`` (:data:`EVENTS_DTYPE`), whole or in chunks;
* networks (a model file, a NIR graph from snnTorch, Norse or ``braille export``) on the
  event-driven engine, one sample or a batch in parallel with the GIL released, and NIR export
  with chips' rules;
* the virtual Evetac: a simulated scan of a Braille board row (SIMULATED data) with its truth;
* the word reader, on a whole array or incrementally;
* a lab's recordings folder (a manifest and event files): checked, its scans and their events.

Errors of the Rust library arrive as :class:`BrailleError` (or ``FileNotFoundError``,
``FileExistsError``, ``OSError`` when a file operation failed) with the library's message, which
names the file or array and the place.
"""

from ._braille import (
    EVENTS_DTYPE,
    BrailleError,
    EventFileReader,
    Network,
    Reader,
    Recording,
    Recordings,
    RunResult,
    Scan,
    Word,
    WordStream,
    __version__,
    event_file_info,
    iter_events,
    peer_benchmark,
    read_events,
    simulate,
    write_events,
)

__all__ = [
    "EVENTS_DTYPE",
    "BrailleError",
    "EventFileReader",
    "Network",
    "Reader",
    "Recording",
    "Recordings",
    "RunResult",
    "Scan",
    "Word",
    "WordStream",
    "__version__",
    "event_file_info",
    "iter_events",
    "peer_benchmark",
    "read_events",
    "simulate",
    "write_events",
]
