//! Word reading on SIMULATED scans: `braille eval words` (the paper's four conditional metrics for
//! one board, speed and depth) and `braille words-report` (the paper's speed table for both
//! architectures, with and without spelling, as Markdown, JSON and a plot).

use crate::read::{Readers, SnnRunnerArg};
use crate::train::ArchArg;
use anyhow::{Context, Result};
use pipeline::metrics::WordMetrics;
use pipeline::reader::{ReadWord, ReaderStats, Spell, Speller};
use plotters::prelude::*;
use rayon::prelude::*;
use serde::Serialize;
use sim::{Board, BoardGeometry, BoardKind, ScanConfig};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The three spellings, in the order reports give them.
pub const SPELLS: [Spell; 3] = [Spell::None, Spell::Textblob, Spell::Lexicon];

/// What one architecture read on a set of scans.
#[derive(Debug, Clone, Serialize)]
pub struct WordsScore {
    pub arch: &'static str,
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
    pub words_per_line: f64,
    pub letters_per_word: f64,
    pub correct_words: f64,
    pub correct_letters: f64,
    pub counts: WordMetrics,
}

/// One simulated scan, read.
pub struct LineRead {
    truth: Vec<String>,
    words: Vec<ReadWord>,
    stats: ReaderStats,
    stream_s: f64,
    read_s: f64,
    seg_ns: u64,
    cls_ns: u64,
    synops: u64,
}

/// The scans of every row of `board`, `trials` each, read by each architecture in `archs` (each
/// scan simulated once for all).
#[allow(clippy::too_many_arguments)]
pub fn read_scans(
    board: &BoardKind,
    speed_mm_s: f64,
    depth_mm: f64,
    trials: u64,
    seed: u64,
    archs: &[ArchArg],
    runner: SnnRunnerArg,
) -> Result<Vec<Vec<LineRead>>> {
    let b = Board::new(board.clone(), BoardGeometry::default(), Board::default_seed(board))?;
    let sensor = crate::simulate::sensor(encoders::Resolution::DVXPLORER, 1)?;
    let jobs: Vec<(usize, u64)> = (0..b.rows.len()).flat_map(|r| (0..trials).map(move |t| (r, t))).collect();
    let bar = indicatif::ProgressBar::new(jobs.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("reading simulated scans [{bar:30}] {pos}/{len} ({elapsed})")
            .expect("template"),
    );
    let speller = Speller::new(Spell::None);
    let lines: Vec<Vec<LineRead>> = jobs
        .par_iter()
        .map_init(
            || archs.iter().map(|&a| Readers::load(a, None, None, runner.runner())).collect::<Result<Vec<_>>>(),
            |readers, &(row, trial)| -> Result<Vec<LineRead>> {
                let readers = readers.as_mut().map_err(|e| anyhow::anyhow!("{e:#}"))?;
                let scan_seed = pipeline::chars::scan_seed(seed, board, row, trial);
                let cfg = ScanConfig { speed_mm_s, depth_mm, row, seed: scan_seed, ..ScanConfig::default() };
                let s = sim::simulate(&b, &sensor, &cfg)?;
                let truth: Vec<String> = s.truth.row_text.split_whitespace().map(str::to_string).collect();
                let stream_s = s.events.last().map_or(0.0, |e| e.t_us as f64 / 1e6);
                let mut out = Vec::new();
                for r in readers.iter_mut() {
                    let (s0, c0, y0) =
                        (r.segmenter.nanos, r.classifier.nanos, r.segmenter.synops + r.classifier.synops);
                    let t = Instant::now();
                    let (words, stats) = r.read(&s.events, sensor.camera.resolution, speed_mm_s, &speller)?;
                    out.push(LineRead {
                        truth: truth.clone(),
                        words,
                        stats,
                        stream_s,
                        read_s: t.elapsed().as_secs_f64(),
                        seg_ns: r.segmenter.nanos - s0,
                        cls_ns: r.classifier.nanos - c0,
                        synops: r.segmenter.synops + r.classifier.synops - y0,
                    });
                }
                bar.inc(1);
                Ok(out)
            },
        )
        .collect::<Result<_>>()?;
    bar.finish_and_clear();
    Ok(lines)
}

