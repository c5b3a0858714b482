//! A whole event source read with bounded memory (a file, or standard input as it arrives): the
//! words as they complete, then what reading gave ([`read_source`], `braille read` and the
//! Python reader).

use crate::classify::ReaderModels;
use crate::error::{Error, Result};
use crate::reader::{ReadWord, ReaderStats, Spell, Speller, Timing};
use serde::Serialize;
use snn::model_file::Arch;
use std::collections::VecDeque;
use std::time::Instant;

/// What reading a whole event source gave: the text, the counters, each network's time, work and
/// per-call latency, and the process's peak memory.
#[derive(Debug, Clone, Serialize)]
pub struct ReadSummary {
    pub summary: bool,
    pub data: String,
    pub arch: Arch,
    pub spell: Spell,
    pub timing: Timing,
    /// Where the segmentation network was read (its model file's calibrated point, or the
    /// paper's).
    pub operating_point: crate::reader::OperatingPoint,
    /// The speed the reader was reading at when the stream ended (its estimate, with estimated
    /// timing).
    pub speed_mm_s: Option<f64>,
    /// The last thousand words read (an endless stream keeps no more).
    pub text: String,
    pub stream_s: f64,
    pub read_s: f64,
    #[serde(flatten)]
    pub stats: ReaderStats,
    /// Time and synaptic operations (SNN) of each network.
    pub segmenter_ms: f64,
    pub classifier_ms: f64,
    pub segmenter_synops: u64,
    pub classifier_synops: u64,
    /// Per call, in microseconds: the segmentation network on every frame, the classifier where
    /// a character is present.
    pub segmenter_us_p50: Option<f64>,
    pub segmenter_us_p99: Option<f64>,
    pub classifier_us_p50: Option<f64>,
    pub classifier_us_p99: Option<f64>,
    pub segmenter_latency: crate::classify::Histogram,
    pub classifier_latency: crate::classify::Histogram,
    /// Per word, in ms of wall time: from the arrival of the chunk holding its last character's
    /// last detection (a live sensor's packet) to the word handed out, which includes the word
    /// gap the filter waits for (stream time the sensor must slide on); and from the arrival of
    /// the chunk that completed the word to the word handed out (the reader's own work). Words
    /// whose last detection arrived more than a minute of stream before are not timed.
    pub words_timed: u64,
    pub word_latency_ms_p50: Option<f64>,
    pub word_latency_ms_p99: Option<f64>,
    pub word_latency_ms_max: Option<f64>,
    pub completion_latency_ms_p50: Option<f64>,
    pub completion_latency_ms_p99: Option<f64>,
    pub peak_rss_mb: Option<f64>,
}

/// What `braille read` prints at the end: what was read, at what cost, and the words' latency.
impl std::fmt::Display for ReadSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "read {:?} from {:.1} s of stream in {:.2} s ({} architecture, spelling {:?}, {} timing, read at {} at the end, {} speed estimates); {} frames, segmentation network on {} ({:.0} ms), classifier on {} ({:.0} ms)",
            self.text,
            self.stream_s,
            self.read_s,
            self.arch,
            self.spell,
            self.timing.mode(),
            self.speed_mm_s.map_or("no speed".into(), |v| format!("{v:.1} mm/s")),
            self.stats.speed_estimates,
            self.stats.frames,
            self.stats.segmenter_calls,
            self.segmenter_ms,
            self.stats.classifier_calls,
            self.classifier_ms
        )?;
        if let (Some(p50), Some(p99), Some(c50)) =
            (self.word_latency_ms_p50, self.word_latency_ms_p99, self.completion_latency_ms_p50)
        {
            writeln!(
                f,
                "word latency over {} words: p50 {p50:.1} ms, p99 {p99:.1} ms from a word's last detection arriving to the word printed (the word gap included); {c50:.2} ms p50 from the events that completed it",
                self.words_timed
            )?;
        }
        if let Some(hz) = self.stats.background_hz_per_pixel {
            writeln!(
                f,
                "background activity about {hz:.2} Hz per pixel (estimated from the {} events the noise filter removed)",
                self.stats.events_denoised
            )?;
        }
        Ok(())
    }
}

/// Wall-time latencies in microseconds, 1 us to an hour, three significant digits, in constant
/// memory.
fn latency_histogram() -> hdrhistogram::Histogram<u64> {
    hdrhistogram::Histogram::new_with_bounds(1, 3_600_000_000, 3).expect("valid bounds")
}

/// How long ago, in us, the chunk holding stream time `t_us` arrived (`arrivals`: each chunk's
/// last event time and its arrival, in order).
fn since_arrival_us(arrivals: &VecDeque<(i64, Instant)>, t_us: i64, now: Instant) -> Option<u64> {
    let k = arrivals.partition_point(|a| a.0 < t_us);
    arrivals.get(k).map(|a| now.duration_since(a.1).as_micros() as u64)
}

/// Stream time the arrivals of chunks are kept for ([`ReadSummary::word_latency_ms_p50`]).
const ARRIVALS_KEPT_US: i64 = 60_000_000;

