//! Event files: real DV output decodes exactly, every format round-trips, and bad input gets an
//! error that names the file and the place.

use encoders::formats::aedat4::{self, Compression, EncoderOptions};
use encoders::formats::{self, AtomicFile, OpenOptions};
use encoders::{Error, Event, Format, Polarity, Resolution};
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures").join(name)
}

fn random_events(n: usize, seed: u64, res: Resolution) -> Vec<Event> {
    // xorshift: deterministic, no dependency
    let mut s = seed | 1;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    let mut t = 1_600_000_000_000_000i64;
    (0..n)
        .map(|_| {
            t += (next() % 50) as i64;
            let r = next();
            Event::new(
                t,
                (r % res.width as u64) as u16,
                ((r >> 16) % res.height as u64) as u16,
                Polarity::from_on(r >> 40 & 1 == 1),
            )
        })
        .collect()
}

fn write_with(path: &Path, events: &[Event], res: Resolution, compression: Compression) {
    let file = AtomicFile::create(path, true).unwrap();
    let mut sink: Box<dyn encoders::EventSink> = match Format::from_path(path).unwrap() {
        Format::Aedat4 => Box::new(
            aedat4::Encoder::new(
                file,
                Some(res),
                EncoderOptions { compression, packet_events: 1000, source: "test".into() },
            )
            .unwrap(),
        ),
        Format::Csv => Box::new(formats::csv::Encoder::new(file, Some(res)).unwrap()),
        Format::Npy => Box::new(formats::npy::Encoder::new(file).unwrap()),
    };
    // uneven chunks
    for chunk in events.chunks(777) {
        sink.write(chunk).unwrap();
    }
    sink.finish().unwrap();
}

#[test]
fn real_dv_recording_decodes_like_the_reference_decoder() {
    // A prefix of a DAVIS346 recording made by iniVation's DV (events, frames, IMU and trigger
    // streams, LZ4), from the `aedat` crate's test data (MIT, see davis346_dv.LICENSE). The
    // expected events were decoded by PyPI `aedat` 2.3.0.
    let (info, events) = formats::read_all(&fixture("davis346_dv.aedat4"), &OpenOptions::default()).unwrap();
    assert_eq!(info.resolution, Some(Resolution::new(346, 260)));
    assert_eq!(info.source.as_deref(), Some("DAVIS346_00000002"));
    let (_, expected) = formats::read_all(&fixture("davis346_dv.expected.csv"), &OpenOptions::default()).unwrap();
    assert_eq!(events.len(), 3576);
    assert_eq!(events, expected);
}

#[test]
fn the_decoder_lists_every_stream_and_reads_one() {
    let d = aedat4::Decoder::open(&fixture("davis346_dv.aedat4"), &OpenOptions::default()).unwrap();
    let kinds: Vec<&str> = d.streams().iter().map(|s| s.type_identifier.as_str()).collect();
    assert_eq!(kinds, ["EVTS", "FRME", "IMUS", "TRIG"]);
    assert_eq!(d.compression(), Compression::Lz4);
    let err = aedat4::Decoder::open(
        &fixture("davis346_dv.aedat4"),
        &OpenOptions { stream_id: Some(1), ..Default::default() },
    )
    .err()
    .unwrap();
    assert!(err.to_string().contains("no event (EVTS) stream with id 1"), "{err}");
}

#[test]
fn every_format_round_trips_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let res = Resolution::DVXPLORER;
    let events = random_events(20_000, 7, res);
    for (name, compression) in [
        ("a.aedat4", Compression::Lz4),
        ("b.aedat4", Compression::Zstd),
        ("c.aedat4", Compression::None),
        ("d.aedat4", Compression::ZstdHigh),
        ("e.csv", Compression::None),
        ("f.npy", Compression::None),
    ] {
        let path = dir.path().join(name);
        write_with(&path, &events, res, compression);
        let (info, back) = formats::read_all(&path, &OpenOptions::default()).unwrap();
        assert_eq!(back, events, "{name}");
        if info.format != Format::Npy {
            assert_eq!(info.resolution, Some(res), "{name}");
        }
    }
}

#[test]
fn streaming_hands_out_bounded_chunks() {
    let dir = tempfile::tempdir().unwrap();
    let res = Resolution::new(64, 64);
    let events = random_events(200_000, 3, res);
    for name in ["s.aedat4", "s.csv", "s.npy"] {
        let path = dir.path().join(name);
        write_with(&path, &events, res, Compression::Lz4);
        let mut src = formats::open(&path, &OpenOptions::default()).unwrap();
        let (mut n, mut largest) = (0, 0);
        while let Some(chunk) = src.next_chunk().unwrap() {
            assert!(!chunk.is_empty());
            n += chunk.len();
            largest = largest.max(chunk.len());
        }
        assert_eq!(n, events.len(), "{name}");
        assert!(largest <= formats::CHUNK_EVENTS, "{name}: chunk of {largest}");
    }
}

