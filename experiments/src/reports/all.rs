//! The whole report (`braille report`): every results table and figure regenerated into one
//! folder, with an index. Each part calls the library function its own command calls and writes
//! the same files: the simulator's physics checks, the labeling pipeline, a simulated scan as a
//! heat map and an event raster, Table I and the depth curve, the speed table, every letter at
//! every place in a row, the SNN against the
//! ResNet on one stream (latency histograms, SynOps and energy), the real iCub results and the
//! engine's benchmark.

use crate::Progress;
use crate::error::{Error, Result};
use crate::reports::figures::{LineChart, Series};
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::reader::Spell;
use pipeline::shipped::{Preset, Shipped, Variant};
use pipeline::source::ReadSummary;
use plotters::prelude::SeriesLabelPosition;
use snn::model_file::Arch;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What the report covers and where it goes.
#[derive(Debug, Clone)]
pub struct ReportSpec {
    /// The report's folder (Markdown, JSON, PNG).
    pub out: PathBuf,
    /// Small trial counts: the same report in a few minutes (its figures too noisy to quote).
    pub quick: bool,
    /// The world of the model tables; the physics checks run at `nominal` whatever this says.
    pub realism: sim::Realism,
    /// The shipped models; the simulated tables read those trained at `realism`.
    pub models: Shipped,
    /// The folder of the iCub dataset folders `raw1350` and `th10`.
    pub icub: PathBuf,
    /// The folder of the SNN searches' trial logs (one folder per search run), whose validation
    /// scores pick the search that heads the iCub table.
    pub search_logs: PathBuf,
}

/// Runs one part, timed, and notes it.
fn step<T>(
    times: &mut Vec<(&'static str, &'static str, f64)>,
    progress: &dyn Progress,
    name: &'static str,
    files: &'static str,
    f: impl FnOnce() -> Result<T>,
) -> Result<T> {
    progress.note(&format!("report: {name}"));
    let t = Instant::now();
    let r = f().map_err(|source| Error::ReportPart { part: name, source: Box::new(source) })?;
    times.push((name, files, t.elapsed().as_secs_f64()));
    Ok(r)
}

