//! Reading words from event streams (SIMULATED scans): `braille read` on a file, on standard
//! input and on a live network stream served by `braille replay`, both SNN runners, `braille eval words`, `braille words-report`, and training the
//! segmentation networks.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn braille(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_braille")).args(args).output().expect("run braille")
}

fn text(o: &Output) -> (String, String) {
    (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// A simulated scan of a text board at 32 mm/s, written as `name` (its ground truth beside it).
fn scan(dir: &Path, board: &str, name: &str) -> PathBuf {
    let out = dir.join(name);
    let o = braille(&["simulate", "--board", board, "--speed", "32", "--seed", "3", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o).1);
    out
}

/// The JSON Lines of `braille read --json`: the words, then the summary.
fn lines(out: &str) -> (Vec<serde_json::Value>, serde_json::Value) {
    let mut v: Vec<serde_json::Value> = out.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let summary = v.pop().unwrap();
    assert_eq!(summary["summary"], true);
    (v, summary)
}

#[test]
fn read_a_scan_with_both_architectures_and_both_snn_runners() {
    let dir = tempfile::tempdir().unwrap();
    let f = scan(dir.path(), "text:HELP WATER", "help.aedat4");
    let f = f.to_str().unwrap();
    // the reader gets the events only: the truth beside the file is not read, the speed is
    // estimated from the events
    std::fs::remove_file(dir.path().join("help.truth.json")).unwrap();
    let o = braille(&["read", f, "--arch", "snn", "--json"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let (words, summary) = lines(&out);
    assert_eq!(summary["text"], "HELP WATER", "{out}");
    assert_eq!(summary["timing"]["mode"], "estimated");
    let speed = summary["speed_mm_s"].as_f64().unwrap();
    assert!((speed / 32.0 - 1.0).abs() < 0.06, "estimated {speed} mm/s");
    assert!(summary["speed_estimates"].as_u64() > Some(10), "{summary}");
    assert_eq!(words.len(), 2);
    let c = &words[0]["chars"][0];
    assert!(c["t_registered_us"].as_i64() > c["t_end_us"].as_i64(), "{c}");
    assert_eq!(c["probs"].as_array().map(Vec::len), Some(26));
    // the event-driven engine reads each window from rest: the same words, letter for letter
    let o = braille(&["read", f, "--arch", "snn", "--json", "--snn-runner", "engine"]);
    let (engine_out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let (engine_words, engine_summary) = lines(&engine_out);
    assert_eq!(engine_words, words);
    assert!(engine_summary["classifier_synops"].as_u64() > summary["classifier_synops"].as_u64());
    // the ResNet reads the same stream
    let o = braille(&["read", f, "--arch", "resnet", "--spell", "textblob"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(out.contains("resnet architecture, spelling Textblob"), "{out}");
    // the paper's fixed timing reads at 8 mm/s whatever the speed; a given timing needs a speed
    let o = braille(&["read", f, "--timing", "paper", "--json"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(lines(&out).1["speed_mm_s"], 8.0);
    let o = braille(&["read", f, "--timing", "given"]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("needs a speed"), "{err}");
}

#[test]
fn read_standard_input_as_it_arrives() {
    let dir = tempfile::tempdir().unwrap();
    let f = scan(dir.path(), "text:STOP", "stop.csv");
    let mut child = Command::new(env!("CARGO_BIN_EXE_braille"))
        .args(["read", "-", "--speed", "32", "--json"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let bytes = std::fs::read(&f).unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || {
        for chunk in bytes.chunks(1 << 16) {
            stdin.write_all(chunk).unwrap();
        }
    });
    let o = child.wait_with_output().unwrap();
    writer.join().unwrap();
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let (_, summary) = lines(&out);
    assert_eq!(summary["text"], "STOP", "{out}");
    assert_eq!(summary["data"], "-");
    // text that is not events: the line is named
    let mut child = Command::new(env!("CARGO_BIN_EXE_braille"))
        .args(["read", "-", "--speed", "32"])
        .stdin(Stdio::piped())
        .stderr(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(b"0,1,2,1\n10,x,2,1\n").unwrap();
    let o = child.wait_with_output().unwrap();
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("line 2"), "{err}");
}

/// `braille replay FILE --listen` as a live sensor and `braille read tcp://HOST:PORT`: the words
/// read over TCP are the file's, each word's latency is timed, and a sender that stops mid-packet
/// or stalls ends the read with an error naming it, after the words it had sent.
#[test]
fn read_a_live_stream_as_replay_serves_it() {
    use std::io::{BufRead, BufReader};
    let dir = tempfile::tempdir().unwrap();
    let f = scan(dir.path(), "text:HELP WATER", "help.aedat4");
    let o = braille(&["read", f.to_str().unwrap(), "--json"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let (file_words, _) = lines(&out);
    assert_eq!(file_words.len(), 2);
    let mut replay = Command::new(env!("CARGO_BIN_EXE_braille"))
        .args(["replay", f.to_str().unwrap(), "--listen", "127.0.0.1:0", "--pace", "4", "--json"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = String::new();
    BufReader::new(replay.stderr.take().unwrap()).read_line(&mut first).unwrap();
    let address = first.trim().rsplit(' ').next().unwrap().to_string();
    assert!(address.starts_with("tcp://127.0.0.1:"), "{first}");
    let o = braille(&["read", &address, "--json"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let (words, summary) = lines(&out);
    assert_eq!(words, file_words, "the words over TCP, letter for letter, are the file's");
    assert_eq!(summary["data"], address.as_str());
    assert_eq!(summary["words_timed"], 2);
    let (p50, p99) =
        (summary["word_latency_ms_p50"].as_f64().unwrap(), summary["word_latency_ms_p99"].as_f64().unwrap());
    assert!(0.0 < p50 && p50 <= p99, "{summary}");
    let served = replay.wait_with_output().unwrap();
    assert!(served.status.success());
    let sent: serde_json::Value = serde_json::from_slice(&served.stdout).unwrap();
    // at 4x the recorded pace, the stream's 2.2 s took at least 0.55 s to send
    assert!(sent["wall_s"].as_f64().unwrap() >= sent["stream_s"].as_f64().unwrap() / 4.0, "{sent}");

    // a sender of the network framing (the file without its 14-byte magic) that stops 30 bytes
    // into a packet two thirds of the way in, or sends that much and then nothing
    let bytes = std::fs::read(&f).unwrap()[14..].to_vec();
    let mut cut = 0;
    let header = 4 + u32::from_le_bytes(bytes[..4].try_into().unwrap()) as usize;
    let mut at = header;
    while at < bytes.len() * 2 / 3 {
        cut = at + 30;
        at += 8 + u32::from_le_bytes(bytes[at + 4..at + 8].try_into().unwrap()) as usize;
    }
    for stall in [false, true] {
        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let address = format!("tcp://{}", listener.local_addr().unwrap());
        let part = bytes[..cut].to_vec();
        let sender = std::thread::spawn(move || {
            let (mut s, _) = listener.accept().unwrap();
            s.write_all(&part).unwrap();
            if stall {
                std::thread::sleep(std::time::Duration::from_secs(3));
            }
        });
        let o = braille(&["read", &address, "--json", "--stall-timeout-s", "0.5"]);
        let (out, err) = text(&o);
        assert!(!o.status.success(), "{out}");
        let want = if stall { "the sender stalled" } else { "truncated at byte" };
        assert!(err.contains(&address) && err.contains(want), "{err}");
        // the first word, read before the sender failed, was printed
        let first: serde_json::Value = serde_json::from_str(out.lines().next().unwrap()).unwrap();
        assert_eq!(first["text"], "HELP", "{out}");
        sender.join().unwrap();
    }
}

/// Simulated scans exported as a lab's recordings folder (numbered files, no truth) read by
/// `eval words --recordings` give the table `eval words` gives for the same scans, word for word
/// (the speed error differs by design: against the commanded speed, not the truth).
#[test]
fn a_recordings_folder_reads_as_the_simulated_path_does() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("scans");
    let board = "text:HELLO WORLD/STOP HELP";
    let common = ["--speed", "32", "--depth", "1.0", "--trials", "2", "--seed", "7", "--sensor-builds", "test"];
    let mut args = vec!["simulate", "--board", board, "--out", rec.to_str().unwrap(), "--recordings", "test"];
    args.extend(common);
    let o = braille(&args);
    assert!(o.status.success(), "{}", text(&o).1);
    assert!(!rec.join("00001.truth.json").exists());
    let o = braille(&["eval", "words", "--recordings", rec.to_str().unwrap(), "--json"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let tables: Vec<serde_json::Value> = serde_json::from_str(&out).unwrap();
    assert_eq!(tables.len(), 1, "one condition");
    let mut args = vec!["eval", "words", "--board", board, "--json"];
    args.extend(common);
    let o = braille(&args);
    assert!(o.status.success(), "{}", text(&o).1);
    let simulated: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let recorded = &tables[0];
    assert_eq!(recorded["data"], "recorded scans");
    assert_eq!(recorded["examples"], simulated["examples"]);
    assert_eq!(recorded["examples"].as_array().unwrap().len(), 4);
    for k in ["word_accuracy", "percent_correct", "wer", "cer", "lines", "speed_mm_s", "depth_mm"] {
        assert_eq!(recorded[k], simulated[k], "{k}");
    }
    for (r, s) in recorded["by_spell"].as_array().unwrap().iter().zip(simulated["by_spell"].as_array().unwrap()) {
        assert_eq!(r["counts"], s["counts"]);
    }
    // the character classifier on the same scans' windows, cut by the labeler from the manifest's
    // text and commanded speed as from the simulator's row and speed: the same windows and score
    let words_snn = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/nominal/snn-words.safetensors");
    let model = words_snn.to_str().unwrap();
    let o = braille(&["eval", "chars", "--model", model, "--recordings", rec.to_str().unwrap(), "--json"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let scores: Vec<serde_json::Value> = serde_json::from_str(&out).unwrap();
    let mut args = vec!["eval", "chars", "--model", model, "--board", board, "--json"];
    args.extend(common);
    let o = braille(&args);
    assert!(o.status.success(), "{}", text(&o).1);
    let simulated: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((scores.len(), scores[0]["data"].as_str()), (1, Some("recorded scans")));
    for k in ["printed", "scans", "skipped_scans", "n", "accuracy", "accuracy_all", "confusion"] {
        assert_eq!(scores[0][k], simulated[k], "{k}");
    }
    assert_eq!(simulated["printed"], 2 * (10 + 8));
}

#[test]
fn eval_words_prints_the_papers_metrics() {
    let o = braille(&["eval", "words", "--arch", "snn", "--speed", "32", "--trials", "1", "--json"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["data"], "simulated (virtual Evetac)");
    assert_eq!(v["lines"], 2);
    assert_eq!(v["timing"], "estimated");
    // every figure from its counts, by hand: EV's two rows print 4 + 5 words, 20 + 25 letters
    // with their spaces (RIGHT LEFT EXIT OPEN / PUSH PULL STOP HELP WATER)
    let b = v["by_spell"].as_array().unwrap().iter().find(|b| b["spell"] == v["spell"]).unwrap();
    let c = &b["counts"];
    let n = |x: &serde_json::Value| x.as_u64().unwrap() as f64;
    let (w, ch) = (&c["word_edits"], &c["char_edits"]);
    assert_eq!((n(&w["reference"]), n(&ch["reference"]), n(&c["lines"])), (9.0, 20.0 + 25.0, 2.0));
    for e in [w, ch] {
        assert_eq!(n(&e["hits"]) + n(&e["substitutions"]) + n(&e["deletions"]), n(&e["reference"]), "{e}");
    }
    let edits = |e: &serde_json::Value| n(&e["substitutions"]) + n(&e["deletions"]) + n(&e["insertions"]);
    let f = |key: &str| v[key].as_f64().unwrap();
    assert_eq!(f("wer"), edits(w) / 9.0);
    assert_eq!(f("word_accuracy"), 1.0 - edits(w) / 9.0, "1 - WER: inserted words count");
    assert_eq!(f("percent_correct"), n(&w["hits"]) / 9.0);
    assert_eq!(f("cer"), edits(ch) / 45.0);
    assert_eq!(f("words_per_line"), n(&c["lines_with_right_word_count"]) / 2.0);
    assert_eq!(f("correct_words"), n(&c["correct_words"]) / n(&c["words_with_right_letter_count"]));
    // the lines read are the words scored: each example is (printed, raw, spelled)
    let ex = v["examples"].as_array().unwrap();
    assert_eq!(ex.len(), 2);
    assert_eq!(
        (ex[0][0].as_str(), ex[1][0].as_str()),
        (Some("RIGHT LEFT EXIT OPEN"), Some("PUSH PULL STOP HELP WATER"))
    );
    // every printed letter scored by letter and place, every word by place, by hand: P is in OPEN,
    // PUSH, PULL, STOP and HELP; 38 letters, 2 at a row's start, 7 at a later word's start, 9 at
    // a word's end; 2 first words, 2 last, 5 between
    let l = &c["letter_scores"];
    let printed = |t: &serde_json::Value| t["printed"].as_u64().unwrap();
    assert_eq!(printed(&l["by_letter"][(b'P' - b'A') as usize]), 5);
    assert_eq!(printed(&l["by_letter"][(b'Q' - b'A') as usize]), 0);
    let places: Vec<u64> = l["by_place"].as_array().unwrap().iter().map(printed).collect();
    assert_eq!(places, [2, 7, 20, 9]);
    let right: u64 = l["by_letter"].as_array().unwrap().iter().map(|t| t["right"].as_u64().unwrap()).sum();
    let diagonal: u64 = (0..26).map(|k| l["confusion"][k][k].as_u64().unwrap()).sum();
    assert_eq!(right, diagonal);
    let wp = &c["word_places"];
    assert_eq!((printed(&wp["first"]), printed(&wp["middle"]), printed(&wp["last"])), (2, 5, 2));
    let hits = |t: &serde_json::Value| t["right"].as_u64().unwrap() as f64;
    assert_eq!(hits(&wp["first"]) + hits(&wp["middle"]) + hits(&wp["last"]), n(&w["hits"]));
    // the speed each character was read at, against the truth under the sensor
    let e = &v["speed_error"];
    assert!(e["chars"].as_u64() > Some(3) && e["mean_abs"].as_f64() < Some(0.2), "{e}");
    // a free-text board works as well, and a bad board is named
    let o = braille(&["eval", "words", "--board", "text:PULL", "--speed", "32", "--trials", "1"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(out.contains("SIMULATED TEXT") || out.contains("SIMULATED text"), "{out}");
    assert!(out.contains("letters: ") && out.contains("by place: row start"), "{out}");
    let o = braille(&["eval", "words", "--board", "XYZ", "--trials", "1"]);
    assert!(!o.status.success() && text(&o).1.contains("XYZ"));
}

#[test]
fn eval_words_reads_the_validation_words_with_either_architectures_networks() {
    // the validation words on the training sensor builds, the ResNet's segmentation with the SNN's
    // classifier (the models trained at `nominal`)
    let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/nominal");
    let (seg, cls) = (models.join("resnet-tiny-segment.safetensors"), models.join("snn-words.safetensors"));
    let (seg, cls) = (seg.to_str().unwrap(), cls.to_str().unwrap());
    let common = ["eval", "words", "--board", "val-words", "--sensor-builds", "training", "--realism", "nominal"];
    let mut args = common.to_vec();
    args.extend([
        "--seed",
        "2000003",
        "--speed",
        "64",
        "--trials",
        "1",
        "--json",
        "--segmenter",
        seg,
        "--classifier",
        cls,
    ]);
    let o = braille(&args);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["lines"], 4, "{out}");
    assert_eq!(v["board"], "VAL-WORDS");
    assert!(v["word_accuracy"].as_f64().unwrap() > 0.5, "{}", v["word_accuracy"]);
    assert_eq!(v["segmenter"], seg);
    assert_eq!(v["classifier"], cls);
    assert_eq!(v["sensor_builds"], "training");
    // a classifier handed over as the segmentation network is named
    let mut args = common.to_vec();
    args.extend(["--trials", "1", "--segmenter", cls, "--classifier", cls]);
    let o = braille(&args);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("snn-words") && err.contains("segmentation"), "{err}");
}

#[test]
fn words_report_writes_the_speed_table() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("docs");
    let o = braille(&[
        "words-report",
        "--trials",
        "1",
        "--speeds",
        "32",
        "--hand-speeds",
        "16",
        "--timings",
        "estimated,paper",
        "--unseen-rows",
        "1",
        "--unseen-trials",
        "1",
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    let (_, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let md = std::fs::read_to_string(out_dir.join("words.md")).unwrap();
    assert!(md.contains("SIMULATED") && md.contains("| 32 mm/s | snn | Lexicon |"), "{md}");
    assert!(md.contains("| 32 mm/s | resnet | None |"), "{md}");
    assert!(md.contains("| 16 mm/s hand-held (±40%) | snn |"), "{md}");
    assert!(md.contains("## The paper's fixed timing") && !md.contains("## Oracle"), "{md}");
    assert!(md.contains("## The speed estimate") && md.contains("## Unseen words"), "{md}");
    assert!(out_dir.join("words_speed.png").exists() && out_dir.join("words.json").exists());
}

#[test]
fn the_envelope_table_reads_each_condition_with_both_readers_and_has_no_sealed_set_yet() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("envelope");
    let args = ["report", "envelope", "--validation", "--presets", "nominal", "--speeds", "200", "--depths", "1.0"];
    let o = braille(&[&args[..], &["--trials", "1", "--out", out.to_str().unwrap()]].concat());
    let (_, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let md = std::fs::read_to_string(out.join("validation_envelope.md")).unwrap();
    assert!(md.contains("SIMULATED") && md.contains("VAL-WORDS") && md.contains("[51, 52]"), "{md}");
    for reader in ["SNN", "ResNet"] {
        let row = md.lines().find(|l| l.starts_with(&format!("| nominal | 1 mm | {reader} |"))).expect(reader);
        assert!(row.contains(" / ") && !row.contains("(0.00)"), "{row}");
        assert!(md.contains(&format!("- {reader}, `nominal` [200.0] mm/s")), "{md}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("validation_envelope.json")).unwrap()).unwrap();
    assert_eq!(json["cells"].as_array().unwrap().len(), 2);
    // no sealed set is fixed for it: --final is refused, and nothing is written or recorded
    let o = braille(&["report", "envelope", "--final", "--out", dir.path().join("sealed").to_str().unwrap()]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("no sealed set"), "{err}");
    assert!(!dir.path().join("sealed").exists());
    // nor for the words sweep
    let o = braille(&["sim", "robustness", "--words", "--final", "--out", dir.path().join("sealed").to_str().unwrap()]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("no sealed set"), "{err}");
    assert!(!dir.path().join("sealed").exists());
}

#[test]
fn letters_report_reads_the_all_letters_board() {
    let dir = tempfile::tempdir().unwrap();
    let common = ["letters-report", "--archs", "snn", "--speeds", "64", "--depths", "1.5", "--trials", "1"];
    let mut args = common.to_vec();
    let out = dir.path().to_str().unwrap();
    args.extend(["--focus-speed", "64", "--focus-depth", "1.5", "--focus-trials", "1", "--rows", "2", "--out", out]);
    let o = braille(&args);
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(stdout.contains("every letter at least 97%"), "{stdout}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("letters.json")).unwrap()).unwrap();
    assert_eq!(v["board"], "ALL-LETTERS");
    assert_eq!(v["board_rows"], 78);
    // the board's first two rows, A and B first
    let rows: Vec<&str> = v["rows"].as_array().unwrap().iter().map(|r| r.as_str().unwrap()).collect();
    assert_eq!(rows.len(), 2);
    assert!(rows[0].starts_with('A') && rows[1].starts_with('B'), "{rows:?}");
    assert_eq!(v["scores"].as_array().unwrap().len(), 1);
    let md = std::fs::read_to_string(dir.path().join("letters.md")).unwrap();
    assert!(md.contains("SIMULATED") && md.contains("first 2 rows of 78") && md.contains("| Z |"), "{md}");
    // the validation board writes its own files
    let mut args = common.to_vec();
    args.extend(["--focus-trials", "1", "--rows", "1", "--validation", "--out", out]);
    let o = braille(&args);
    assert!(o.status.success(), "{}", text(&o).1);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("val_letters.json")).unwrap()).unwrap();
    assert_eq!((v["board"].as_str(), v["seed"].as_u64()), (Some("VAL-LETTERS"), Some(2_000_003)));
    assert_eq!(v["sensor_builds"], serde_json::json!([1, 2, 3, 4]));
    // the per-letter tables' condition (16 mm/s, 1 mm by default) is read beside a grid without it
    assert_eq!(v["scores"].as_array().unwrap().len(), 2);
    assert_eq!(
        (v["speeds_mm_s"].clone(), v["depths_mm"].clone()),
        (serde_json::json!([64.0]), serde_json::json!([1.5]))
    );
    let md = std::fs::read_to_string(dir.path().join("val_letters.md")).unwrap();
    assert!(md.contains("## Per letter at 16 mm/s and 1 mm") && md.contains("--speeds 64 --depths 1.5"), "{md}");
    // on the builds held out of training and test, for choices that must hold on a new sensor;
    // the test builds are refused on the validation board
    let mut args = common.to_vec();
    args.extend(["--focus-speed", "64", "--focus-depth", "1.5", "--focus-trials", "1", "--rows", "1"]);
    args.extend(["--validation", "--sensor-builds", "validation", "--out", out]);
    let o = braille(&args);
    assert!(o.status.success(), "{}", text(&o).1);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("val_letters.json")).unwrap()).unwrap();
    assert_eq!(v["sensor_builds"], serde_json::json!([51, 52]));
    let md = std::fs::read_to_string(dir.path().join("val_letters.md")).unwrap();
    assert!(
        md.contains("builds held out of training and test") && md.contains("--validation --sensor-builds validation"),
        "{md}"
    );
    let o = braille(&["letters-report", "--validation", "--sensor-builds", "test", "--rows", "1", "--out", out]);
    assert!(!o.status.success() && text(&o).1.contains("--sensor-builds test"), "{}", text(&o).1);
}

#[test]
fn train_the_segmentation_networks() {
    let dir = tempfile::tempdir().unwrap();
    for (arch, extra) in
        [("snn", &["--hidden", "8", "--pool", "4"][..]), ("resnet", &["--preset", "tiny", "--pool", "2"])]
    {
        let model = dir.path().join(format!("{arch}-segment.safetensors"));
        let mut args = vec![
            "train",
            "--arch",
            arch,
            "--task",
            "segment",
            "--trials",
            "1",
            "--epochs",
            "1",
            "--quiet",
            "--out",
            model.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let o = braille(&args);
        let (_, err) = text(&o);
        assert!(o.status.success(), "{arch}: {err}");
        let head = std::fs::read(&model).unwrap();
        let n = u64::from_le_bytes(head[..8].try_into().unwrap()) as usize;
        let header = String::from_utf8_lossy(&head[8..8 + n]);
        assert!(header.contains(r#"[\"background\",\"character\"]"#), "{arch}: {header}");
    }
}

#[test]
fn train_and_fine_tune_on_a_recordings_folder() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("lab");
    let recs = rec.to_str().unwrap();
    for (role, board, trials) in [("train", "text:HELLO WORLD", "2"), ("val", "text:STOP HELP", "1")] {
        let o = braille(&[
            "simulate",
            "--board",
            board,
            "--out",
            recs,
            "--recordings",
            role,
            "--speed",
            "16",
            "--depth",
            "1.0",
            "--trials",
            trials,
            "--seed",
            "5",
        ]);
        assert!(o.status.success(), "{}", text(&o).1);
    }
    let header = |path: &Path| {
        let head = std::fs::read(path).unwrap();
        let n = u64::from_le_bytes(head[..8].try_into().unwrap()) as usize;
        String::from_utf8_lossy(&head[8..8 + n]).to_string()
    };
    let val_score = |model: &Path| {
        let o = braille(&[
            "eval",
            "chars",
            "--model",
            model.to_str().unwrap(),
            "--recordings",
            recs,
            "--role",
            "val",
            "--json",
        ]);
        assert!(o.status.success(), "{}", text(&o).1);
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        (v[0]["confusion"].clone(), v[0]["printed"].clone())
    };
    for (arch, extra) in
        [("snn", &["--hidden", "8", "--pool", "4"][..]), ("resnet", &["--preset", "tiny", "--pool", "2"])]
    {
        let first = dir.path().join(format!("{arch}-1.safetensors"));
        let mut args = vec!["train", "--arch", arch, "--recordings", recs, "--epochs", "1", "--quiet"];
        args.extend_from_slice(extra);
        let mut a = args.clone();
        a.extend(["--out", first.to_str().unwrap()]);
        let o = braille(&a);
        assert!(o.status.success(), "{arch}: {}", text(&o).1);
        assert!(header(&first).contains("recorded scans of"), "{arch}: {}", header(&first));
        // fine-tuned at a learning rate of 0 it stays the model it started from
        let tuned = dir.path().join(format!("{arch}-2.safetensors"));
        let mut a = args.clone();
        a.extend(["--init", first.to_str().unwrap(), "--lr", "0", "--out", tuned.to_str().unwrap()]);
        let o = braille(&a);
        assert!(o.status.success(), "{arch}: {}", text(&o).1);
        assert!(header(&tuned).contains("-1.safetensors"), "{arch}: the provenance names the start");
        // every weight as it was (the ResNet's batch norm statistics follow the new data)
        let (a, b) = (std::fs::read(&first).unwrap(), std::fs::read(&tuned).unwrap());
        let (a, b) =
            (safetensors::SafeTensors::deserialize(&a).unwrap(), safetensors::SafeTensors::deserialize(&b).unwrap());
        let mut names: Vec<String> =
            a.names().into_iter().filter(|n| !n.contains("running")).map(String::from).collect();
        names.sort();
        assert!(!names.is_empty());
        for n in &names {
            assert_eq!(a.tensor(n).unwrap().data(), b.tensor(n).unwrap().data(), "{arch}: {n}");
        }
        if arch == "snn" {
            let (c1, printed) = val_score(&first);
            assert_eq!(printed, 8, "STOP HELP");
            assert_eq!(c1, val_score(&tuned).0, "{arch}");
        }
    }
    // a model whose windows an earlier labeler cut (the shipped `clean` SNN, before the running
    // median) fine-tunes on windows cut by this one, and records this labeler
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let clean = root.join("models/clean/snn-chars.safetensors");
    assert!(!header(&clean).contains("despike_bins"), "the clean model predates the running median");
    let tuned = dir.path().join("clean-tuned.safetensors");
    let o = braille(&[
        "train",
        "--arch",
        "snn",
        "--recipe",
        "chars",
        "--recordings",
        recs,
        "--epochs",
        "1",
        "--quiet",
        "--init",
        clean.to_str().unwrap(),
        "--out",
        tuned.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    assert!(header(&tuned).contains("despike_bins"), "{}", header(&tuned));
    // a start of another network, or of another architecture, is refused by name
    let snn = dir.path().join("snn-1.safetensors");
    let o = braille(&[
        "train",
        "--arch",
        "snn",
        "--recordings",
        recs,
        "--hidden",
        "16",
        "--pool",
        "4",
        "--epochs",
        "1",
        "--init",
        snn.to_str().unwrap(),
        "--out",
        dir.path().join("x.safetensors").to_str().unwrap(),
    ]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("snn-1.safetensors") && err.contains("network"), "{err}");
    let o = braille(&[
        "train",
        "--arch",
        "resnet",
        "--preset",
        "tiny",
        "--pool",
        "2",
        "--recordings",
        recs,
        "--epochs",
        "1",
        "--init",
        snn.to_str().unwrap(),
        "--out",
        dir.path().join("y.safetensors").to_str().unwrap(),
    ]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("holds an SNN"), "{err}");
    // a folder with no validation scans cannot choose checkpoints
    let lone = dir.path().join("lone");
    let o = braille(&[
        "simulate",
        "--board",
        "text:HELLO",
        "--out",
        lone.to_str().unwrap(),
        "--recordings",
        "train",
        "--speed",
        "16",
        "--trials",
        "1",
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let o = braille(&[
        "train",
        "--arch",
        "snn",
        "--recordings",
        lone.to_str().unwrap(),
        "--hidden",
        "8",
        "--epochs",
        "1",
        "--out",
        dir.path().join("z.safetensors").to_str().unwrap(),
    ]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("no val scans"), "{err}");
}

#[test]
fn report_quick_regenerates_every_table_and_figure() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    // a report regenerates in place: the files of an earlier run are replaced
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("scan_ev_row0.png"), b"old").unwrap();
    let o = braille(&["report", "--quick", "--out", out.to_str().unwrap()]);
    let (_, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let index = std::fs::read_to_string(out.join("index.md")).unwrap();
    assert!(index.contains("Quick run") && index.contains("SNN against ResNet on one stream"), "{index}");
    for f in [
        "sim_check.md",
        "label_check.md",
        "scan_ev_row0.png",
        "chars.md",
        "chars_depth.png",
        "words.md",
        "words_speed.png",
        "latency.png",
        "icub.md",
        "bench.json",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    assert_ne!(std::fs::read(out.join("scan_ev_row0.png")).unwrap(), b"old");
    // the scan the report read is not left behind
    assert!(!out.join("ev_row0_16mm_s.aedat4").exists());
}

#[test]
fn calibrate_reader_chooses_on_the_validation_words_and_records_the_point() {
    // the `clean` SNN pair, copied: a small grid on one scan per row of the validation words
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for f in ["snn-segment.safetensors", "snn-words.safetensors"] {
        std::fs::copy(root.join("models/clean").join(f), dir.path().join(f)).unwrap();
    }
    let d = dir.path().to_str().unwrap();
    let args = ["calibrate-reader", "--realism", "clean", "--models", d, "--out", d, "--trials", "1", "--speeds", "32"];
    let mut a = args.to_vec();
    a.extend(["--thresholds", "0.5,0.9", "--min-frames", "4,6", "--write"]);
    let o = braille(&a);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(out.contains("chosen for") && out.contains("recorded in"), "{out}");
    let md = std::fs::read_to_string(dir.path().join("operating_point_snn.md")).unwrap();
    assert!(md.contains("VAL-WORDS") && md.contains("**chosen**"), "{md}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("operating_point_snn.json")).unwrap()).unwrap();
    assert_eq!(v["rows"].as_array().unwrap().len(), 4);
    assert_eq!(v["spec"]["seed"], 2_000_003, "validation seed");
    let chosen = v["chosen"]["present_threshold"].as_f64().unwrap();
    // the same scans as a lab's `val` recordings give the same grid, point for point
    let rec = dir.path().join("lab");
    let o = braille(&[
        "simulate",
        "--realism",
        "clean",
        "--board",
        "VAL-WORDS",
        "--speed",
        "32",
        "--depth",
        "1.5",
        "--trials",
        "1",
        "--seed",
        "2000003",
        "--sensor-builds",
        "training",
        "--out",
        rec.to_str().unwrap(),
        "--recordings",
        "val",
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let out_rec = dir.path().join("from-recordings");
    let o = braille(&[
        "calibrate-reader",
        "--models",
        d,
        "--out",
        out_rec.to_str().unwrap(),
        "--thresholds",
        "0.5,0.9",
        "--min-frames",
        "4,6",
        "--recordings",
        rec.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_rec.join("operating_point_snn.json")).unwrap()).unwrap();
    assert_eq!(r["data"], "recorded scans");
    assert_eq!(
        (&r["rows"], &r["words"], &r["chosen"]["min_frames"]),
        (&v["rows"], &v["words"], &v["chosen"]["min_frames"])
    );
    assert!(r.get("spec").is_none());
    // the reader now reads there: eval words names the point
    let seg = dir.path().join("snn-segment.safetensors");
    let cls = dir.path().join("snn-words.safetensors");
    let o = braille(&[
        "eval",
        "words",
        "--realism",
        "clean",
        "--board",
        "text:HELP",
        "--trials",
        "1",
        "--speed",
        "32",
        "--json",
        "--segmenter",
        seg.to_str().unwrap(),
        "--classifier",
        cls.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let e: serde_json::Value = serde_json::from_str(&text(&o).0).unwrap();
    assert_eq!(e["operating_point"]["present_threshold"].as_f64(), Some(chosen), "{e}");
    assert_eq!(e["operating_point"]["min_frames"], v["chosen"]["min_frames"]);
    // --apply writes an earlier run's choice without sweeping; a file without one is refused
    let json = dir.path().join("operating_point_snn.json");
    let o = braille(&["calibrate-reader", "--models", d, "--apply", json.to_str().unwrap()]);
    assert!(o.status.success() && text(&o).0.contains(&format!("threshold {chosen}")), "{:?}", text(&o));
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, "{\"chosen\": {\"present_threshold\": 2.0, \"min_frames\": 4}}").unwrap();
    let o = braille(&["calibrate-reader", "--models", d, "--apply", bad.to_str().unwrap()]);
    assert!(!o.status.success() && text(&o).1.contains("bad.json"), "{}", text(&o).1);
}

/// Golden test of the README's SIMULATED word headline: the first scan of each EV row at 64
/// mm/s, read again by each shipped `nominal` reader (speed estimated, operating point as
/// recorded in the model file), gives word for word the lines the committed table
/// (docs/results/nominal/words.json, `braille words-report --trials 30`) read from the same
/// scans (the same seed, trial 0 of each row), the table's WER is its counts', and the README
/// quotes its range; the table's word accuracy is 1 - WER and its percent correct hits over
/// printed words, both from its counts.
#[test]
fn the_committed_word_table_reads_again_from_its_first_scans() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let table: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(root.join("docs/results/nominal/words.json")).unwrap()).unwrap();
    let trials = table["trials"].as_u64().unwrap() as usize;
    let seed = table["seed"].as_u64().unwrap().to_string();
    for arch in ["resnet", "snn"] {
        let row = table["scores"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| {
                s["arch"] == arch
                    && s["timing"] == "estimated"
                    && s["speed_mm_s"] == 64.0
                    && s["speed_variation"] == 0.0
            })
            .unwrap_or_else(|| panic!("{arch} at 64 mm/s in the committed table"));
        // the lines are row-major: row 0's trials, then row 1's
        let committed = &row["examples"];
        let want = [&committed[0], &committed[trials]];
        let o = braille(&[
            "eval",
            "words",
            "--arch",
            arch,
            "--realism",
            "nominal",
            "--board",
            "EV",
            "--speed",
            "64",
            "--depth",
            "1.5",
            "--trials",
            "1",
            "--seed",
            &seed,
            "--json",
        ]);
        let (out, err) = text(&o);
        assert!(o.status.success(), "{err}");
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        let got = v["examples"].as_array().unwrap();
        assert_eq!([&got[0], &got[1]], want, "{arch}: the lines read now against the committed table's");
        // the table's WER, word accuracy and percent correct are its counts'
        for b in row["by_spell"].as_array().unwrap() {
            let w = &b["counts"]["word_edits"];
            let n = |k: &str| w[k].as_u64().unwrap() as f64;
            let wer = (n("substitutions") + n("deletions") + n("insertions")) / n("reference");
            assert_eq!(b["word_error_rate"].as_f64().unwrap(), wer, "{arch} {}", b["spell"]);
            // (to the last bits: the table computes them from the counts in another order)
            let accuracy = b["word_accuracy"].as_f64().unwrap();
            assert!((accuracy - (1.0 - wer)).abs() < 1e-12, "{arch} {}: {accuracy} against 1 - WER", b["spell"]);
            let correct = b["percent_correct"].as_f64().unwrap();
            assert!((correct - n("hits") / n("reference")).abs() < 1e-12, "{arch} {}: {correct}", b["spell"]);
        }
    }
    // the README's EV row: each reader's lowest and highest word accuracy with the lexicon over
    // the arm's speeds, speed estimated, as the committed table gives them
    let range = |arch: &str| {
        let v: Vec<f64> = table["scores"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|s| s["arch"] == arch && s["timing"] == "estimated" && s["speed_variation"] == 0.0)
            .map(|s| s["by_spell"].as_array().unwrap().iter().find(|b| b["spell"] == "lexicon").unwrap())
            .map(|b| b["word_accuracy"].as_f64().unwrap())
            .collect();
        assert_eq!(v.len(), table["speeds_mm_s"].as_array().unwrap().len());
        format!("{:.3}-{:.3}", v.iter().copied().fold(f64::INFINITY, f64::min), v.iter().copied().fold(0.0, f64::max))
    };
    let quoted = format!("| {} / {} ", range("resnet"), range("snn"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    assert!(readme.contains(&quoted), "the README quotes the EV row as the table gives it: {quoted}");
}

#[test]
fn ueb_print_is_read_back_from_its_cells_and_scored_exactly_and_blind() {
    // eval words in UEB: the cells of "The children, 12." are 2 + 3 + 4 = 9 (⠠⠮ ⠡⠝⠂ ⠼⠁⠃⠲)
    let print = "The children, 12.";
    let board = format!("text:{print}");
    // the same print, speed and depth for eval words and for simulate
    let common = ["--braille", "ueb-g2", "--board", &board, "--speed", "16", "--depth", "1.0"];
    let o = braille(&[&["eval", "words", "--trials", "1", "--json"][..], &common].concat());
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(
        (v["code"].as_str(), v["cells_printed"].as_u64(), v["lines"].as_u64()),
        (Some("ueb-g2"), Some(9), Some(1))
    );
    assert!(v["classifier"].as_str().unwrap().ends_with("ueb/snn-cells.safetensors"), "{}", v["classifier"]);
    let ex = &v["examples"][0];
    assert_eq!(ex[0], print);
    let spells: Vec<&str> = v["by_spell"].as_array().unwrap().iter().map(|s| s["spell"].as_str().unwrap()).collect();
    assert_eq!(spells, ["none", "textblob", "lexicon"]);
    // what the lexicon read, scored exactly: all three words right only if the print is the same
    let lexicon = &v["by_spell"][2];
    let read = ex[2].as_str().unwrap();
    assert_eq!(lexicon["word_accuracy"].as_f64() == Some(1.0), read == print, "{read:?}");
    assert!(v["cell_error_rate"].as_f64().unwrap() < 0.25, "{v}");
    // braille read in UEB: a simulated scan of the same print, read back to print from its events
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("ueb.aedat4");
    let o = braille(&[&["simulate", "--out", file.to_str().unwrap()][..], &common].concat());
    assert!(o.status.success(), "{}", text(&o).1);
    let o = braille(&["read", file.to_str().unwrap(), "--braille", "ueb-g2", "--json"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let (words, summary) = lines(&out);
    assert!(!words.is_empty(), "{out}");
    // a word's raw reading is its cells; its text their print
    assert!(
        words.iter().all(|w| w["raw"].as_str().unwrap().chars().all(|c| ('\u{2801}'..='\u{283F}').contains(&c))),
        "{out}"
    );
    assert_eq!(summary["spell"], "lexicon");
    // the paper's letters cannot take this board
    let o = braille(&["eval", "words", "--board", &board, "--trials", "1"]);
    assert!(!o.status.success());
    assert!(text(&o).1.contains("cannot write ','"), "{}", text(&o).1);
}
