use super::*;
use crate::error::Result;
use crate::labeling::LabelerConfig;
use encoders::Event;
use encoders::Polarity;
use encoders::Resolution;
use encoders::pooling::PoolMap;

#[test]
fn an_operating_point_keeps_its_threshold_as_written_through_a_json_value() {
    let p = OperatingPoint { present_threshold: 0.95, ..OperatingPoint::PAPER };
    let v = serde_json::to_value(&p).unwrap();
    assert_eq!(v["present_threshold"].as_f64(), Some(0.95));
    let back: OperatingPoint = serde_json::from_value(v).unwrap();
    assert_eq!(back, p);
    assert_eq!(f32_as_printed(0.3), 0.3);
}

/// A segmenter that sees a character when the window holds at least `min` events, and a
/// classifier that reads the letter from the newest non-empty bin's first column (A + col % 26).
struct Count(f32);
impl WindowClassifier for Count {
    type State = ();
    fn new_state(&self) {}
    fn classify(&self, _: &mut (), w: &Window) -> Result<Vec<f32>> {
        let n: f32 = w.bins().flat_map(|b| b.iter().map(|c| c.count)).sum();
        Ok(if n >= self.0 { vec![0.0, 1.0] } else { vec![1.0, 0.0] })
    }
}
/// The pooled column of the newest non-empty bin's first cell (0 for an empty window).
fn newest_col(w: &Window) -> usize {
    w.bins().filter(|b| !b.is_empty()).last().map_or(0, |b| b[0].input as usize % w.width)
}

struct Column;
impl WindowClassifier for Column {
    type State = ();
    fn new_state(&self) {}
    fn classify(&self, _: &mut (), w: &Window) -> Result<Vec<f32>> {
        let mut p = vec![0.0; 26];
        p[newest_col(w) % 26] = 1.0;
        Ok(p)
    }
}

/// Events at pooled column `col` (pixel 4 col) every 5 ms over `[from, to)` ms.
fn burst(col: u16, from_ms: i64, to_ms: i64) -> Vec<Event> {
    (from_ms..to_ms).step_by(5).map(|t| Event { t_us: t * 1000, x: 4 * col, y: 200, polarity: Polarity::On }).collect()
}

fn read(events: Vec<Event>, cfg: ReaderConfig) -> (Vec<ReadWord>, ReaderStats) {
    let speller = Speller::new(Spell::None);
    let r = read_all(&events, cfg, Resolution::DVXPLORER, &Count(1.0), &Column, &speller).unwrap();
    (r.words, r.stats)
}

#[test]
fn bursts_become_letters_and_silences_words() {
    // pooled columns 20 + k read as letter (20 + k) % 26: U, V, W...; 8 mm/s, 10 ms frames
    let mut ev = burst(20, 0, 100); // U
    ev.extend(burst(21, 400, 500)); // V, 300 ms later: same word
    ev.extend(burst(22, 2_000, 2_100)); // W, after more than 1 s of silence: a new word
    let (words, stats) = read(ev, ReaderConfig::at_speed(8.0));
    let text: Vec<&str> = words.iter().map(|w| w.raw.as_str()).collect();
    assert_eq!(text, ["UV", "W"]);
    assert!(stats.frames_empty > 0 && stats.segmenter_calls > 0);
    // a character registers once its segment has ended: after its last detection, before the
    // next burst
    let u = &words[0].chars[0];
    assert_eq!(u.t_registered_us, u.t_end_us + 70_000, "{u:?}");
    assert!(u.t_registered_us < 400_000, "{u:?}");
}