/// Regenerates the whole report into `spec.out`; writes `index.md` last.
pub fn run(spec: &ReportSpec, progress: &dyn Progress) -> Result<()> {
    let out = &spec.out;
    std::fs::create_dir_all(out).map_err(|source| Error::Io { path: out.clone(), source })?;
    let q = spec.quick;
    // the simulated tables read with the models trained at the preset
    let models = spec.models.dir(Preset::of_name(&spec.realism.to_string())?);
    let test_world = corpus::world::World::test(spec.realism);
    let started = Instant::now();
    let mut times = Vec::new();
    let write = |file: &str, text: &str| -> Result<()> {
        let p = out.join(file);
        std::fs::write(&p, text).map_err(|source| Error::Io { path: p, source })
    };
    let checks = step(
        &mut times,
        progress,
        "simulator physics checks (nominal)",
        "[sim_check.md](sim_check.md), sim_check.json, sim_check_dot_lag.png",
        || {
            let r = sim::checks::run(sim::Realism::Nominal, if q { 2 } else { 8 })?;
            write("sim_check.md", &r.markdown())?;
            crate::write_json(&out.join("sim_check.json"), &r, true)?;
            crate::reports::figures::dot_lag_figure(&r, &out.join("sim_check_dot_lag.png"))?;
            Ok(r.markdown())
        },
    )?;
    let labels = step(&mut times, progress, "labeling pipeline", "[label_check.md](label_check.md)", || {
        let rows = crate::eval::labeling::label_check(
            if q { 1 } else { 30 },
            corpus::world::TEST_SEED,
            &test_world,
            crate::eval::labeling::CheckBoards::Test,
        )?;
        let md = crate::eval::labeling::label_check_markdown(&rows);
        write("label_check.md", &md)?;
        Ok(md)
    })?;
    // the scan `braille simulate --board EV --row 0 --speed 16 --seed 1 --realism R` writes
    let scan_path = out.join("ev_row0_16mm_s.aedat4");
    step(
        &mut times,
        progress,
        "a simulated scan, as a heat map and an event raster",
        "[scan_ev_row0.png](scan_ev_row0.png)",
        || {
            let scanner = corpus::scans::Scanner::new(
                sim::BoardKind::Ev,
                None,
                1,
                spec.realism,
                encoders::Resolution::DVXPLORER,
                16.0,
                1.5,
                sim::Direction::Forward,
                1,
            )?;
            let (s, sensor) = (scanner.scan(0, 0)?, &scanner.sensor);
            corpus::scans::write_events(&scan_path, &s.events, sensor.camera.resolution, true)?;
            let window = crate::reports::figures::ScanWindow { pool: 4, start_s: None, length_s: 0.35 };
            crate::reports::figures::scan_figure(
                &s.events,
                Some(sensor.camera.resolution),
                &window,
                "SIMULATED EV row 0, 16 mm/s",
                &out.join("scan_ev_row0.png"),
            )
        },
    )?;
    step(
        &mut times,
        progress,
        "Table I and the depth curve",
        "[chars.md](chars.md), chars_depth.png, chars_confusion_*.png",
        || {
            let depths: &[f64] = if q { &[0.6, 1.5] } else { &[] };
            let r = crate::reports::chars::chars_report(
                &models,
                depths,
                if q { 1 } else { 30 },
                corpus::world::TEST_SEED,
                &test_world,
                progress,
            )?;
            crate::reports::figures::write_chars_report(&r, out)
        },
    )?;
    step(&mut times, progress, "the speed table", "[words.md](words.md), words_speed.png", || {
        use pipeline::reader::TimingMode;
        let spec = crate::reports::words::WordsReportSpec {
            speeds_mm_s: if q { vec![16.0, 64.0] } else { vec![8.0, 16.0, 24.0, 32.0, 48.0, 64.0] },
            hand_speeds_mm_s: if q { vec![16.0] } else { vec![16.0, 32.0] },
            hand_speed_variation: 0.4,
            timings: vec![TimingMode::Estimated, TimingMode::Paper, TimingMode::Given],
            depth_mm: 1.5,
            trials: if q { 1 } else { 30 },
            seed: corpus::world::TEST_SEED,
            world: test_world.clone(),
            unseen_rows: if q { 1 } else { 4 },
            unseen_trials: if q { 1 } else { 10 },
        };
        let r = crate::reports::words::words_report(&models, &spec, progress)?;
        crate::reports::figures::write_words_report(&r, out)
    })?;
    step(&mut times, progress, "every letter at every place", "[letters.md](letters.md)", || {
        let spec = crate::reports::letters::LettersReportSpec {
            held_out: corpus::boards::HeldOut::Test,
            speeds_mm_s: if q { vec![32.0] } else { vec![8.0, 16.0, 24.0, 32.0, 48.0] },
            depths_mm: if q { vec![1.0] } else { vec![0.6, 1.0, 1.5] },
            trials: 1,
            focus_speed_mm_s: if q { 32.0 } else { 16.0 },
            focus_depth_mm: 1.0,
            focus_trials: if q { 1 } else { 4 },
            seed: corpus::world::TEST_SEED,
            world: test_world.clone(),
            first_rows: q.then_some(4),
        };
        let readers: Vec<pipeline::shipped::ReaderFiles> =
            [Arch::Resnet, Arch::Snn].into_iter().map(|a| pipeline::shipped::reader_in(&models, a)).collect();
        let r = crate::reports::letters::letters_report(&readers, &spec, progress)?;
        crate::reports::figures::write_letters_report(&r, out).map(|_| ())
    })?;
    let runs = step(
        &mut times,
        progress,
        "one stream read by each architecture",
        "read_resnet.jsonl, read_snn.jsonl",
        || {
            [Arch::Resnet, Arch::Snn]
                .into_iter()
                .map(|arch| read_scan(&scan_path, arch, &models, out))
                .collect::<Result<Vec<_>>>()
        },
    )?;
    step(&mut times, progress, "the real iCub results", "[icub.md](icub.md), icub.png", || {
        crate::reports::figures::write_icub_report(
            &spec.icub,
            &spec.models.icub_dir(Variant::Trained),
            Some(&crate::reports::icub::SearchFolders {
                models: spec.models.search_dir(),
                logs: spec.search_logs.clone(),
            }),
            out,
        )
    })?;
    let bench = step(&mut times, progress, "the engine on the peer benchmark", "bench.json", || {
        let r = crate::bench::engine::engine(64, 7, 1)?;
        crate::write_json(&out.join("bench.json"), &r, true)?;
        Ok(r)
    })?;
    std::fs::remove_file(&scan_path).ok();
    let lat_md = latency(&runs, &out.join("latency.png"))?;
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# braille: the report\n\nRegenerated by `braille report --out {}{}` in {:.1} min on this machine. Every figure on **simulated** data (the virtual Evetac) says so; the iCub results are real recordings of another sensor.{}\n",
        out.display(),
        if q { " --quick" } else { "" },
        started.elapsed().as_secs_f64() / 60.0,
        if q { " **Quick run**: one or two scans per condition, too noisy to quote." } else { "" }
    );
    let _ = writeln!(md, "| part | files | minutes |\n| --- | --- | --- |");
    for (name, files, t) in &times {
        let _ = writeln!(md, "| {name} | {files} | {:.1} |", t / 60.0);
    }
    let _ = writeln!(md, "\n## A simulated scan\n\n![heat map and event raster](scan_ev_row0.png)\n");
    let _ = writeln!(md, "## Simulator physics checks (SIMULATED)\n\n{checks}\n");
    let _ = writeln!(md, "## Labeling pipeline against the ground truth (SIMULATED)\n\n{labels}\n");
    let _ =
        writeln!(md, "## SNN against ResNet on one stream (SIMULATED)\n\n{lat_md}\n![per-call latency](latency.png)\n");
    let _ = writeln!(
        md,
        "## Characters, words and the real sensor\n\n- [Table I and the depth curve](chars.md) (SIMULATED)\n- [The speed table](words.md) (SIMULATED)\n- [iCub Braille, real recordings](icub.md)\n"
    );
    let _ = writeln!(
        md,
        "## The event-driven engine on the peer benchmark's network\n\n{:.3} ms per sample, {:.2} ns per synaptic event, {:.3} us per input event (stepped); async mode: an input event's effects done in {:.0} ns (p50), {:.0} ns (p99) (`braille bench --json`; the peers: `bash scripts/peers/compare.sh`).\n",
        bench.ms_per_sample,
        bench.ns_per_synop,
        bench.us_per_input_event,
        bench.async_event_latency_ns_p50.unwrap_or(f64::NAN),
        bench.async_event_latency_ns_p99.unwrap_or(f64::NAN)
    );
    write("index.md", &md)?;
    progress.note(&format!(
        "wrote {} ({:.1} min)",
        out.join("index.md").display(),
        started.elapsed().as_secs_f64() / 60.0
    ));
    Ok(())
}

