"""Type stubs of the native module (``neurobraille._braille``); see each function's docstring."""

import os
from pathlib import Path
from typing import Any, Iterator, Literal, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str

#: ``[('x', '<u2'), ('y', '<u2'), ('t', '<i8'), ('p', 'u1')]``: Tonic's fields, t in microseconds,
#: p 0 (OFF) or 1 (ON). Arrays taken in may have any integer fields named x, y, t, p.
EVENTS_DTYPE: np.dtype

Events = npt.NDArray[np.void]
PathLike = Union[str, os.PathLike]
SensorSize = Sequence[int]

class BrailleError(Exception):
    """An error of the braille library, with its message (naming the file or array and place)."""

def read_events(
    path: PathLike, resolution: Optional[SensorSize] = None, stream_id: Optional[int] = None
) -> Events:
    """Reads a whole event file (AEDAT 4.0, CSV or NumPy) into one array of EVENTS_DTYPE."""

def write_events(
    path: PathLike, events: Events, resolution: Optional[SensorSize] = None, overwrite: bool = False
) -> int:
    """Writes events in the format of the path's extension; returns the number written."""

def iter_events(
    path: PathLike,
    chunk_events: int = 65536,
    resolution: Optional[SensorSize] = None,
    stream_id: Optional[int] = None,
) -> EventFileReader:
    """Streams an event file in arrays of at most chunk_events events (bounded memory)."""

def event_file_info(path: PathLike, stream_id: Optional[int] = None) -> dict[str, Any]:
    """What an event file declares: format, resolution (or None), source (or None)."""

class EventFileReader(Iterator[Events]):
    @property
    def info(self) -> dict[str, Any]: ...
    @property
    def path(self) -> str: ...
    def __iter__(self) -> EventFileReader: ...
    def __next__(self) -> Events: ...

Mode = Literal["stepped", "async", "event-driven"]  # "event-driven" with chip= only

class RunResult:
    """One sample's run on the engine."""

    readout: npt.NDArray[np.float32]
    prediction: int
    label: str
    spikes_per_layer: list[int]
    synops: int
    input_events: int
    output_spikes: npt.NDArray[np.int64]
    latency_ns: Optional[npt.NDArray[np.uint64]]

class Network:
    """A spiking network on the event-driven engine, shared by every call and thread."""

    @staticmethod
    def load(
        path: PathLike, dt_us: int = 100, reset: Literal["to-v-reset", "subtract"] = "to-v-reset"
    ) -> Network: ...
    @property
    def source(self) -> Literal["model_file", "nir_graph", "builtin"]: ...
    @property
    def name(self) -> str: ...
    @property
    def dt_us(self) -> int: ...
    @property
    def n_inputs(self) -> int: ...
    @property
    def n_outputs(self) -> int: ...
    @property
    def input_shape(self) -> list[int]: ...
    @property
    def classes(self) -> list[str]: ...
    @property
    def readout(self) -> Literal["max-membrane", "spike-count"]: ...
    @property
    def spec(self) -> dict[str, Any]: ...
    def run(
        self,
        events: Events,
        mode: Mode = "stepped",
        sensor_size: Optional[SensorSize] = None,
        t_start_us: int = 0,
        t_end_us: Optional[int] = None,
        latency: bool = False,
        chip: Optional[Literal["xylo"]] = None,
        quantisation: Literal["global", "channel"] = "global",
    ) -> RunResult: ...
    def run_batch(
        self,
        samples: Sequence[Events],
        mode: Mode = "stepped",
        sensor_size: Optional[SensorSize] = None,
        t_start_us: int = 0,
        t_end_us: Optional[int] = None,
    ) -> list[RunResult]: ...
    def record(
        self, events: Events, sensor_size: Optional[SensorSize] = None, steps: Optional[int] = None
    ) -> dict[str, Any]: ...
    def check(self, target: str) -> None: ...
    def export(
        self,
        path: PathLike,
        target: str = "generic",
        convention: Literal["nir", "snntorch", "norse"] = "nir",
        subtract_as_reset: bool = False,
        overwrite: bool = False,
    ) -> float: ...

def peer_benchmark(samples: int = 64) -> tuple[Network, list[Events]]:
    """The peer benchmark's network and `samples` random samples (80 x 60 sensor, 20 steps of 1 ms)."""

class Scan:
    """A simulated scan (SIMULATED data): the events and the simulator's ground truth."""

    events: Events
    truth: dict[str, Any]
    text: str
    resolution: tuple[int, int]
    duration_s: float

def simulate(
    board: str = "EV",
    row: int = 0,
    speed_mm_s: float = 8.0,
    depth_mm: float = 1.5,
    seed: int = 0,
    trial: int = 0,
    board_seed: Optional[int] = None,
    sensor_seed: int = 1,
    realism: Literal["clean", "nominal", "harsh"] = "clean",
    direction: Literal["forward", "reverse"] = "forward",
    resolution: Optional[SensorSize] = None,
) -> Scan: ...

class Word:
    text: str
    raw: str
    t_start_us: int
    t_end_us: int
    confidences: list[float]
    unreadable: bool
    details: dict[str, Any]

class WordStream:
    def push(self, events: Events) -> list[Word]: ...
    def finish(self) -> list[Word]: ...
    @property
    def stats(self) -> dict[str, Any]: ...
    @property
    def speed_mm_s(self) -> Optional[float]: ...

class Reader:
    def __init__(
        self,
        arch: Literal["snn", "resnet"] = "snn",
        spell: Literal["lexicon", "textblob", "none"] = "lexicon",
        timing: Literal["estimated", "paper", "given"] = "estimated",
        speed_mm_s: Optional[float] = None,
        segmenter: Optional[PathLike] = None,
        classifier: Optional[PathLike] = None,
        runner: Literal["sliding", "engine"] = "sliding",
        models_dir: Optional[PathLike] = None,
    ) -> None: ...
    def read(self, events: Events, resolution: Optional[SensorSize] = None) -> list[Word]: ...
    def stream(self, resolution: Optional[SensorSize] = None) -> WordStream: ...
    @property
    def arch(self) -> str: ...
    @property
    def spell(self) -> str: ...
    @property
    def timing(self) -> dict[str, Any]: ...

class Recording:
    """One scan of a recordings folder: its manifest line (labels for training and scoring; a
    reader gets the events only)."""

    file: Path
    path: Path
    role: Literal["train", "val", "test"]
    text: str
    speed_mm_s: float
    depth_mm: float
    extra: dict[str, str]
    line: int

    def events(self) -> Events:
        """The scan's events, read whole."""

class Recordings:
    """A recordings folder (docs/recordings.md): the manifest, checked on opening."""

    def __init__(self, dir: PathLike) -> None: ...
    @property
    def dir(self) -> Path: ...
    def scans(self, role: Optional[Literal["train", "val", "test"]] = None) -> list[Recording]:
        """The scans of `role`, or all, in the manifest's order."""
    def check(self) -> dict[str, Any]:
        """Reads every event file through; the summary `braille recordings check --json` prints."""
    def __len__(self) -> int: ...

