//! Trials as shards log them (JSON lines), and reading the logs back.

use super::*;

pub(super) fn one() -> u64 {
    1
}

/// One trial as its shard logged it (a JSON line).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Trial {
    pub trial: usize,
    pub point: SearchPoint,
    pub recipe: SnnRecipe,
    /// Mean validation accuracy over the last `score_epochs` epochs run and kept (the mean over
    /// the trial's seeds).
    pub score: f64,
    /// Each seed's score, when a trial trains several ([`SearchSpace::trial_seeds`]).
    #[serde(default)]
    pub seed_scores: Vec<f64>,
    pub best_val_accuracy: f64,
    pub best_epoch: usize,
    /// The most epochs any of its seeds ran.
    pub epochs_run: usize,
    /// The lowest final training accuracy of its seeds.
    pub final_train_accuracy: f64,
    /// Epochs the loss-spike guard undid, over all its seeds (0 without the guard, and in logs
    /// from before 2026-12-01).
    #[serde(default, skip_serializing_if = "crate::train::recipe::is_zero_count")]
    pub undone_epochs: usize,
    /// The first seed's validation accuracy per epoch kept (the loss-spike guard's undone epochs
    /// have none).
    pub val_accuracy: Vec<f64>,
    pub seconds: f64,
    /// `I/N`: the shard that ran it.
    pub shard: String,
    pub profile: DataProfile,
}

/// Which share of the trials this process runs: every `count`-th trial from `index`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Parses `I/N` (0 <= I < N).
    pub fn parse(s: &str) -> Result<Shard> {
        let bad = || Error::Setting { name: "shard", value: s.to_string(), expected: "I/N with 0 <= I < N" };
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count) = (i.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }

    pub(super) fn runs(&self, trial: usize) -> bool {
        trial % self.count == self.index
    }

    pub(super) fn log(&self, dir: &Path) -> PathBuf {
        dir.join(format!("trials-{}-of-{}.jsonl", self.index, self.count))
    }
}

/// The line a trial ends with: its score, its best epoch, its time.
impl std::fmt::Display for Trial {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(
            f,
            "trial {}: score {:.2}% (best {:.2}% at epoch {} of {}), {:.1} min",
            self.trial,
            100.0 * self.score,
            100.0 * self.best_val_accuracy,
            self.best_epoch,
            self.epochs_run,
            self.seconds / 60.0
        )
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The trials logged in `dir` (every `trials-*.jsonl`), by trial number. A line that does not
/// parse is an error naming the file and the line.
pub fn read_logs(dir: &Path) -> Result<Vec<Trial>> {
    read_logs_named(dir, |n| n.starts_with("trials-") && n.ends_with(".jsonl"))
}

/// The trials of a successive-halving search's rung `rung` (not the last), as [`read_logs`].
pub fn read_rung_log(dir: &Path, rung: usize) -> Result<Vec<Trial>> {
    let name = rung_log_name(rung);
    if !dir.join(&name).exists() {
        return Ok(Vec::new());
    }
    read_logs_named(dir, |n| n == name)
}

pub(super) fn rung_log_name(rung: usize) -> String {
    format!("rung-{rung}.jsonl")
}

pub(super) fn read_logs_named(dir: &Path, wanted: impl Fn(&str) -> bool) -> Result<Vec<Trial>> {
    let io = |source| Error::Io { path: dir.to_path_buf(), source };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(io)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(&wanted))
        .collect();
    files.sort();
    let mut trials: Vec<Trial> = Vec::new();
    for f in files {
        let file = std::fs::File::open(&f).map_err(|source| Error::Io { path: f.clone(), source })?;
        for (i, line) in std::io::BufReader::new(file).lines().enumerate() {
            let line = line.map_err(|source| Error::Io { path: f.clone(), source })?;
            if line.trim().is_empty() {
                continue;
            }
            let t: Trial = serde_json::from_str(&line).map_err(|e| Error::TrialLine {
                path: f.clone(),
                line: i + 1,
                what: format!("not a trial: {e}"),
            })?;
            if let Some(first) = trials.first()
                && first.profile != t.profile
            {
                return Err(Error::TrialLine {
                    path: f.clone(),
                    line: i + 1,
                    what: format!("a trial on another dataset ({}) than {}", t.profile.data, first.profile.data),
                });
            }
            if !trials.iter().any(|o| o.trial == t.trial) {
                trials.push(t);
            }
        }
    }
    trials.sort_by_key(|t| t.trial);
    Ok(trials)
}
