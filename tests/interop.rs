//! Files written by `braille convert` read back exactly in independent decoders: PyPI `aedat`
//! (AEDAT 4.0) and NumPy (.npy). Needs Python with `aedat` and `numpy`; `.ci/run` installs them.
//! Without them the test is skipped, except under CI (`CI` set), where it fails.

use std::path::Path;
use std::process::Command;

#[test]
fn independent_decoders_read_back_exactly_what_was_written() {
    let python = std::env::var("PYTHON").unwrap_or_else(|_| "python3".into());
    let available =
        Command::new(&python).args(["-c", "import aedat, numpy"]).output().is_ok_and(|o| o.status.success());
    if !available {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must have python3 with aedat and numpy (pip install aedat numpy)"
        );
        eprintln!("skipped: {python} with aedat and numpy not found");
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = root.join("tests/fixtures/davis346_dv.aedat4");
    let expected = root.join("tests/fixtures/davis346_dv.expected.csv");
    let dir = tempfile::tempdir().unwrap();
    let mut outputs = Vec::new();
    for (name, compression) in
        [("lz4.aedat4", "lz4"), ("zstd.aedat4", "zstd"), ("none.aedat4", "none"), ("events.npy", "lz4")]
    {
        let out = dir.path().join(name);
        let o = Command::new(env!("CARGO_BIN_EXE_braille"))
            .args([
                "convert",
                src.to_str().unwrap(),
                out.to_str().unwrap(),
                "--compression",
                compression,
                "--packet-events",
                "1000",
            ])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        outputs.push(out);
    }
    let o = Command::new(&python)
        .arg(root.join("tests/python/read_back.py"))
        .arg(&expected)
        .args(&outputs)
        .output()
        .unwrap();
    let (out, err) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "{out}\n{err}");
    assert_eq!(out.matches("3576 events identical").count(), 4, "{out}");
    eprintln!("{out}");
}

/// DV's network stream both ways with iniVation's own dv-processing (PyPI): its `NetworkReader`
/// reads what `braille replay` serves, and `braille convert tcp://HOST:PORT` records what its
/// `NetworkWriter` serves, event for event. Skipped without dv-processing, except under CI.
#[test]
fn live_streams_pass_both_ways_between_braille_and_dv_processing() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let python = std::env::var("PYTHON").unwrap_or_else(|_| "python3".into());
    let available =
        Command::new(&python).args(["-c", "import dv_processing, numpy"]).output().is_ok_and(|o| o.status.success());
    if !available {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must have python3 with dv-processing (pip install dv-processing)"
        );
        eprintln!("skipped: {python} with dv_processing not found");
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = root.join("tests/fixtures/davis346_dv.aedat4");
    let expected = std::fs::read_to_string(root.join("tests/fixtures/davis346_dv.expected.csv")).unwrap();
    let script = root.join("tests/python/dv_network.py");
    let dir = tempfile::tempdir().unwrap();

    // braille serves, dv-processing reads (at the recorded pace; the connection kept open until
    // the reader has every event and closes)
    let mut replay = Command::new(env!("CARGO_BIN_EXE_braille"))
        .args(["replay", src.to_str().unwrap(), "--listen", "127.0.0.1:0", "--linger-s", "20"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = String::new();
    BufReader::new(replay.stderr.take().unwrap()).read_line(&mut first).unwrap();
    let address = first.trim().rsplit("tcp://").next().unwrap().to_string();
    let received = dir.path().join("received.csv");
    let o = Command::new(&python)
        .arg(&script)
        .args(["receive", &address, "3576", received.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("resolution (346, 260)"));
    assert_eq!(std::fs::read_to_string(&received).unwrap(), expected, "dv-processing read what braille served");
    assert!(replay.wait().unwrap().success());

    // dv-processing serves, braille records
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let mut sender = Command::new(&python)
        .arg(&script)
        .args(["send", &port.to_string(), root.join("tests/fixtures/davis346_dv.expected.csv").to_str().unwrap()])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(sender.stdout.as_mut().unwrap()).read_line(&mut line).unwrap();
    assert_eq!(line.trim(), "listening");
    let recorded = dir.path().join("recorded.csv");
    let o = Command::new(env!("CARGO_BIN_EXE_braille"))
        .args(["convert", &format!("tcp://127.0.0.1:{port}"), recorded.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(sender.wait().unwrap().success());
    let got = std::fs::read_to_string(&recorded).unwrap();
    // the CSV writer puts the declared resolution first
    assert_eq!(got, format!("# resolution: 346x260\n{expected}"), "braille recorded what dv-processing served");
}
