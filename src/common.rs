//! What the commands share: repository paths, progress bars for the libraries' long steps, the
//! writing of event files and JSON.

use indicatif::{ProgressBar, ProgressStyle};
use learn::train::{EpochReport, Observer};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// A result as pretty JSON (`json`), else as its text.
pub fn emit<T: serde::Serialize + std::fmt::Display>(r: &T, json: bool) -> anyhow::Result<()> {
    if json {
        println!("{}", serde_json::to_string_pretty(r)?);
    } else {
        print!("{r}");
    }
    Ok(())
}

/// A file of the repository: from the working directory, else from where the binary was built.
pub fn repo_path(rel: &str) -> PathBuf {
    let local = PathBuf::from(rel);
    if local.exists() { local } else { Path::new(env!("CARGO_MANIFEST_DIR")).join(rel) }
}

/// A progress bar per step of a library call ([`experiments::Progress`]); notes go to stderr.
#[derive(Default)]
pub struct Bar(Mutex<Option<ProgressBar>>);

impl experiments::Progress for Bar {
    fn start(&self, what: &str, len: u64) {
        let bar = ProgressBar::new(len);
        bar.set_style(
            ProgressStyle::with_template(&format!("{what} [{{bar:30}}] {{pos}}/{{len}} ({{elapsed}})"))
                .expect("a valid template"),
        );
        *self.0.lock().expect("bar lock") = Some(bar);
    }

    fn inc(&self) {
        if let Some(b) = self.0.lock().expect("bar lock").as_ref() {
            b.inc(1);
        }
    }

    fn finish(&self) {
        if let Some(b) = self.0.lock().expect("bar lock").take() {
            b.finish_and_clear();
        }
    }

    fn note(&self, line: &str) {
        eprintln!("{line}");
    }
}

/// Training progress: a bar per epoch with running loss and accuracy, and a line per epoch.
pub struct Epochs {
    bar: Option<ProgressBar>,
    quiet: bool,
    sum: (f64, f64, usize),
}

impl Epochs {
    pub fn new(quiet: bool) -> Epochs {
        Epochs { bar: None, quiet, sum: (0.0, 0.0, 0) }
    }
}

impl Observer for Epochs {
    fn epoch_begin(&mut self, epoch: usize, batches: usize) {
        self.sum = (0.0, 0.0, 0);
        if !self.quiet {
            let bar = ProgressBar::new(batches as u64);
            bar.set_style(
                ProgressStyle::with_template("epoch {prefix:>3} [{bar:30}] {pos}/{len} {msg} ({elapsed})")
                    .expect("a valid template")
                    .progress_chars("=> "),
            );
            bar.set_prefix(epoch.to_string());
            self.bar = Some(bar);
        }
    }

    fn batch(&mut self, loss: f64, accuracy: f64) {
        self.sum = (self.sum.0 + loss, self.sum.1 + accuracy, self.sum.2 + 1);
        if let Some(b) = &self.bar {
            let n = self.sum.2 as f64;
            b.set_message(format!("loss {:.3} acc {:.1}%", self.sum.0 / n, 100.0 * self.sum.1 / n));
            b.inc(1);
        }
    }

    fn epoch_end(&mut self, r: &EpochReport) {
        if let Some(b) = self.bar.take() {
            b.finish_and_clear();
        }
        eprintln!("{r}");
    }
}

/// `--realism` of the commands that score the shipped models on simulated scans. Its default is
/// `nominal`, the world of every published table; `clean` is the simulator before its nuisances,
/// kept for regression (docs/simulator.md). Test scans use the preset's test builds of the sensor,
/// and the default models are those trained at the preset ([`RealismArg::models_dir`]).
#[derive(clap::Args, Clone, Copy)]
pub struct RealismArg {
    /// The simulator's nuisances: clean, nominal or harsh (docs/simulator.md).
    #[arg(long, value_enum, default_value_t = sim::Realism::Nominal)]
    pub realism: sim::Realism,
}

/// The shipped models (`pipeline::shipped`): the repository's `models/`, or `$BRAILLE_MODELS`.
pub fn shipped() -> pipeline::shipped::Shipped {
    pipeline::shipped::Shipped::repo()
}

/// The models a command reads with when none is named: those trained at the default preset,
/// `nominal` (`models/nominal/`).
pub fn default_models_dir() -> PathBuf {
    shipped().dir(pipeline::shipped::Preset::Nominal)
}

impl RealismArg {
    /// The world of these sensor builds at this preset.
    pub fn world(self, builds: SensorBuilds) -> corpus::world::World {
        corpus::world::World::of(self.realism, builds)
    }

    /// The results of the tables at this preset, `docs/results/REALISM/`.
    pub fn results_dir(self) -> PathBuf {
        repo_path(&format!("docs/results/{}", self.realism))
    }

    /// The models trained at this preset, `models/REALISM/` (`REALISM=nominal bash
    /// scripts/table1.sh`, `scripts/words.sh`; none at `harsh`).
    pub fn models_dir(self) -> PathBuf {
        shipped().root().join(self.realism.to_string())
    }
}

pub use corpus::world::SensorBuilds;