/// Reads `source` chunk by chunk with bounded memory, words spelled by `speller` (a cell
/// reader's back-translated by its code: [`Speller::in_code`]) (a file, standard input or a live stream as
/// it arrives), handing each word to `on_word` as it completes. `name` names the source in
/// errors. A source that fails (a stalled sender, a truncated or garbled packet) ends the stream
/// where it failed: the characters read until then are handed out as the last word, then the
/// error is returned.
pub fn read_source(
    source: &mut dyn encoders::EventSource,
    name: &str,
    readers: &ReaderModels,
    timing: Timing,
    resolution: encoders::Resolution,
    speller: &Speller,
    on_word: &mut dyn FnMut(&ReadWord) -> Result<()>,
) -> Result<ReadSummary> {
    use crate::reader::ReadOutput;
    let spell = speller.spell();
    let started = Instant::now();
    let mut reader = readers.stream(timing, resolution, speller)?;
    let (mut out, mut text) = (Vec::new(), VecDeque::<String>::new());
    let (mut first, mut last) = (None, 0i64);
    let mut arrivals: VecDeque<(i64, Instant)> = VecDeque::new();
    let (mut word_latency, mut completion_latency) = (latency_histogram(), latency_histogram());
    let mut emit = |out: &mut Vec<ReadOutput>,
                    text: &mut VecDeque<String>,
                    arrivals: &VecDeque<(i64, Instant)>,
                    arrived: Instant|
     -> Result<()> {
        for o in out.drain(..) {
            if let ReadOutput::Word(w) = o {
                let now = Instant::now();
                if let Some(us) = w.chars.last().and_then(|c| since_arrival_us(arrivals, c.t_end_us, now)) {
                    word_latency.saturating_record(us.max(1));
                    completion_latency.saturating_record((now.duration_since(arrived).as_micros() as u64).max(1));
                }
                on_word(&w)?;
                text.push_back(if w.unreadable { "[unreadable]".to_string() } else { w.text });
                if text.len() > 1000 {
                    text.pop_front();
                }
            }
        }
        Ok(())
    };
    let at = |e: Error| Error::Source { name: name.to_string(), source: Box::new(e) };
    let mut failed = None;
    loop {
        let chunk = match source.next_chunk() {
            Ok(Some(chunk)) => chunk,
            Ok(None) => break,
            Err(e) => {
                failed = Some(e);
                break;
            }
        };
        let arrived = Instant::now();
        first.get_or_insert(chunk[0].t_us);
        last = chunk[chunk.len() - 1].t_us;
        arrivals.push_back((last, arrived));
        while arrivals.front().is_some_and(|a| a.0 < last - ARRIVALS_KEPT_US) {
            arrivals.pop_front();
        }
        reader.push_all(chunk, &mut out).map_err(at)?;
        emit(&mut out, &mut text, &arrivals, arrived)?;
    }
    reader.finish(&mut out).map_err(at)?;
    emit(&mut out, &mut text, &arrivals, Instant::now())?;
    if let Some(e) = failed {
        return Err(Error::Read { name: name.to_string(), source: Box::new(e) });
    }
    let stats = reader.stats.clone();
    let (seg, cls) = reader.into_states();
    let us = |h: &crate::classify::Histogram, q: f64| h.quantile_ns(q).map(|n| n / 1e3);
    let ms = |h: &hdrhistogram::Histogram<u64>, q: f64| (!h.is_empty()).then(|| h.value_at_quantile(q) as f64 / 1e3);
    Ok(ReadSummary {
        summary: true,
        data: name.to_string(),
        arch: readers.classifier.arch(),
        spell,
        timing,
        operating_point: readers.operating_point().clone(),
        speed_mm_s: stats.speed_mm_s,
        text: text.into_iter().collect::<Vec<_>>().join(" "),
        stream_s: first.map_or(0.0, |f| (last - f) as f64 / 1e6),
        read_s: started.elapsed().as_secs_f64(),
        stats,
        segmenter_ms: seg.stats.nanos as f64 / 1e6,
        classifier_ms: cls.stats.nanos as f64 / 1e6,
        segmenter_synops: seg.stats.synops,
        classifier_synops: cls.stats.synops,
        segmenter_us_p50: us(&seg.stats.latency, 0.5),
        segmenter_us_p99: us(&seg.stats.latency, 0.99),
        classifier_us_p50: us(&cls.stats.latency, 0.5),
        classifier_us_p99: us(&cls.stats.latency, 0.99),
        segmenter_latency: seg.stats.latency,
        classifier_latency: cls.stats.latency,
        words_timed: word_latency.len(),
        word_latency_ms_p50: ms(&word_latency, 0.5),
        word_latency_ms_p99: ms(&word_latency, 0.99),
        word_latency_ms_max: (!word_latency.is_empty()).then(|| word_latency.max() as f64 / 1e3),
        completion_latency_ms_p50: ms(&completion_latency, 0.5),
        completion_latency_ms_p99: ms(&completion_latency, 0.99),
        peak_rss_mb: peak_rss_mb(),
    })
}

/// Starts a new peak for [`peak_rss_mb`] (Linux: `/proc/self/clear_refs`); whether it could.
pub fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// Peak resident memory of this process (Linux), in MB.
pub fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}