#[test]
fn the_denoiser_drops_lone_events_before_the_reader_sees_them() {
    // lone events 1.5 s apart: each a letter to this segmenter without the filter
    let lone: Vec<Event> = (0..5)
        .map(|k| Event { t_us: k * 1_500_000 + 1_000, x: 4 * (20 + k as u16), y: 200, polarity: Polarity::On })
        .collect();
    assert!(!read(lone.clone(), ReaderConfig::at_speed(8.0)).0.is_empty());
    let cfg =
        ReaderConfig { denoise: Some(encoders::denoise::NoiseFilterSettings::DV_LAB), ..ReaderConfig::at_speed(8.0) };
    let (words, stats) = read(lone, cfg.clone());
    assert!(words.is_empty() && (stats.events, stats.events_denoised) == (5, 5), "{stats:?}");
    // a contact's events come in neighbouring pixels: pairs 10 us apart every 5 ms pass where
    // the second of a pair follows the first; the first follows the last pair's second 5 ms
    // later, outside the 2 ms window, and is dropped
    let pairs: Vec<Event> = [burst(20, 0, 100), burst(22, 2_000, 2_100)]
        .concat()
        .into_iter()
        .flat_map(|e| [e, Event { t_us: e.t_us + 10, x: e.x + 1, ..e }])
        .collect();
    let (words, stats) = read(pairs.clone(), cfg);
    let text = |words: &[ReadWord]| words.iter().map(|w| w.raw.clone()).collect::<Vec<_>>();
    assert_eq!(text(&words), ["U", "W"], "{stats:?}");
    assert_eq!((stats.events, stats.events_denoised), (80, 40));
    assert_eq!(text(&read(pairs, ReaderConfig::at_speed(8.0)).0), ["U", "W"]);
}

/// A cell classifier: pooled column 20 reads ⠉ (dots 1 and 4), any other ⠁ (dot 1, a cell of
/// one column), with a little probability on ⠈ (dot 4, its twin in the right column).
struct Cells;
impl WindowClassifier for Cells {
    type State = ();
    fn new_state(&self) {}
    fn classify(&self, _: &mut (), w: &Window) -> Result<Vec<f32>> {
        let mut p = vec![0.0; 63];
        if newest_col(w) == 20 {
            p[0b001_001 - 1] = 1.0;
        } else {
            (p[0], p[0b001_000 - 1]) = (0.75, 0.25);
        }
        Ok(p)
    }
}

#[test]
fn a_cell_of_one_column_is_placed_on_the_grid_its_neighbours_draw() {
    // at 8 mm/s a cell spacing (6 mm) is 750 ms and the columns 2.5 mm (312 ms) apart. A burst
    // that follows the stream's first 200 ms and precedes more events is detected from 10 ms
    // after its start until its window has passed: its segment's middle is 150 ms after its
    // start, and a lone column's mark the labeler's 280 ms before that. A lone column a whole
    // spacing from ⠉'s right column is ⠈, one a dot spacing short of that ⠁. A burst at 0 ms
    // and one at 6 s, words of their own, frame the row.
    let speller = Speller::new(Spell::None);
    let row = |lone_ms: i64| {
        let mut ev = burst(23, 0, 100);
        ev.extend(burst(20, 2_000, 2_100));
        ev.extend(burst(21, lone_ms, lone_ms + 100));
        ev.extend(burst(23, 6_000, 6_100));
        ev
    };
    let (right_ms, left_ms) = (2_000 + 280 + 750, 2_000 + 280 + 750 - 312);
    for (lone_ms, want, p_left, p_right) in [(right_ms, '⠈', 0.0f32, 1.0f32), (left_ms, '⠁', 1.0, 0.0)] {
        let mut r =
            StreamReader::new(ReaderConfig::at_speed(8.0), Resolution::DVXPLORER, &Count(1.0), &Cells, &speller)
                .unwrap();
        let mut out = Vec::new();
        r.push_all(&row(lone_ms), &mut out).unwrap();
        r.finish(&mut out).unwrap();
        let chars: String =
            out.iter().filter_map(|o| if let ReadOutput::Char(c) = o { Some(c.letter) } else { None }).collect();
        let words: Vec<&ReadWord> =
            out.iter().filter_map(|o| if let ReadOutput::Word(w) = o { Some(w) } else { None }).collect();
        // the framing words are lone columns with no two-column neighbour in reach: as read
        let raw: Vec<&str> = words.iter().map(|w| w.raw.as_str()).collect();
        assert_eq!(raw, ["⠁", &format!("⠉{want}"), "⠁"], "lone column at {lone_ms} ms");
        // the characters given out are the words' (placed)
        assert_eq!(chars, raw.concat());
        let lone = &words[1].chars[1];
        assert_eq!((lone.probs[0], lone.probs[7]), (p_left, p_right));
    }
    // without the grid the classifier's column stands
    let cfg = ReaderConfig { cell_grid: None, ..ReaderConfig::at_speed(8.0) };
    let r = read_all(&row(right_ms), cfg, Resolution::DVXPLORER, &Count(1.0), &Cells, &speller).unwrap();
    assert_eq!(r.words[1].raw, "⠉⠁");
}

