//! What tells a word read from noise from a word read from print (issue #113's abstention), on
//! the validation words only (VAL-WORDS, validation builds, validation seed; SIMULATED): each
//! word a reader gives, scored against the printed row (hit, substitution or insertion, with the
//! lexicon), with what the reader knows of it, and for each of those measures the threshold under
//! which dropping the words would gain the most (inserted words dropped minus hits dropped).
//!
//! `cargo run --release -p experiments --example word_confidence MODELS [presets] [speeds] [depths] [trials] [out.json] [boards]`
//! (boards: VAL-WORDS and VAL-SENTENCES by default)
//! e.g. `... word_confidence models/nominal nominal,harsh 8,16,32,64,128,200 0.6,1.0,1.5 1`.

use corpus::world::{SensorBuilds, VALIDATION_SEED, World};
use experiments::eval::scoring::{Step, alignment};
use experiments::eval::words::{WordsSpec, read_scans_in};
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::lexicon::{LetterProbs, LexiconConfig, LexiconDecoder};
use pipeline::reader::{ReadWord, Spell, Speller, TimingMode};
use serde::Serialize;
use sim::Realism;
use snn::model_file::Arch;
use std::path::PathBuf;

/// One word as read, with its label and the measures a reader has of it.
#[derive(Debug, Clone, Serialize)]
struct WordRecord {
    arch: Arch,
    realism: Realism,
    speed_mm_s: f64,
    depth_mm: f64,
    /// `hit`, `sub` or `ins` against the printed row (lexicon words).
    label: &'static str,
    chars: usize,
    /// The letters' mean and least confidence (mean top probability over each segment).
    mean_confidence: f64,
    min_confidence: f64,
    /// The word's frames per character (segment length), and its characters per second of the
    /// word's span over the rate its own speed estimate expects (one cell a 6.2 mm pitch).
    frames_per_char: f64,
    rate_ratio: f64,
    /// The lexicon decoder's score per character (what the reader's abstention judges by,
    /// `pipeline::abstain::score_per_char`), and whether the lexicon kept a word of its own.
    lexicon_score_per_char: f64,
    /// The same without the word's prior: how well the letters fit the word.
    lexicon_fit_per_char: f64,
    in_lexicon: bool,
}

/// The cell pitch of the boards, mm (Braille standard 6.2 mm; only a scale for `rate_ratio`).
const CELL_PITCH_MM: f64 = 6.2;

