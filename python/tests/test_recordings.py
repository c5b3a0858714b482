"""A lab's recordings folder from Python: the folder `braille simulate --recordings` writes (SIMULATED
scans kept as a lab keeps them), its lines and events, its summary equal to the command line's,
and a bad manifest refused by line and field."""

import json
import subprocess

import numpy as np
import pytest

import neurobraille


@pytest.fixture(scope="module")
def folder(cli, tmp_path_factory):
    d = tmp_path_factory.mktemp("lab") / "scans"
    for role, board in [("train", "text:HELLO WORLD"), ("test", "text:STOP HELP")]:
        subprocess.run(
            [cli, "simulate", "--board", board, "--speed", "32", "--depth", "1.0", "--trials", "1", "--seed", "3",
             "--out", str(d), "--recordings", role],
            check=True,
            capture_output=True,
        )
    return d


def test_a_folder_gives_its_lines_and_events(folder, cli):
    rec = neurobraille.Recordings(folder)
    assert len(rec) == 2 and "1 train" in repr(rec) and "1 test" in repr(rec)
    [test] = rec.scans("test")
    assert (test.role, test.text, test.speed_mm_s, test.depth_mm, test.line) == ("test", "STOP HELP", 32.0, 1.0, 3)
    ev = test.events()
    assert ev.dtype == neurobraille.EVENTS_DTYPE and len(ev) > 1000
    np.testing.assert_array_equal(ev, neurobraille.read_events(test.path))
    assert [r.file.name for r in rec.scans()] == ["00001.aedat4", "00002.aedat4"]
    # the summary is the command line's, field for field
    summary = rec.check()
    out = subprocess.run([cli, "recordings", "check", str(folder), "--json"], check=True, capture_output=True, text=True)
    assert summary == json.loads(out.stdout)
    assert [(r["role"], r["scans"]) for r in summary["roles"]] == [("train", 1), ("val", 0), ("test", 1)]
    with pytest.raises(ValueError, match="role"):
        rec.scans("training")


def test_a_bad_manifest_is_refused_by_line_and_field(folder, tmp_path):
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "00001.aedat4").write_bytes((folder / "00001.aedat4").read_bytes())
    (bad / "manifest.csv").write_text("file,role,text,speed_mm_s,depth_mm\n00001.aedat4,train,HELLO,fast,1\n")
    with pytest.raises(neurobraille.BrailleError, match=r"line 2: field `speed_mm_s`"):
        neurobraille.Recordings(bad)