#[test]
fn a_reader_that_abstains_marks_letters_that_make_no_word() {
    // pooled column c reads letter c % 26: 26 + 0 = A, 26 + 19 = T ("AT"), then after a word gap
    // 26 + 16 = Q, 26 + 23 = X, 26 + 25 = Z ("QXZ"), all read with certainty
    let mut ev = burst(26, 0, 100);
    ev.extend(burst(45, 400, 500));
    ev.extend(burst(42, 2_000, 2_100));
    ev.extend(burst(49, 2_400, 2_500));
    ev.extend(burst(51, 2_800, 2_900));
    let (words, stats) = read(ev.clone(), ReaderConfig::at_speed(8.0));
    assert_eq!(
        words.iter().map(|w| (w.raw.as_str(), w.unreadable)).collect::<Vec<_>>(),
        [("AT", false), ("QXZ", false)]
    );
    assert!(words.iter().all(|w| w.lexicon_score_per_char.is_none()) && stats.words_unreadable == 0);
    let cfg = ReaderConfig { abstain_below_score_per_char: Some(-2.5), ..ReaderConfig::at_speed(8.0) };
    let (words, stats) = read(ev, cfg);
    assert_eq!(
        words.iter().map(|w| (w.raw.as_str(), w.unreadable)).collect::<Vec<_>>(),
        [("AT", false), ("QXZ", true)]
    );
    assert!(
        words[0].lexicon_score_per_char.unwrap() > -2.0 && words[1].lexicon_score_per_char.unwrap() < -3.0,
        "{words:?}"
    );
    assert_eq!(stats.words_unreadable, 1);
    assert!(words[1].to_string().contains("[unreadable]") && words[1].to_string().contains("QXZ"));
}

#[test]
fn a_reader_that_filters_estimates_the_background_from_what_it_drops() {
    // isolated events, one every 10 ms at pixels far apart over 2 s: all background to the filter
    let ev: Vec<Event> = (0..200i64)
        .map(|k| Event {
            t_us: k * 10_000,
            x: (k as u16 * 37) % 600 + 10,
            y: (k as u16 * 53) % 400 + 10,
            polarity: Polarity::On,
        })
        .collect();
    let (_, stats) = read(ev.clone(), ReaderConfig::at_speed(8.0));
    assert_eq!(stats.background_hz_per_pixel, None);
    let lab = Some(encoders::denoise::NoiseFilterSettings::DV_LAB);
    let (_, stats) = read(ev, ReaderConfig { denoise: lab, ..ReaderConfig::at_speed(8.0) });
    let pixels = f64::from(Resolution::DVXPLORER.width) * f64::from(Resolution::DVXPLORER.height);
    let want = 200.0 / pixels / 1.99;
    let got = stats.background_hz_per_pixel.unwrap();
    assert_eq!(stats.events_denoised, 200);
    assert!((got / want - 1.0).abs() < 1e-3, "{got} {want}");
}

#[test]
fn durations_scale_with_speed() {
    // at 32 mm/s frames are 2.5 ms, windows 50 ms and the word gap 250 ms: 340 ms of silence
    // between bursts splits words; at 8 mm/s it does not
    let mut ev = burst(20, 0, 60);
    ev.extend(burst(21, 400, 460));
    let (words, _) = read(ev.clone(), ReaderConfig::at_speed(32.0));
    assert_eq!(words.iter().map(|w| w.raw.as_str()).collect::<Vec<_>>(), ["U", "V"]);
    let (words, _) = read(ev, ReaderConfig::at_speed(8.0));
    assert_eq!(words.iter().map(|w| w.raw.as_str()).collect::<Vec<_>>(), ["UV"]);
}