#[test]
fn empty_streams_are_valid_files() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["z.aedat4", "z.csv", "z.npy"] {
        let path = dir.path().join(name);
        write_with(&path, &[], Resolution::new(10, 10), Compression::Lz4);
        let (_, back) = formats::read_all(&path, &OpenOptions::default()).unwrap();
        assert!(back.is_empty(), "{name}");
    }
}

#[test]
fn outputs_are_atomic_and_not_overwritten_without_force() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.csv");
    std::fs::write(&path, "keep me").unwrap();
    let err = formats::create(&path, None, false).err().unwrap();
    assert!(matches!(err, Error::Exists { .. }), "{err}");
    {
        let mut sink = formats::create(&path, None, true).unwrap();
        sink.write(&[Event::new(1, 1, 1, Polarity::On)]).unwrap();
        // dropped without finish: the old file stays, no temporary file is left
    }
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "keep me");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

/// Writes `bytes` to a file named `name` and returns the error that opening and reading it gives.
fn error_of(name: &str, bytes: &[u8], options: &OpenOptions) -> (PathBuf, String) {
    let dir = tempfile::tempdir().unwrap().keep();
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    let result = formats::open(&path, options).and_then(|mut s| {
        while s.next_chunk()?.is_some() {}
        Ok(())
    });
    let msg = result.err().map(|e| e.to_string()).unwrap_or_else(|| panic!("{name}: no error"));
    assert!(msg.contains(&path.display().to_string()), "message does not name the file: {msg}");
    (path, msg)
}

fn valid_aedat(compression: Compression, events: &[Event]) -> Vec<u8> {
    let mut enc = aedat4::Encoder::to_writer(
        Vec::new(),
        Path::new("mem"),
        Some(Resolution::new(100, 100)),
        EncoderOptions { compression, packet_events: 4, source: "t".into() },
    )
    .unwrap();
    enc.write(events).unwrap();
    enc.into_inner().unwrap()
}

#[test]
fn bad_aedat4_input_names_the_place() {
    let events: Vec<Event> = (0..10).map(|i| Event::new(i * 10, i as u16, 2, Polarity::On)).collect();
    let good = valid_aedat(Compression::Lz4, &events);
    let header_end = 18 + u32::from_le_bytes(good[14..18].try_into().unwrap()) as usize;

    let (_, m) = error_of("empty.aedat4", b"", &OpenOptions::default());
    assert!(m.contains("empty file"), "{m}");

    let (_, m) = error_of("magic.aedat4", b"#!AER-DAT2.0\r\nxxxx", &OpenOptions::default());
    assert!(m.contains("byte 0") && m.contains("not an AEDAT 4.0 file"), "{m}");

    let (_, m) = error_of("short.aedat4", &good[..header_end - 5], &OpenOptions::default());
    assert!(m.contains("truncated at byte") && m.contains("header"), "{m}");

    let (_, m) = error_of("packet.aedat4", &good[..good.len() - 3], &OpenOptions::default());
    assert!(m.contains("truncated at byte") && m.contains("packet"), "{m}");

    let mut huge = good[..header_end].to_vec();
    huge.extend_from_slice(&0u32.to_le_bytes());
    huge.extend_from_slice(&u32::MAX.to_le_bytes());
    let (_, m) = error_of("huge.aedat4", &huge, &OpenOptions::default());
    assert!(m.contains(&format!("byte {header_end}")) && m.contains("more than the limit"), "{m}");

    let mut comp = good.clone();
    comp[18 + 28] = 9; // the compression field of the header table
    let (_, m) = error_of("comp.aedat4", &comp, &OpenOptions::default());
    assert!(m.contains("unknown compression 9") && m.contains("byte 18"), "{m}");

    let mut garbage = good.clone();
    for b in &mut garbage[header_end + 8..header_end + 20] {
        *b = 0xAB;
    }
    let (_, m) = error_of("garbage.aedat4", &garbage, &OpenOptions::default());
    assert!(m.contains(&format!("byte {header_end}")) && m.contains("LZ4"), "{m}");

    let mut stream = good.clone();
    stream[header_end] = 5;
    let (_, m) = error_of("stream.aedat4", &stream, &OpenOptions::default());
    assert!(m.contains("stream 5, which the header does not declare"), "{m}");

    // timestamps going backwards and coordinates outside the resolution, written raw
    let mut raw = valid_aedat(Compression::None, &events);
    let first_event = header_end + 8 + 32;
    raw[first_event + 16..first_event + 24].copy_from_slice(&(-5i64).to_le_bytes());
    let (_, m) = error_of("back.aedat4", &raw, &OpenOptions::default());
    assert!(m.contains("goes backwards") && m.contains(&format!("event 1 of the packet at byte {header_end}")), "{m}");

    let (_, m) = error_of(
        "range.aedat4",
        &valid_aedat(Compression::None, &events),
        &OpenOptions { resolution: Some(Resolution::new(5, 5)), ..Default::default() },
    );
    assert!(m.contains("(5, 2) outside the declared resolution 5x5") && m.contains("event 1 of the packet"), "{m}");
}

