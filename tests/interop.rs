//! Files written by `braille convert` read back exactly in independent decoders: PyPI `aedat`
//! (AEDAT 4.0) and NumPy (.npy). Needs Python with `aedat` and `numpy`; `.ci/run` installs them.
//! Without them the test is skipped, except under CI (`CI` set), where it fails.

use std::path::Path;
use std::process::Command;

/// The Python with `modules`, or `None` (the test skipped) where it is missing, except under CI
/// (`CI` set), where a missing one fails.
fn python_with(modules: &str, pip: &str) -> Option<String> {
    let python = std::env::var("PYTHON").unwrap_or_else(|_| "python3".into());
    let import = format!("import {modules}");
    if Command::new(&python).args(["-c", &import]).output().is_ok_and(|o| o.status.success()) {
        return Some(python);
    }
    assert!(std::env::var_os("CI").is_none(), "CI must have python3 with {modules} (pip install {pip})");
    eprintln!("skipped: {python} with {modules} not found");
    None
}

#[test]
fn independent_decoders_read_back_exactly_what_was_written() {
    let Some(python) = python_with("aedat, numpy", "aedat numpy") else { return };
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
    let Some(python) = python_with("dv_processing, numpy", "dv-processing") else { return };
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

/// The background-activity filter (`encoders::denoise`, `braille convert --denoise`) against
/// iniVation's own, dv-processing's `noise.BackgroundActivityNoiseFilter`, with the same settings
/// on the same streams, event for event: DV's recording of a DAVIS346 and a `harsh` simulated
/// Evetac scan (its timestamps moved 1000 s on, past the window in which dv-processing's
/// zero-initialised map supports every event: `encoders::denoise`), at the default 2 ms window
/// and at 5 ms. Skipped without dv-processing, except under CI.
#[test]
fn the_noise_filter_keeps_what_dv_processing_keeps() {
    let Some(python) = python_with("dv_processing, numpy", "dv-processing") else { return };
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let braille = |args: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_braille")).args(args).output().unwrap();
        assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    braille(&["simulate", "--board", "text:AB", "--speed", "64", "--realism", "harsh", "--out", &p("sim")]);
    let scan = std::fs::read_dir(p("sim"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|f| f.extension().is_some_and(|e| e == "aedat4"))
        .unwrap();
    braille(&["convert", scan.to_str().unwrap(), &p("scan.csv")]);
    let moved: String = std::fs::read_to_string(p("scan.csv"))
        .unwrap()
        .lines()
        .map(|l| match l.split_once(',') {
            Some((t, rest)) if !l.starts_with("t_us") => {
                format!("{},{rest}\n", t.parse::<i64>().unwrap() + 1_000_000_000)
            }
            _ => format!("{l}\n"),
        })
        .collect();
    std::fs::write(p("evetac.csv"), moved).unwrap();
    let davis = root.join("tests/fixtures/davis346_dv.expected.csv");
    let davis = davis.to_str().unwrap();
    for (input, (width, height), window_us) in [
        (davis, ("346", "260"), "2000"),
        (&p("evetac.csv"), ("640", "480"), "2000"),
        (&p("evetac.csv"), ("640", "480"), "5000"),
    ] {
        let ours = p("ours.csv");
        let err = braille(&[
            "convert",
            input,
            &ours,
            "--force",
            "--resolution",
            &format!("{width}x{height}"),
            "--denoise",
            &format!("dv-processing:{window_us}"),
        ]);
        let theirs = p("theirs.csv");
        let o = Command::new(&python)
            .arg(root.join("tests/python/dv_denoise.py"))
            .args([input, &theirs, width, height, window_us])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let ours = std::fs::read_to_string(&ours).unwrap();
        let ours = ours.split_once('\n').unwrap().1; // the CSV writer's `# resolution:` line
        let theirs = std::fs::read_to_string(&theirs).unwrap();
        let (kept, seen) = (theirs.lines().count() - 1, std::fs::read_to_string(input).unwrap().lines().count());
        assert!(
            kept > 100 && kept + 100 < seen,
            "{input}: a cross-check needs events kept and dropped ({kept} of {seen})"
        );
        assert!(ours == theirs, "{input} at {window_us} us: ours and dv-processing's differ\n{err}");
        eprintln!("{input} at {window_us} us: {kept} events kept by both, identical");
    }
}
