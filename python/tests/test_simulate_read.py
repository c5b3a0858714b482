"""The virtual Evetac and the reader from Python: a simulated row (SIMULATED data) read whole and
incrementally, by both architectures, and bad input."""

import numpy as np
import pytest

import neurobraille
from conftest import ROOT

SPEED = 16.0


@pytest.fixture(scope="module")
def scan():
    return neurobraille.simulate(board="text:LEFT OPEN", row=0, speed_mm_s=SPEED, seed=7)


def test_simulation_is_seeded_and_carries_its_truth(scan):
    assert scan.text == "LEFT OPEN"
    assert scan.events.dtype == neurobraille.EVENTS_DTYPE and len(scan.events) > 100_000
    assert np.all(np.diff(scan.events["t"]) >= 0)
    assert scan.resolution == (640, 480)
    assert scan.truth["row_text"] == "LEFT OPEN"
    assert len(scan.truth["characters"]) == len("LEFT OPEN")
    assert scan.truth["scan"]["speed_mm_s"] == SPEED
    small = dict(board="text:AB", row=0, speed_mm_s=32.0, resolution=(160, 120))
    a, b = neurobraille.simulate(seed=1, **small), neurobraille.simulate(seed=1, **small)
    np.testing.assert_array_equal(a.events, b.events)
    c = neurobraille.simulate(seed=2, **small)
    assert len(c.events) != len(a.events) or not np.array_equal(c.events, a.events)


@pytest.mark.parametrize("arch", ["snn", "resnet"])
def test_reader_reads_a_simulated_row_whole_and_in_chunks(scan, arch):
    reader = neurobraille.Reader(arch=arch, spell="none")
    whole = reader.read(scan.events)
    # the reader gets the events only: nothing of the truth, not the speed
    assert [w.text for w in whole] == ["LEFT", "OPEN"], whole
    stream = reader.stream()
    chunked = []
    for chunk in np.array_split(scan.events, 37):
        chunked += stream.push(chunk)
    assert stream.speed_mm_s is not None
    chunked += stream.finish()
    assert [(w.text, w.t_start_us, w.t_end_us) for w in chunked] == [(w.text, w.t_start_us, w.t_end_us) for w in whole]
    assert all(len(w.confidences) == len(w.raw) for w in whole)
    # both words are read as words, neither marked unreadable
    assert not any(w.unreadable for w in whole)
    assert whole[0].details["text"] == "LEFT"
    with pytest.raises(neurobraille.BrailleError, match="finished"):
        stream.push(scan.events[:10])


def test_the_exportable_reader_reads_in_loihi_2s_arithmetic(scan):
    """Both SNNs (the reset-to-zero twins) on Loihi 2's arithmetic, as `eval words --chip loihi2`;
    a ResNet runs on no chip, and Xylo cannot hold a window."""
    twins = ROOT / "models" / "nominal" / "nir"
    files = dict(segmenter=twins / "snn-segment.safetensors", classifier=twins / "snn-words.safetensors")
    reader = neurobraille.Reader(spell="none", chip="loihi2", **files)
    assert [w.text for w in reader.read(scan.events)] == ["LEFT", "OPEN"]
    with pytest.raises(neurobraille.BrailleError, match="ResNet"):
        neurobraille.Reader(arch="resnet", chip="loihi2")
    with pytest.raises(neurobraille.BrailleError, match="snn-segment.safetensors.*Xylo"):
        neurobraille.Reader(chip="xylo", **files)
    with pytest.raises(ValueError, match="chip"):
        neurobraille.Reader(chip="truenorth")


def test_a_ueb_reader_reads_cells_back_to_print():
    # "The children" in contracted UEB, printed as its cells
    cells = neurobraille.simulate(board="text:⠠⠮ ⠡⠝", row=0, speed_mm_s=SPEED, seed=7)
    reader = neurobraille.Reader(braille="ueb-g2")
    assert reader.braille == "ueb-g2"
    words = reader.read(cells.events)
    assert words, "a word read"
    assert all(all("\u2801" <= c <= "\u283f" for c in w.raw) for w in words)
    assert " ".join(w.text for w in words) != " ".join(w.raw for w in words), "print, not cells"
    with pytest.raises(ValueError, match="one of grade1-letters, ueb-g1, ueb-g2"):
        neurobraille.Reader(braille="ueb-g3")


def test_reader_refuses_bad_streams_and_models(scan, tmp_path):
    reader = neurobraille.Reader(spell="none", timing="given", speed_mm_s=SPEED)
    stream = reader.stream()
    stream.push(scan.events[1000:2000])
    with pytest.raises(neurobraille.BrailleError, match="chunk from event 1000"):
        stream.push(scan.events[:10])
    with pytest.raises(ValueError, match="needs a speed"):
        neurobraille.Reader(timing="given")
    with pytest.raises(ValueError, match="one of snn, resnet"):
        neurobraille.Reader(arch="transformer")
    with pytest.raises(FileNotFoundError, match="nowhere"):
        neurobraille.Reader(models_dir=tmp_path / "nowhere")
    with pytest.raises(neurobraille.BrailleError, match="not a character classifier of 26 letters or 63 cells"):
        neurobraille.Reader(classifier=ROOT / "models" / "clean" / "snn-segment.safetensors")
    with pytest.raises(ValueError, match="board"):
        neurobraille.simulate(board="text:")
    with pytest.raises(neurobraille.BrailleError, match="row 3"):
        neurobraille.simulate(board="text:AB", row=3)
