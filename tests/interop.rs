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
