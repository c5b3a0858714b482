//! Word reading on SIMULATED scans: each architecture reads every scan of a board from its raw
//! event stream, and the lines are scored with the paper's four conditional metrics
//! (`braille eval words`, the speed table).

use crate::Progress;
use crate::error::Result;
use crate::scoring::WordMetrics;
use pipeline::classify::ReaderModels;
use pipeline::reader::{ReadWord, ReaderStats, Spell, Speller};
use rayon::prelude::*;
use serde::Serialize;
use sim::BoardKind;
use snn::model_file::Arch;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The three spellings, in the order reports give them.
pub const SPELLS: [Spell; 3] = [Spell::None, Spell::Textblob, Spell::Lexicon];

/// What one architecture read on a set of scans.
#[derive(Debug, Clone, Serialize)]
pub struct WordsScore {
    pub arch: Arch,
    pub speed_mm_s: f64,
    pub depth_mm: f64,
    pub lines: usize,
    /// Per spelling (none, textblob, lexicon): the paper's four metrics.
    pub by_spell: Vec<SpellScore>,
    /// Seconds of stream read, and the wall time reading took (segmentation, classifier,
    /// filter; not the simulation).
    pub stream_s: f64,
    pub read_s: f64,
    /// Stream time from the last event a character's detections used to its registration.
    pub registration_delay_ms_mean: f64,
    pub registration_delay_ms_max: f64,
    pub frames: u64,
    pub segmenter_calls: u64,
    pub classifier_calls: u64,
    pub segmenter_ms: f64,
    pub classifier_ms: f64,
    pub synops: u64,
    /// Every line: truth and what was read (raw letters; spelled by the lexicon decoder).
    pub examples: Vec<(String, String, String)>,
}

#[derive(Debug, Clone, Serialize)]
pub struct SpellScore {
    pub spell: Spell,
    /// Unconditional, over every printed word: words read right (aligned to the line), and the
    /// word and character error rates.
    pub word_accuracy: f64,
    pub word_error_rate: f64,
    pub char_error_rate: f64,
    /// The paper's four conditional metrics.
    pub words_per_line: f64,
    pub letters_per_word: f64,
    pub correct_words: f64,
    pub correct_letters: f64,
    pub counts: WordMetrics,
}

/// One simulated scan, read.
pub struct LineRead {
    /// The row's words as printed.
    pub truth: Vec<String>,
    pub words: Vec<ReadWord>,
    pub stats: ReaderStats,
    /// Seconds of stream, and the wall time reading took.
    pub stream_s: f64,
    pub read_s: f64,
    /// Time in the segmentation network and in the classifier, and synaptic operations (SNN).
    pub seg_ns: u64,
    pub cls_ns: u64,
    pub synops: u64,
}

/// Which scans to read.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WordsSpec {
    pub board: BoardKind,
    pub speed_mm_s: f64,
    pub depth_mm: f64,
    /// Scans per board row.
    pub trials: u64,
    pub seed: u64,
    /// The simulated world of the scans.
    pub world: crate::datasets::World,
}

/// The shipped models of each architecture under `models`: (segmentation network, character
/// classifier).
pub fn default_models(arch: Arch, models: &Path) -> (PathBuf, PathBuf) {
    let (s, c) = match arch {
        Arch::Resnet => ("resnet-tiny-segment.safetensors", "resnet-lite-normaug-words.safetensors"),
        Arch::Snn => ("snn-segment.safetensors", "snn-words.safetensors"),
    };
    (models.join(s), models.join(c))
}