#[test]
fn events_out_of_order_are_an_error_and_masked_columns_are_dropped() {
    let mut ev = burst(20, 0, 100);
    ev.push(Event { t_us: 50_000, x: 80, y: 10, polarity: Polarity::Off });
    let speller = Speller::new(Spell::None);
    let e = read_all(&ev, ReaderConfig::at_speed(8.0), Resolution::DVXPLORER, &Count(1.0), &Column, &speller)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("event 20") && e.contains("back in time"), "{e}");
    let (words, stats) = read(burst(5, 0, 100), ReaderConfig::at_speed(8.0));
    assert!(words.is_empty());
    assert_eq!(stats.events_masked, 20);
}

#[test]
fn an_hour_of_stream_is_read_with_bounded_memory() {
    // every 600 ms a 100 ms burst (letters U..Y by column), a word of five, then 1.5 s of
    // silence; an hour of it, handed in a chunk of a second at a time as a live sensor would
    let speller = Speller::new(Spell::None);
    let mut r =
        StreamReader::new(ReaderConfig::at_speed(8.0), Resolution::DVXPLORER, &Count(1.0), &Column, &speller).unwrap();
    let (mut out, mut words, mut peak, mut chunk) = (Vec::new(), 0usize, 0usize, Vec::new());
    let mut t_ms = 0i64;
    let word_ms = 5 * 600 + 1500;
    let mut letters = 0;
    while t_ms < 3_600_000 {
        let k = (t_ms % word_ms) / 600;
        if k < 5 && t_ms % 600 == 0 {
            chunk.extend(burst(20 + k as u16, t_ms, t_ms + 100));
            letters += 1;
        }
        t_ms += 100;
        if t_ms % 1000 == 0 {
            r.push_all(&chunk, &mut out).unwrap();
            chunk.clear();
            words += out.drain(..).filter(|o| matches!(o, ReadOutput::Word(w) if w.raw == "UVWXY")).count();
            peak = peak.max(r.memory_bytes());
        }
    }
    r.push_all(&chunk, &mut out).unwrap();
    r.finish(&mut out).unwrap();
    words += out.drain(..).filter(|o| matches!(o, ReadOutput::Word(w) if w.raw == "UVWXY")).count();
    assert_eq!(r.stats.characters as usize, letters, "every letter of the hour is read");
    assert_eq!(words, 800, "every word of the hour is read");
    assert!(peak < 300_000, "the reader held {peak} bytes");
}