/// How long a live stream (`tcp://HOST:PORT`) is waited for.
#[derive(clap::Args, Debug, Clone)]
pub struct LiveArgs {
    /// Live streams: seconds to wait for the sender to accept the connection.
    #[arg(long, default_value_t = 10.0)]
    pub connect_timeout_s: f64,
    /// Live streams: a sender silent for this many seconds has stalled and the read ends with an
    /// error (the words read until then are kept); 0 waits forever.
    #[arg(long, default_value_t = 10.0)]
    pub stall_timeout_s: f64,
}

impl LiveArgs {
    pub fn options(&self) -> encoders::formats::net::ConnectOptions {
        let secs = |s: f64| std::time::Duration::from_secs_f64(s.max(0.0));
        encoders::formats::net::ConnectOptions {
            connect_timeout: secs(self.connect_timeout_s).max(std::time::Duration::from_millis(1)),
            stall_timeout: (self.stall_timeout_s > 0.0).then(|| secs(self.stall_timeout_s)),
        }
    }
}

/// AEDAT4 packet compression on the command line.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum CompressionArg {
    None,
    Lz4,
    Zstd,
}

impl CompressionArg {
    pub fn compression(self) -> encoders::formats::aedat4::Compression {
        use encoders::formats::aedat4::Compression;
        match self {
            CompressionArg::None => Compression::None,
            CompressionArg::Lz4 => Compression::Lz4,
            CompressionArg::Zstd => Compression::Zstd,
        }
    }
}

/// A model in a chip's arithmetic (`--chip`), shared by `eval` and `eval chars`.
#[derive(clap::Args)]
pub struct ChipArgs {
    /// Run the model in a chip's arithmetic (docs/chips.md): mapped into its number formats
    /// (integer weights, fixed-point state, decays by bit shifts or integer multiplies), every
    /// sample as the chip computes.
    #[arg(long, value_enum)]
    pub chip: Option<snn::chip::Chip>,
    /// --chip: how float weights become the chip's integers (Xylo: Rockpool's quantisers; Speck:
    /// Sinabs's one scale per core; Loihi 2: one exponent per layer; the last two `global` only).
    #[arg(long, value_enum, default_value = "global", requires = "chip")]
    pub quantisation: snn::chip::xylo::Quantisation,
    /// --chip: every neuron every step (`stepped`, the vendor simulator's loop) or only neurons
    /// with state or input (`event-driven`); the two agree bit for bit.
    #[arg(long, value_enum, default_value = "event-driven", requires = "chip")]
    pub chip_run: snn::chip::xylo::Run,
    /// --chip: also write every sample as the chip ran it (JSON: the mapped specification, the
    /// inputs and every spike), for a spike-for-spike check with the vendor's simulator
    /// (scripts/chips/xylosim_check.py, sinabs_check.py, lava_check.py).
    #[arg(long, requires = "chip")]
    pub trace: Option<PathBuf>,
}

impl ChipArgs {
    pub fn choice(&self) -> Option<experiments::eval::chip::ChipChoice> {
        let (quantisation, run) = (self.quantisation, self.chip_run);
        self.chip.map(|chip| experiments::eval::chip::ChipChoice { chip, quantisation, run })
    }

    pub fn write_trace<T: serde::Serialize>(&self, trace: Option<T>) -> anyhow::Result<()> {
        if let (Some(path), Some(trace)) = (&self.trace, trace) {
            let json = serde_json::to_vec(&trace)?;
            std::fs::write(path, json).map_err(|e| anyhow::anyhow!("writing {}: {e}", path.display()))?;
        }
        Ok(())
    }
}

/// A report's models and folder where none is given: those of its preset in the repository.
pub fn place_defaults(place: &mut experiments::reports::jobs::ReportPlace) {
    let preset = RealismArg { realism: place.realism };
    place.models.get_or_insert_with(|| preset.models_dir());
    place.out.get_or_insert_with(|| results_dir(preset, place.final_read));
}

/// A report's folder: `docs/results/REALISM/`, or its `sealed/` for a `--final` read.
pub fn results_dir(realism: RealismArg, final_read: bool) -> PathBuf {
    let dir = realism.results_dir();
    if final_read { dir.join("sealed") } else { dir }
}

/// A read of sealed set `set` recorded in the ledger (docs/protocol.md unless `ledger`) with the
/// command that made it; returns how many times the set has been read.
pub fn record_sealed(set: &str, out: &str, ledger: Option<PathBuf>) -> anyhow::Result<usize> {
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let read = experiments::sealed::SealedRead { set: set.to_string(), command, out: out.to_string() };
    let ledger = ledger.unwrap_or_else(|| repo_path("docs/protocol.md"));
    let reads = experiments::sealed::record(&ledger, &read)?;
    eprintln!("sealed set {set:?}: read {reads} time(s), recorded in {}", ledger.display());
    Ok(reads)
}

/// What a report job wrote, printed; a `--final` read recorded in docs/protocol.md's ledger with
/// the command that made it, and the report's Markdown stamped with the count of reads.
pub fn finish(w: experiments::reports::jobs::Written) -> anyhow::Result<()> {
    if let Some(set) = &w.sealed_set {
        let reads = record_sealed(set, &w.md.display().to_string(), w.ledger.clone())?;
        experiments::sealed::stamp(&w.md, set, reads, &w.sealed_scans.0, w.sealed_scans.1)?;
    }
    print!("{}", w.printed);
    eprintln!("wrote {}", w.md.display());
    Ok(())
}