/// The scans of every row of the board, `trials` each, read by each of `readers` (each scan
/// simulated once for all; the models are shared by the threads); `[scan][reader]`.
pub fn read_scans(spec: &WordsSpec, readers: &[&ReaderModels], progress: &dyn Progress) -> Result<Vec<Vec<LineRead>>> {
    let (board, speed_mm_s, depth_mm) = (&spec.board, spec.speed_mm_s, spec.depth_mm);
    let setup = spec.world.setup();
    let b = spec.world.board(&setup, board)?;
    let sensors = spec.world.sensors_at(&setup, encoders::Resolution::DVXPLORER)?;
    let jobs: Vec<(usize, u64)> = (0..b.rows.len()).flat_map(|r| (0..spec.trials).map(move |t| (r, t))).collect();
    progress.start("reading simulated scans", jobs.len() as u64);
    let speller = Speller::new(Spell::None);
    let lines: Vec<Vec<LineRead>> = jobs
        .par_iter()
        .map(|&(row, trial)| -> Result<Vec<LineRead>> {
            let scan_seed = spec.world.scan_seed(spec.seed, board, row, trial, speed_mm_s, depth_mm);
            let sensor = &sensors[(trial % sensors.len() as u64) as usize];
            let s = sim::simulate(&b, sensor, &setup.scan(speed_mm_s, depth_mm, row, scan_seed))?;
            let truth: Vec<String> = s.truth.row_text.split_whitespace().map(str::to_string).collect();
            let stream_s = s.events.last().map_or(0.0, |e| e.t_us as f64 / 1e6);
            let mut out = Vec::new();
            for r in readers {
                let t = Instant::now();
                let read = r.read(&s.events, sensor.camera.resolution, speed_mm_s, &speller)?;
                out.push(LineRead {
                    truth: truth.clone(),
                    words: read.words,
                    stats: read.stats,
                    stream_s,
                    read_s: t.elapsed().as_secs_f64(),
                    seg_ns: read.segmenter.stats.nanos,
                    cls_ns: read.classifier.stats.nanos,
                    synops: read.segmenter.stats.synops + read.classifier.stats.synops,
                });
            }
            progress.inc();
            Ok(out)
        })
        .collect::<Result<_>>()?;
    progress.finish();
    Ok(lines)
}

/// Scores the lines of reader `k` (`lines[scan][k]`), an `arch` reader.
pub fn score(arch: Arch, k: usize, lines: &[Vec<LineRead>], speed_mm_s: f64, depth_mm: f64) -> WordsScore {
    let spellers: Vec<Speller> = SPELLS.iter().map(|&s| Speller::new(s)).collect();
    let mut metrics = vec![WordMetrics::default(); SPELLS.len()];
    let (mut delays, mut examples) = (Vec::new(), Vec::new());
    let mut s = WordsScore {
        arch,
        speed_mm_s,
        depth_mm,
        lines: lines.len(),
        by_spell: Vec::new(),
        stream_s: 0.0,
        read_s: 0.0,
        registration_delay_ms_mean: 0.0,
        registration_delay_ms_max: 0.0,
        frames: 0,
        segmenter_calls: 0,
        classifier_calls: 0,
        segmenter_ms: 0.0,
        classifier_ms: 0.0,
        synops: 0,
        examples: Vec::new(),
    };
    for scan in lines {
        let l = &scan[k];
        for (m, sp) in metrics.iter_mut().zip(&spellers) {
            let read: Vec<String> = l.words.iter().map(|w| sp.correct(&w.chars)).collect();
            m.add_line(&l.truth, &read);
        }
        let raw: Vec<String> = l.words.iter().map(|w| w.raw.clone()).collect();
        let lex: Vec<String> = l.words.iter().map(|w| spellers[2].correct(&w.chars)).collect();
        examples.push((l.truth.join(" "), raw.join(" "), lex.join(" ")));
        delays
            .extend(l.words.iter().flat_map(|w| w.chars.iter().map(|c| (c.t_registered_us - c.t_end_us) as f64 / 1e3)));
        s.stream_s += l.stream_s;
        s.read_s += l.read_s;
        s.frames += l.stats.frames;
        s.segmenter_calls += l.stats.segmenter_calls;
        s.classifier_calls += l.stats.classifier_calls;
        s.segmenter_ms += l.seg_ns as f64 / 1e6;
        s.classifier_ms += l.cls_ns as f64 / 1e6;
        s.synops += l.synops;
    }
    s.registration_delay_ms_mean = delays.iter().sum::<f64>() / delays.len().max(1) as f64;
    s.registration_delay_ms_max = delays.iter().copied().fold(0.0, f64::max);
    s.by_spell = SPELLS
        .iter()
        .zip(metrics)
        .map(|(&spell, m)| SpellScore {
            spell,
            word_accuracy: m.word_accuracy(),
            word_error_rate: m.word_error_rate(),
            char_error_rate: m.char_error_rate(),
            words_per_line: m.words_per_line(),
            letters_per_word: m.letters_per_word(),
            correct_words: m.correct_words_rate(),
            correct_letters: m.correct_letters_rate(),
            counts: m,
        })
        .collect();
    s.examples = examples;
    s
}

/// What reading a whole event source gave: the text, the counters, each network's time, work and
/// per-call latency, and the process's peak memory.
#[derive(Debug, Clone, Serialize)]
pub struct ReadSummary {
    pub summary: bool,
    pub data: String,
    pub arch: Arch,
    pub spell: Spell,
    pub speed_mm_s: f64,
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
    pub segmenter_latency: pipeline::classify::Histogram,
    pub classifier_latency: pipeline::classify::Histogram,
    pub peak_rss_mb: Option<f64>,
}