#[test]
fn streams_read_in_parallel_give_what_they_give_read_one_by_one() {
    let streams: Vec<Vec<Event>> = (0..6u16)
        .map(|s| {
            (0..5i64).flat_map(|k| burst(20 + (s + k as u16) % 7, k * 700 + s as i64 * 13, k * 700 + 120)).collect()
        })
        .collect();
    let one = |ev: &Vec<Event>| read(ev.clone(), ReaderConfig::at_speed(8.0));
    let sequential: Vec<_> = streams.iter().map(one).collect();
    let parallel: Vec<_> = std::thread::scope(|sc| {
        let handles: Vec<_> = streams.iter().map(|ev| sc.spawn(move || one(ev))).collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert_eq!(sequential, parallel);
    assert!(sequential.iter().all(|(w, _)| w.len() == 1 && w[0].raw.len() == 5), "{sequential:?}");
}

#[test]
fn a_word_without_end_is_given_out_in_pieces() {
    let mut ev = Vec::new();
    for k in 0..10 {
        ev.extend(burst(20 + (k % 3) as u16, k * 600, k * 600 + 100));
    }
    let cfg = ReaderConfig { max_word_chars: 4, ..ReaderConfig::at_speed(8.0) };
    let (words, stats) = read(ev, cfg);
    assert_eq!(words.iter().map(|w| w.raw.as_str()).collect::<Vec<_>>(), ["UVWU", "VWUV", "WU"]);
    assert_eq!(stats.characters, 10);
}

/// Events of `events` in masked columns (what `events_masked` counts once each is binned).
fn masked(events: &[Event]) -> u64 {
    let l = LabelerConfig::default();
    let map = PoolMap::new(Resolution::DVXPLORER, l.pool, Some(&l.active_cols)).unwrap();
    events.iter().filter(|e| map.cell(e.x, e.y).is_none()).count() as u64
}

#[test]
fn events_handed_in_runs_read_as_events_handed_in_one_at_a_time() {
    // `push_all`'s binning loop and the runs it hands the speed estimator, against `push`,
    // on a stream with events off the sensor in some runs (the estimator's slow path)
    let speller = Speller::new(Spell::None);
    let mut ev = crate::speed::tests::moving(32.0, true, 0.05, 1.5, 5);
    for (k, e) in ev.iter_mut().enumerate().filter(|(k, _)| k % 997 < 3) {
        (e.x, e.y) = if k % 2 == 0 { (640, e.y) } else { (e.x, 481) };
    }
    let read = |all: bool| {
        let cfg = ReaderConfig::new(Timing::ESTIMATED);
        let mut r = StreamReader::new(cfg, Resolution::DVXPLORER, &Count(1.0), &Column, &speller).unwrap();
        let mut out = Vec::new();
        if all {
            for chunk in ev.chunks(7_777) {
                r.push_all(chunk, &mut out).unwrap();
            }
        } else {
            for e in &ev {
                r.push(e, &mut out).unwrap();
            }
        }
        r.finish(&mut out).unwrap();
        // the estimator's whole state: the events it kept, their weights, its counters
        (r.stats.speed_estimates, format!("{:?}", r.stats), format!("{out:?}"), format!("{:?}", r.estimator))
    };
    let (one, all) = (read(false), read(true));
    assert!(one.0 > 0, "{}", one.1);
    assert_eq!(one, all);
}

#[test]
fn the_reader_reads_at_the_speed_it_estimates_and_loses_no_held_event() {
    let speller = Speller::new(Spell::None);
    for (speed, forward) in [(8.0, true), (32.0, false), (64.0, true)] {
        let ev = crate::speed::tests::moving(speed, forward, 0.05, 1.5, 11);
        let mut r = StreamReader::new(
            ReaderConfig::new(Timing::ESTIMATED),
            Resolution::DVXPLORER,
            &Count(1.0),
            &Column,
            &speller,
        )
        .unwrap();
        let mut out = Vec::new();
        // in chunks, as a live sensor hands them in
        for chunk in ev.chunks(7_777) {
            r.push_all(chunk, &mut out).unwrap();
        }
        let read_at = r.speed_mm_s().unwrap();
        assert!((read_at / speed - 1.0).abs() < 0.06, "{speed} mm/s read at {read_at}");
        let bin = 10_000.0 * 8.0 / speed;
        assert!((r.bin_us() as f64 / bin - 1.0).abs() < 0.06, "{speed} mm/s: {} us bins", r.bin_us());
        r.finish(&mut out).unwrap();
        assert_eq!(r.stats.events, ev.len() as u64);
        assert_eq!(r.stats.events_masked, masked(&ev), "every event held for the first estimate is read");
        assert!(r.stats.speed_estimates > 10, "{:?}", r.stats);
        // characters carry the speed they were read at
        for o in &out {
            if let ReadOutput::Char(c) = o {
                assert!(c.speed_mm_s.is_some_and(|v| (v / speed - 1.0).abs() < 0.3), "{c:?}");
            }
        }
    }
}

#[test]
fn without_an_estimate_reading_starts_at_the_reference_speed_after_the_hold() {
    // noise alone never gives an estimate: after 1 s of stream held the reader starts at
    // 8 mm/s, and reads every event
    let ev: Vec<Event> = crate::speed::tests::moving(8.0, true, 0.5, 2.0, 3)
        .into_iter()
        .filter(|e| e.polarity == Polarity::Off)
        .collect();
    let speller = Speller::new(Spell::None);
    let cfg = ReaderConfig::new(Timing::ESTIMATED);
    let mut r = StreamReader::new(cfg, Resolution::DVXPLORER, &Count(1e9), &Column, &speller).unwrap();
    let mut out = Vec::new();
    r.push_all(&ev[..ev.len() / 4], &mut out).unwrap();
    assert_eq!(r.speed_mm_s(), None, "still holding");
    r.push_all(&ev[ev.len() / 4..], &mut out).unwrap();
    assert_eq!(r.speed_mm_s(), Some(8.0));
    r.finish(&mut out).unwrap();
    assert_eq!(r.stats.events_masked, masked(&ev));
    assert_eq!(r.stats.speed_estimates, 0);
}

#[test]
fn paper_timing_is_fixed_and_a_hint_starts_reading_at_once() {
    let speller = Speller::new(Spell::None);
    let new =
        |t: Timing| StreamReader::new(ReaderConfig::new(t), Resolution::DVXPLORER, &Count(1.0), &Column, &speller);
    let paper = new(Timing::Paper).unwrap();
    assert_eq!((paper.bin_us(), paper.speed_mm_s()), (10_000, Some(8.0)));
    let hinted = new(Timing::Estimated { hint_mm_s: Some(16.0) }).unwrap();
    assert_eq!((hinted.bin_us(), hinted.speed_mm_s()), (5_000, Some(16.0)));
    assert!(new(Timing::Given { speed_mm_s: -1.0 }).is_err());
    assert!(Timing::from_mode(TimingMode::Given, None).is_err());
    assert_eq!(
        Timing::from_mode(TimingMode::Estimated, Some(3.0)).unwrap(),
        Timing::Estimated { hint_mm_s: Some(3.0) }
    );
    // a paper reader of a 32 mm/s stream keeps 10 ms bins: the paper's protocol
    let ev = crate::speed::tests::moving(32.0, true, 0.05, 1.0, 5);
    let r =
        read_all(&ev, ReaderConfig::new(Timing::Paper), Resolution::DVXPLORER, &Count(1.0), &Column, &speller).unwrap();
    assert_eq!((r.stats.speed_estimates, r.stats.speed_mm_s), (0, Some(8.0)));
}

#[test]
fn the_window_is_the_labelers_heat_map() {
    // the reader's window equals the labeler's heat map of the same span
    struct Grab;
    impl WindowClassifier for Grab {
        type State = Vec<encoders::heatmap::Heatmap>;
        fn new_state(&self) -> Self::State {
            Vec::new()
        }
        fn classify(&self, grabbed: &mut Self::State, w: &Window) -> Result<Vec<f32>> {
            grabbed.push(w.heatmap());
            Ok(vec![1.0, 0.0])
        }
    }
    let ev: Vec<Event> = (0..4000)
        .map(|k| Event {
            t_us: k * 97,
            x: ((k * 37) % 640) as u16,
            y: ((k * 53) % 480) as u16,
            polarity: if k % 3 == 0 { Polarity::Off } else { Polarity::On },
        })
        .collect();
    let cfg = ReaderConfig::at_speed(8.0);
    let speller = Speller::new(Spell::None);
    let grabbed = read_all(&ev, cfg.clone(), Resolution::DVXPLORER, &Grab, &Column, &speller).unwrap().segmenter;
    assert!(grabbed.len() > 10);
    let l = &cfg.labeler;
    let enc = encoders::heatmap::HeatmapEncoder::new(
        encoders::heatmap::HeatmapConfig::new(Resolution::DVXPLORER)
            .with_pool(l.pool)
            .with_bin_us(l.bin_us(8.0))
            .with_mask_cols(l.active_cols.clone()),
    )
    .unwrap();
    for w in &grabbed {
        let a = ev.partition_point(|e| e.t_us < w.t_start_us);
        let b = ev.partition_point(|e| e.t_us < w.t_end_us());
        assert_eq!(w, &enc.encode(&ev[a..b], w.t_start_us, l.frames));
    }
}