#[test]
fn bad_csv_input_names_the_line() {
    let o = OpenOptions::default();
    let cases: [(&str, &str, &[&str]); 8] = [
        ("empty.csv", "", &["empty file"]),
        ("nan.csv", "t_us,x,y,p\n1,2,3,1\nNaN,2,3,1\n", &["line 3", "t_us", "NaN"]),
        ("text.csv", "1,2,3,1\n2,abc,3,0\n", &["line 2", "`x`", "abc"]),
        ("float.csv", "1.5,2,3,1\n", &["line 1", "microseconds"]),
        ("fields.csv", "1,2,3\n", &["line 1", "4 comma-separated fields"]),
        ("pol.csv", "1,2,3,7\n", &["line 1", "`p`"]),
        ("back.csv", "# resolution: 10x10\nt_us,x,y,p\n5,1,1,1\n4,1,1,1\n", &["line 4", "goes backwards"]),
        ("range.csv", "# resolution: 10x10\nt_us,x,y,p\n5,1,1,1\n6,10,1,1\n", &["line 4", "(10, 1) outside"]),
    ];
    for (name, text, needles) in cases {
        let (_, m) = error_of(name, text.as_bytes(), &o);
        for n in needles {
            assert!(m.contains(n), "{name}: {m:?} lacks {n:?}");
        }
    }
    let (_, m) = error_of("wide.csv", b"a,b,c,d,e,f,g,h,i,t_us,x,y,p\n", &o);
    assert!(m.contains("at most 8 columns"), "{m}");
    let (_, m) = error_of("neg.csv", b"5,-1,1,1\n", &o);
    assert!(m.contains("(-1, 1) outside"), "{m}");
    // A file that is not text (here a model file's first bytes) is named as such, not printed.
    let (_, m) = error_of("model.safetensors", b"\x90\x08\0\0\0\0\0\0{\"__metadata__\":{}}\n", &o);
    assert!(m.contains("line 1") && m.contains("binary data, not CSV text"), "{m}");
    assert!(!m.contains("metadata"), "the binary line is not echoed: {m}");
    // A long field is cut in the message.
    let long = format!("1,2,3,{}\n", "x".repeat(5000));
    let (_, m) = error_of("long.csv", long.as_bytes(), &o);
    assert!(m.contains("`p`") && m.contains("...") && m.len() < 400, "{m}");
}

#[test]
fn csv_headers_may_reorder_columns() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("o.csv");
    std::fs::write(&path, "x,y,polarity,timestamp\n3,4,1,10\n5,6,-1,20\n").unwrap();
    let (_, ev) = formats::read_all(&path, &OpenOptions::default()).unwrap();
    assert_eq!(ev, vec![Event::new(10, 3, 4, Polarity::On), Event::new(20, 5, 6, Polarity::Off)]);
}

#[test]
fn bad_npy_input_names_the_place() {
    let o = OpenOptions::default();
    let (_, m) = error_of("magic.npy", b"\x93NUMPZ\x01\x00", &o);
    assert!(m.contains("byte 0"), "{m}");
    let header = |descr: &str, n: u64| {
        let dict = format!("{{'descr': {descr}, 'fortran_order': False, 'shape': ({n},), }}\n");
        let mut b = b"\x93NUMPY\x01\x00".to_vec();
        b.extend_from_slice(&(dict.len() as u16).to_le_bytes());
        b.extend_from_slice(dict.as_bytes());
        b
    };
    let mut short = header(formats::npy::DESCR, 3);
    short.extend_from_slice(&[0u8; 20]);
    let (_, m) = error_of("short.npy", &short, &o);
    assert!(m.contains("truncated at byte") && m.contains("3 more events"), "{m}");
    let (_, m) = error_of("float.npy", &header("[('x', '<f8'), ('y', '<u2'), ('t', '<i8'), ('p', '|u1')]", 0), &o);
    assert!(m.contains("<f8"), "{m}");
    let (_, m) = error_of("nofield.npy", &header("[('x', '<u2'), ('y', '<u2'), ('t', '<i8')]", 0), &o);
    assert!(m.contains("no field `p`"), "{m}");
}

#[test]
fn aedat_writer_rejects_what_it_cannot_store() {
    let mut enc = aedat4::Encoder::to_writer(
        Vec::new(),
        Path::new("w.aedat4"),
        Some(Resolution::new(10, 10)),
        EncoderOptions::default(),
    )
    .unwrap();
    let err = enc.write(&[Event::new(0, 10, 0, Polarity::On)]).unwrap_err();
    assert!(err.to_string().contains("w.aedat4") && err.to_string().contains("outside"), "{err}");
    let err = enc.write(&[Event::new(5, 1, 0, Polarity::On), Event::new(4, 1, 0, Polarity::On)]).unwrap_err();
    assert!(err.to_string().contains("goes backwards"), "{err}");
}