/// Reads `source` chunk by chunk with bounded memory (a file, or standard input as it arrives),
/// handing each word to `on_word` as it completes. `name` names the source in errors.
pub fn read_source(
    source: &mut dyn encoders::EventSource,
    name: &str,
    readers: &ReaderModels,
    speed_mm_s: f64,
    resolution: encoders::Resolution,
    spell: Spell,
    on_word: &mut dyn FnMut(&ReadWord) -> Result<()>,
) -> Result<ReadSummary> {
    use pipeline::reader::ReadOutput;
    let speller = Speller::new(spell);
    let started = Instant::now();
    let mut reader = readers.stream(speed_mm_s, resolution, &speller)?;
    let (mut out, mut text) = (Vec::new(), std::collections::VecDeque::<String>::new());
    let (mut first, mut last) = (None, 0i64);
    let mut emit = |out: &mut Vec<ReadOutput>, text: &mut std::collections::VecDeque<String>| -> Result<()> {
        for o in out.drain(..) {
            if let ReadOutput::Word(w) = o {
                on_word(&w)?;
                text.push_back(w.text);
                if text.len() > 1000 {
                    text.pop_front();
                }
            }
        }
        Ok(())
    };
    let at = |e: pipeline::Error| crate::Error::Stream { name: name.to_string(), source: Box::new(e) };
    while let Some(chunk) =
        source.next_chunk().map_err(|e| crate::Error::Read { name: name.to_string(), source: Box::new(e) })?
    {
        first.get_or_insert(chunk[0].t_us);
        last = chunk[chunk.len() - 1].t_us;
        reader.push_all(chunk, &mut out).map_err(at)?;
        emit(&mut out, &mut text)?;
    }
    reader.finish(&mut out).map_err(at)?;
    emit(&mut out, &mut text)?;
    let stats = reader.stats.clone();
    let (seg, cls) = reader.into_states();
    let us = |h: &pipeline::classify::Histogram, q: f64| h.quantile_ns(q).map(|n| n / 1e3);
    Ok(ReadSummary {
        summary: true,
        data: name.to_string(),
        arch: readers.classifier.arch(),
        spell,
        speed_mm_s,
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
        peak_rss_mb: crate::peak_rss_mb(),
    })
}

/// The scanning speed a simulated scan's ground truth gives (`FILE.truth.json` beside it, as
/// `braille simulate` writes it), if there is one.
pub fn truth_speed(truth: &Path) -> Result<Option<f64>> {
    if !truth.exists() {
        return Ok(None);
    }
    let text =
        std::fs::read_to_string(truth).map_err(|source| crate::Error::Io { path: truth.to_path_buf(), source })?;
    let t: sim::ScanTruth =
        serde_json::from_str(&text).map_err(|source| crate::Error::Json { path: truth.to_path_buf(), source })?;
    Ok(Some(t.scan.speed_mm_s))
}

/// A reader's words on a board's SIMULATED scans (`braille eval words`): the paper's four metrics
/// with the spelling asked for, and the score with every spelling.
#[derive(Debug, Clone, Serialize)]
pub struct EvalWords {
    pub data: &'static str,
    pub board: String,
    pub spell: Spell,
    /// Unconditional, over every printed word.
    pub word_accuracy: f64,
    pub word_error_rate: f64,
    pub char_error_rate: f64,
    /// The paper's conditional metrics.
    pub words_per_line: f64,
    pub letters_per_word: f64,
    pub correct_words: f64,
    pub correct_letters: f64,
    #[serde(flatten)]
    pub score: WordsScore,
}

/// Reads every scan of `spec` with `readers` and scores it.
pub fn eval_words(
    spec: &WordsSpec,
    readers: &ReaderModels,
    spell: Spell,
    progress: &dyn Progress,
) -> Result<EvalWords> {
    let lines = read_scans(spec, &[readers], progress)?;
    let score = score(readers.classifier.arch(), 0, &lines, spec.speed_mm_s, spec.depth_mm);
    let m = score.by_spell.iter().find(|b| b.spell == spell).expect("every spelling is scored").clone();
    Ok(EvalWords {
        data: "simulated (virtual Evetac)",
        board: spec.board.name(),
        spell,
        word_accuracy: m.word_accuracy,
        word_error_rate: m.word_error_rate,
        char_error_rate: m.char_error_rate,
        words_per_line: m.words_per_line,
        letters_per_word: m.letters_per_word,
        correct_words: m.correct_words,
        correct_letters: m.correct_letters,
        score,
    })
}