/// Scores one architecture's lines (`lines[scan][arch_index]`).
pub fn score(arch: ArchArg, k: usize, lines: &[Vec<LineRead>], speed_mm_s: f64, depth_mm: f64) -> WordsScore {
    let spellers: Vec<Speller> = SPELLS.iter().map(|&s| Speller::new(s)).collect();
    let mut metrics = vec![WordMetrics::default(); SPELLS.len()];
    let (mut delays, mut examples) = (Vec::new(), Vec::new());
    let mut s = WordsScore {
        arch: arch_name(arch),
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

pub fn arch_name(a: ArchArg) -> &'static str {
    match a {
        ArchArg::Resnet => "resnet",
        ArchArg::Snn => "snn",
    }
}

#[derive(clap::Args)]
pub struct EvalWordsArgs {
    #[arg(long, value_enum, default_value = "snn")]
    arch: ArchArg,
    /// Board: SAB, UN, RAB, EV, or text:"ANY WORDS" (`/` starts a new row).
    #[arg(long, default_value = "EV")]
    board: BoardKind,
    #[arg(long, default_value_t = 16.0)]
    speed: f64,
    #[arg(long, default_value_t = 1.5)]
    depth: f64,
    /// Scans per board row.
    #[arg(long, default_value_t = 30)]
    trials: u64,
    #[arg(long, value_enum, default_value = "lexicon")]
    spell: crate::read::SpellArg,
    /// Scan seed (training used others).
    #[arg(long, default_value_t = 1_000_003)]
    seed: u64,
    #[arg(long, value_enum, default_value = "sliding")]
    snn_runner: SnnRunnerArg,
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct EvalWordsReport<'a> {
    data: &'static str,
    board: String,
    spell: Spell,
    words_per_line: f64,
    letters_per_word: f64,
    correct_words: f64,
    correct_letters: f64,
    #[serde(flatten)]
    score: &'a WordsScore,
}

pub fn eval(args: EvalWordsArgs) -> Result<()> {
    let lines = read_scans(&args.board, args.speed, args.depth, args.trials, args.seed, &[args.arch], args.snn_runner)?;
    let s = score(args.arch, 0, &lines, args.speed, args.depth);
    let spell = args.spell.spell();
    let m = s.by_spell.iter().find(|b| b.spell == spell).context("spelling scored")?;
    let r = EvalWordsReport {
        data: "simulated (virtual Evetac)",
        board: args.board.name(),
        spell,
        words_per_line: m.words_per_line,
        letters_per_word: m.letters_per_word,
        correct_words: m.correct_words,
        correct_letters: m.correct_letters,
        score: &s,
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        println!(
            "SIMULATED {} at {} mm/s, {} mm, {} lines, {} architecture, spelling {:?}: words per line {:.3}, letters per word {:.3}, correct words {:.3}, correct letters {:.3}; read {:.1} s of stream in {:.2} s",
            r.board,
            args.speed,
            args.depth,
            s.lines,
            s.arch,
            spell,
            r.words_per_line,
            r.letters_per_word,
            r.correct_words,
            r.correct_letters,
            s.stream_s,
            s.read_s
        );
    }
    Ok(())
}

#[derive(clap::Args)]
pub struct ReportArgs {
    /// Where to write `words.md`, `words.json` and `words_speed.png`.
    #[arg(long, default_value = "docs")]
    out: PathBuf,
    /// EV scans per row and speed (the paper: 30).
    #[arg(long, default_value_t = 30)]
    trials: u64,
    #[arg(long, value_delimiter = ',', default_value = "8,16,24,32")]
    speeds: Vec<f64>,
    #[arg(long, default_value_t = 1.5)]
    depth: f64,
    #[arg(long, default_value_t = 1_000_003)]
    seed: u64,
}

#[derive(Serialize)]
struct Report {
    data: &'static str,
    board: &'static str,
    depth_mm: f64,
    trials: u64,
    seed: u64,
    speeds_mm_s: Vec<f64>,
    /// Per speed, one score per architecture (ResNet, SNN).
    scores: Vec<Vec<WordsScore>>,
}

/// The paper's speed table (with TextBlob), correct words: 8, 16, 24, 32 mm/s.
const PAPER_SPELL: [f64; 4] = [0.903, 0.97, 0.913, 0.971];
const PAPER_NONE: [f64; 4] = [0.876, 0.866, 0.753, 0.685];

pub fn report(args: ReportArgs) -> Result<()> {
    let archs = [ArchArg::Resnet, ArchArg::Snn];
    let mut scores = Vec::new();
    for &speed in &args.speeds {
        let t = Instant::now();
        let lines =
            read_scans(&BoardKind::Ev, speed, args.depth, args.trials, args.seed, &archs, SnnRunnerArg::Sliding)?;
        let row: Vec<WordsScore> = (0..archs.len()).map(|k| score(archs[k], k, &lines, speed, args.depth)).collect();
        for s in &row {
            eprintln!(
                "SIMULATED EV {speed} mm/s: {}: correct words {} (none / textblob / lexicon) in {:.0} s",
                s.arch,
                s.by_spell.iter().map(|b| format!("{:.3}", b.correct_words)).collect::<Vec<_>>().join(" / "),
                t.elapsed().as_secs_f64()
            );
        }
        scores.push(row);
    }
    let r = Report {
        data: "simulated (virtual Evetac)",
        board: "EV",
        depth_mm: args.depth,
        trials: args.trials,
        seed: args.seed,
        speeds_mm_s: args.speeds.clone(),
        scores,
    };
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    crate::simulate::write_json(&args.out.join("words.json"), &r, true)?;
    plot(&r, &args.out.join("words_speed.png"))?;
    let md = markdown(&r);
    std::fs::write(args.out.join("words.md"), md).with_context(|| format!("writing {}", args.out.display()))?;
    eprintln!("wrote {}/words.md, words.json, words_speed.png", args.out.display());
    Ok(())
}

fn markdown(r: &Report) -> String {
    let mut m = String::new();
    let _ = writeln!(
        m,
        "# Reading words at four speeds (SIMULATED)\n\nAll figures on **simulated** scans (virtual Evetac) of the EV board (two rows: RIGHT LEFT EXIT OPEN, PUSH PULL STOP HELP WATER), {} scans per row and speed, {} mm deep, seed {}. Regenerate: `braille words-report --trials {}` (or `bash scripts/words.sh`).\n\nEach architecture reads every scan from the raw event stream: the segmentation network on every frame, the character classifier where it says a character is present, the paper's temporal filter (4 frames, 70 ms, 1 s at 8 mm/s; durations scale with 8 mm/s / speed), then the spelling. The four metrics are the paper's, each on the subset that passed the one before. TextBlob is the paper's corrector; the lexicon decoder is ours (Braille dot confusions, the classifier's letter probabilities, insertions and deletions).\n",
        r.trials, r.depth_mm, r.seed, r.trials
    );
    let _ = writeln!(
        m,
        "| speed | architecture | spelling | words per line | letters per word | correct words | correct letters | paper, correct words |"
    );
    let _ = writeln!(m, "| --- | --- | --- | --- | --- | --- | --- | --- |");
    for (i, row) in r.scores.iter().enumerate() {
        let speed = r.speeds_mm_s[i];
        let paper_idx = [8.0, 16.0, 24.0, 32.0].iter().position(|&s| s == speed);
        for s in row {
            for b in &s.by_spell {
                let paper = match (paper_idx, b.spell) {
                    (Some(p), Spell::None) if s.arch == "resnet" => format!("{:.3}", PAPER_NONE[p]),
                    (Some(p), Spell::Textblob) if s.arch == "resnet" => format!("{:.3}", PAPER_SPELL[p]),
                    _ => String::new(),
                };
                let _ = writeln!(
                    m,
                    "| {speed} mm/s | {} | {:?} | {:.3} | {:.3} | {:.3} | {:.3} | {paper} |",
                    s.arch, b.spell, b.words_per_line, b.letters_per_word, b.correct_words, b.correct_letters
                );
            }
        }
    }
    let _ = writeln!(m, "\n![correct words against speed](words_speed.png)\n");
    let _ = writeln!(m, "## Targets (issue #5)\n");
    for arch in ["resnet", "snn"] {
        let get = |spell: Spell| -> Vec<f64> {
            r.scores
                .iter()
                .filter_map(|row| row.iter().find(|s| s.arch == arch))
                .map(|s| s.by_spell.iter().find(|b| b.spell == spell).map_or(f64::NAN, |b| b.correct_words))
                .collect()
        };
        let (lex, none) = (get(Spell::Lexicon), get(Spell::None));
        let lo = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
        let _ = writeln!(
            m,
            "- {arch}: correct words with the lexicon decoder at least 0.97 at every speed: lowest {:.3}, {}; without spelling at least 0.90: lowest {:.3}, {}.",
            lo(&lex),
            if lo(&lex) >= 0.97 { "met" } else { "**not met**" },
            lo(&none),
            if lo(&none) >= 0.90 { "met" } else { "**not met**" }
        );
    }
    let _ = writeln!(m, "\n## Time\n");
    let _ = writeln!(
        m,
        "Reading time against the stream's duration on this machine (2 cores, both scans of a speed read in parallel, so the figures include contention; `cargo bench --bench reading` measures one row on a quiet core). Registration delay: stream time from the last event a character's detections used to the frame that registered it (the filter waits 70 ms, scaled, for the segment to end).\n"
    );
    let _ = writeln!(
        m,
        "| speed | architecture | stream (s) | read (s) | share of duration | segmentation (ms) | classifier (ms) | classifier calls | registration delay mean / max (ms) |"
    );
    let _ = writeln!(m, "| --- | --- | --- | --- | --- | --- | --- | --- | --- |");
    for (i, row) in r.scores.iter().enumerate() {
        for s in row {
            let _ = writeln!(
                m,
                "| {} mm/s | {} | {:.1} | {:.2} | {:.2}% | {:.0} | {:.0} | {} | {:.0} / {:.0} |",
                r.speeds_mm_s[i],
                s.arch,
                s.stream_s,
                s.read_s,
                100.0 * s.read_s / s.stream_s.max(1e-9),
                s.segmenter_ms,
                s.classifier_ms,
                s.classifier_calls,
                s.registration_delay_ms_mean,
                s.registration_delay_ms_max
            );
        }
    }
    let _ = writeln!(m, "\n## What was read (first three lines per speed and architecture)\n");
    for (i, row) in r.scores.iter().enumerate() {
        for s in row {
            for (t, raw, lex) in s.examples.iter().take(3) {
                let _ = writeln!(m, "- {} mm/s, {}: `{t}` read `{raw}`, lexicon `{lex}`", r.speeds_mm_s[i], s.arch);
            }
        }
    }
    m
}

fn plot(r: &Report, path: &Path) -> Result<()> {
    crate::plot::register_fonts();
    let root = BitMapBackend::new(path, (900, 520)).into_drawing_area();
    root.fill(&WHITE)?;
    let lo = r
        .scores
        .iter()
        .flatten()
        .flat_map(|s| s.by_spell.iter().map(|b| 100.0 * b.correct_words))
        .filter(|v| v.is_finite())
        .fold(100.0f64, f64::min)
        .min(60.0);
    let (x0, x1) = (
        r.speeds_mm_s.iter().copied().fold(f64::INFINITY, f64::min) - 2.0,
        r.speeds_mm_s.iter().copied().fold(0.0, f64::max) + 2.0,
    );
    let mut chart = ChartBuilder::on(&root)
        .caption("SIMULATED: correct words against speed, EV board", ("sans-serif", 20))
        .margin(14)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(x0..x1, (lo - 5.0).max(0.0)..101.0f64)?;
    chart.configure_mesh().x_desc("speed (mm/s)").y_desc("correct words (%)").draw()?;
    // name, points, colour, thick (the SNN)
    type Series = (String, Vec<(f64, f64)>, RGBColor, bool);
    let mut series: Vec<Series> = Vec::new();
    for (k, arch) in ["resnet", "snn"].iter().enumerate() {
        for (j, spell) in SPELLS.iter().enumerate() {
            let pts: Vec<(f64, f64)> = r
                .scores
                .iter()
                .zip(&r.speeds_mm_s)
                .filter_map(|(row, &sp)| {
                    let s = row.iter().find(|s| s.arch == *arch)?;
                    let v = s.by_spell.iter().find(|b| b.spell == *spell)?.correct_words;
                    v.is_finite().then_some((sp, 100.0 * v))
                })
                .collect();
            let shade = [RGBColor(150, 150, 150), RGBColor(60, 120, 200), RGBColor(200, 40, 40)][j];
            series.push((format!("{arch}, {spell:?}"), pts, shade, k == 1));
        }
    }
    for (name, pts, c, dashed) in series {
        let style = c.stroke_width(if dashed { 3 } else { 1 });
        chart
            .draw_series(LineSeries::new(pts.clone(), style))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled())))?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    root.present().map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(())
}