/// The measures of `w`: characters, mean and least confidence, frames per character, the rate
/// ratio, the lexicon's score per character and its fit (score without the prior) per character, and whether the lexicon's best is one of its words.
fn measures(w: &ReadWord, decoder: &LexiconDecoder) -> (usize, [f64; 6], bool) {
    let n = w.chars.len().max(1);
    let conf: Vec<f64> = w.chars.iter().map(|c| c.confidence as f64).collect();
    let mean = conf.iter().sum::<f64>() / n as f64;
    let min = conf.iter().copied().fold(1.0, f64::min);
    let frames = w.chars.iter().map(|c| c.frames).sum::<usize>() as f64 / n as f64;
    let span_s = match (w.chars.first(), w.chars.last()) {
        (Some(a), Some(b)) if n > 1 => (b.t_start_us - a.t_start_us) as f64 / 1e6,
        _ => f64::NAN,
    };
    let speed = w.chars.iter().filter_map(|c| c.speed_mm_s).next_back().unwrap_or(f64::NAN);
    let rate_ratio = ((n - 1) as f64 / span_s) / (speed / CELL_PITCH_MM);
    let obs: Vec<LetterProbs> =
        w.chars.iter().map(|c| <[f32; 26]>::try_from(c.probs.as_slice()).unwrap_or([1.0 / 26.0; 26])).collect();
    let (best, score) = decoder.decode(&obs);
    // the same word's score without its prior: how well the letters fit it
    let prior = decoder.log_prior(&best);
    let fit = score - LexiconConfig::default().lm_weight * prior.unwrap_or(LexiconConfig::default().p_oov.ln());
    (n, [mean, min, frames, rate_ratio, score / n as f64, fit / n as f64], prior.is_some())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, d: &str| args.get(i).cloned().unwrap_or_else(|| d.to_string());
    let models = PathBuf::from(arg(0, "models/nominal"));
    let list = |s: String| -> Vec<f64> { s.split(',').filter_map(|x| x.parse().ok()).collect() };
    let presets: Vec<Realism> = arg(1, "nominal,harsh")
        .split(',')
        .map(|p| serde_json::from_value(serde_json::Value::String(p.to_string())))
        .collect::<Result<_, _>>()?;
    let speeds = list(arg(2, "8,16,32,64,128,200"));
    let depths = list(arg(3, "0.6,1.0,1.5"));
    let trials: u64 = arg(4, "1").parse()?;
    let out = arg(5, "");
    let boards: Vec<sim::BoardKind> =
        arg(6, "VAL-WORDS,VAL-SENTENCES").split(',').map(corpus::boards::parse_board).collect::<Result<_, _>>()?;
    let archs = [Arch::Resnet, Arch::Snn];
    let mut readers = Vec::new();
    for arch in archs {
        let f = pipeline::shipped::reader_for(&models, arch, pipeline::code::BrailleCode::Grade1Letters);
        readers.push(ReaderModels::load(&f.segmenter, &f.classifier, SnnRunner::Sliding)?);
    }
    let refs: Vec<&ReaderModels> = readers.iter().collect();
    let lexicon = Speller::new(Spell::Lexicon);
    let decoder = LexiconDecoder::textblob(Default::default());
    let mut records = Vec::new();
    for &realism in &presets {
        let world = World::of(realism, SensorBuilds::Validation);
        let setup = world.setup();
        let mut conditions = Vec::new();
        for b in &boards {
            for &d in &depths {
                for &v in &speeds {
                    conditions.push((b, d, v));
                }
            }
        }
        for (board, depth_mm, speed_mm_s) in conditions {
            let spec = WordsSpec {
                board: board.clone(),
                speed_mm_s,
                speed_variation: 0.0,
                depth_mm,
                trials,
                seed: VALIDATION_SEED,
                world: world.clone(),
            };
            let lines = read_scans_in(&spec, &setup, &refs, &[TimingMode::Estimated], &())?;
            for scan in &lines {
                for (k, &arch) in archs.iter().enumerate() {
                    let l = &scan[k];
                    let read: Vec<String> = l.words.iter().map(|w| lexicon.correct(&w.chars)).collect();
                    for step in alignment(&l.truth, &read) {
                        let (j, label) = match step {
                            Step::Hit(_, j) => (j, "hit"),
                            Step::Sub(_, j) => (j, "sub"),
                            Step::Ins(j) => (j, "ins"),
                            Step::Del(_) => continue,
                        };
                        let (chars, m, in_lexicon) = measures(&l.words[j], &decoder);
                        records.push(WordRecord {
                            arch,
                            realism,
                            speed_mm_s,
                            depth_mm,
                            label,
                            chars,
                            mean_confidence: m[0],
                            min_confidence: m[1],
                            frames_per_char: m[2],
                            rate_ratio: m[3],
                            lexicon_score_per_char: m[4],
                            lexicon_fit_per_char: m[5],
                            in_lexicon,
                        });
                    }
                }
            }
            let board = corpus::boards::board_name(board);
            eprintln!("{board} {realism} {speed_mm_s} mm/s {depth_mm} mm: {} words so far", records.len());
        }
    }
    if !out.is_empty() {
        std::fs::write(&out, serde_json::to_string_pretty(&records)?)?;
    }
    type Measure = (&'static str, fn(&WordRecord) -> f64);
    let by: [Measure; 8] = [
        ("lexicon fit per char", |r| r.lexicon_fit_per_char),
        ("mean confidence", |r| r.mean_confidence),
        ("least confidence", |r| r.min_confidence),
        ("frames per char", |r| r.frames_per_char),
        ("lexicon score per char", |r| r.lexicon_score_per_char),
        ("chars", |r| r.chars as f64),
        ("rate ratio (low side)", |r| -r.rate_ratio),
        ("in lexicon", |r| r.in_lexicon as u8 as f64),
    ];
    for arch in archs {
        let rs: Vec<&WordRecord> = records.iter().filter(|r| r.arch == arch).collect();
        let count = |l: &str| rs.iter().filter(|r| r.label == l).count();
        println!(
            "{arch}: {} words read: {} hits, {} substitutions, {} insertions",
            rs.len(),
            count("hit"),
            count("sub"),
            count("ins")
        );
        for (name, f) in &by {
            let mut vals: Vec<f64> = rs.iter().map(|r| f(r)).filter(|v| !v.is_nan()).collect();
            vals.sort_by(f64::total_cmp);
            vals.dedup();
            let mut best = (0i64, f64::NEG_INFINITY, 0, 0);
            for &t in &vals {
                let below = |l: &str| rs.iter().filter(|r| r.label == l && f(r) < t).count();
                let gain = below("ins") as i64 - below("hit") as i64;
                if gain > best.0 {
                    best = (gain, t, below("ins"), below("hit"));
                }
            }
            let mean_of = |l: &str| {
                let v: Vec<f64> = rs.iter().filter(|r| r.label == l).map(|r| f(r)).filter(|v| v.is_finite()).collect();
                v.iter().sum::<f64>() / v.len().max(1) as f64
            };
            println!(
                "  {name:<24} mean hit {:.3} sub {:.3} ins {:.3} | best drop under {:.3}: {} insertions and {} hits dropped (gain {})",
                mean_of("hit"),
                mean_of("sub"),
                mean_of("ins"),
                best.1,
                best.2,
                best.3,
                best.0
            );
        }
    }
    Ok(())
}