/// `braille read SCAN --arch A --json` into `read_A.jsonl`: the words, then the summary.
fn read_scan(scan: &Path, arch: Arch, models: &Path, out: &Path) -> Result<ReadSummary> {
    let pipeline::shipped::ReaderFiles { segmenter: s, classifier: c } = pipeline::shipped::reader_in(models, arch);
    let readers = ReaderModels::load(&s, &c, SnnRunner::Sliding)?;
    let mut source = encoders::formats::open(scan, &encoders::formats::OpenOptions::default())?;
    let resolution = source.info().resolution.unwrap_or(encoders::Resolution::DVXPLORER);
    let mut lines = String::new();
    let mut on_word = |w: &pipeline::reader::ReadWord| -> pipeline::Result<()> {
        lines.push_str(&serde_json::to_string(w).expect("words serialise"));
        lines.push('\n');
        Ok(())
    };
    let name = scan.display().to_string();
    let mut summary = pipeline::source::read_source(
        source.as_mut(),
        &name,
        &readers,
        pipeline::reader::Timing::ESTIMATED,
        resolution,
        &pipeline::reader::Speller::new(Spell::Lexicon),
        &mut on_word,
    )?;
    // The process's peak is the report's (its earlier parts), not the reader's.
    summary.peak_rss_mb = None;
    let path = out.join(format!("read_{arch}.jsonl"));
    let io = |source| Error::Io { path: path.clone(), source };
    let json = serde_json::to_string(&summary).map_err(|source| Error::Json { path: path.clone(), source })?;
    let mut f = std::fs::File::create(&path).map_err(io)?;
    writeln!(f, "{lines}{json}").map_err(io)?;
    Ok(summary)
}

/// The two architectures' reading of one stream: a table and the per-call latency histograms.
fn latency(runs: &[ReadSummary], png: &Path) -> Result<String> {
    let mut md = String::from(
        "The simulated EV row 0 at 16 mm/s, read by each architecture's shipped networks (`braille read FILE --arch A --json`). Per call: the segmentation network runs on every frame, the classifier where a character is present. SynOps count the SNN's synaptic operations; the ResNet's multiply-accumulates are in [chars.md](chars.md). Memory is left out: inside the report it would be the report's own peak; `braille read FILE --json` gives the reader's in its own process.\n\n| architecture | text | stream (s) | read (s) | segmentation p50 / p99 (us) | classifier p50 / p99 (us) | classifier calls | SynOps |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n",
    );
    let f = |v: Option<f64>| v.map_or("-".into(), |x| format!("{x:.0}"));
    let mut series = Vec::new();
    for v in runs {
        let synops = v.segmenter_synops + v.classifier_synops;
        let _ = writeln!(
            md,
            "| {} | {} | {:.1} | {:.2} | {} / {} | {} / {} | {} | {} |",
            v.arch,
            v.text,
            v.stream_s,
            v.read_s,
            f(v.segmenter_us_p50),
            f(v.segmenter_us_p99),
            f(v.classifier_us_p50),
            f(v.classifier_us_p99),
            v.stats.classifier_calls,
            if synops == 0 { "-".to_string() } else { synops.to_string() },
        );
        for (h, what) in [(&v.segmenter_latency, "segmentation"), (&v.classifier_latency, "classifier")] {
            let total = h.total().max(1) as f64;
            let points = h
                .octave_buckets(4)
                .into_iter()
                .map(|(edge_ns, c)| ((edge_ns / 1e3).log10(), 100.0 * c as f64 / total))
                .collect();
            series.push(Series { name: format!("{}, {what}", v.arch), points, emphasis: v.arch == Arch::Snn });
        }
    }
    let max_y = series.iter().flat_map(|s| s.points.iter().map(|p| p.1)).fold(1.0, f64::max);
    LineChart {
        title: "SIMULATED: time per call, EV row 0 at 16 mm/s",
        x_desc: "microseconds per call (log scale)",
        y_desc: "share of calls (%)",
        x: 0.0..5.0,
        y: 0.0..max_y * 1.1,
        x_log10: true,
        series,
        targets: vec![],
        legend: SeriesLabelPosition::UpperRight,
        size: (900, 480),
    }
    .draw(png)?;
    Ok(md)
}
