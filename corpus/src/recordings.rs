//! A lab's own recorded scans: a folder of event files and a manifest (docs/recordings.md).
//!
//! `DIR/manifest.csv` has the header `file,role,text,speed_mm_s,depth_mm` (further columns are
//! allowed and kept, e.g. `direction`, `sensor`, `notes`): `file` relative to DIR (AEDAT4, CSV
//! or .npy), `role` one of `train`, `val`, `test`, `text` the printed row as written on the board,
//! and the commanded `speed_mm_s` and `depth_mm`, which label training and validation data and
//! group test results; a reader never gets them. [`Recordings::open`] checks the whole manifest
//! and names the line and the field of the first thing wrong; [`Recordings::check`] also reads
//! every event file through (a bad file is named with the place) and summarises the folder.

use encoders::formats::{self, OpenOptions};
use serde::Serialize;
use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};

/// The manifest's name inside a recordings folder.
pub const MANIFEST: &str = "manifest.csv";

/// The columns every manifest has.
pub const COLUMNS: [&str; 5] = ["file", "role", "text", "speed_mm_s", "depth_mm"];

/// What a recorded scan is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Cut into training windows.
    Train,
    /// Chooses checkpoints and the reader's operating point.
    Val,
    /// Scored, never used to choose anything.
    #[default]
    Test,
}

impl Role {
    pub const ALL: [Role; 3] = [Role::Train, Role::Val, Role::Test];

    pub fn name(self) -> &'static str {
        match self {
            Role::Train => "train",
            Role::Val => "val",
            Role::Test => "test",
        }
    }
}

/// One line of the manifest.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Recording {
    /// The event file, as the manifest names it (relative to the folder).
    pub file: PathBuf,
    pub role: Role,
    /// The printed row, as written on the board (letters and spaces).
    pub text: String,
    pub speed_mm_s: f64,
    pub depth_mm: f64,
    /// The manifest's further columns, by name.
    pub extra: BTreeMap<String, String>,
    /// The manifest's line (1-based, the header is line 1).
    pub line: u64,
}

/// What is wrong with a recordings folder, with the line and the field.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("{}: {source}", path.display())]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{}: line {line}: {source}", path.display())]
    Csv { path: PathBuf, line: u64, source: csv::Error },
    #[error("{}: the header lacks the column `{column}` (a manifest starts `file,role,text,speed_mm_s,depth_mm`)", path.display())]
    MissingColumn { path: PathBuf, column: &'static str },
    #[error("{}: line {line}: field `{field}`: {what}", path.display())]
    Field { path: PathBuf, line: u64, field: &'static str, what: String },
    #[error("{}: no scans: every line after the header is a recorded scan", path.display())]
    Empty { path: PathBuf },
    #[error("{}: line {line}: {source}", path.display())]
    Events { path: PathBuf, line: u64, source: Box<encoders::Error> },
}

/// A checked recordings folder.
#[derive(Debug, Clone, Serialize)]
pub struct Recordings {
    pub dir: PathBuf,
    pub recordings: Vec<Recording>,
}

impl Recordings {
    /// Reads and checks `dir`'s manifest: the columns, every field of every line, that every
    /// file exists, and that no file is listed twice. The event files are not read.
    pub fn open(dir: &Path) -> Result<Recordings, Error> {
        let path = dir.join(MANIFEST);
        let file = std::fs::File::open(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
        let mut reader = csv::ReaderBuilder::new().trim(csv::Trim::All).flexible(false).from_reader(file);
        let header = reader.headers().map_err(|source| Error::Csv { path: path.clone(), line: 1, source })?.clone();
        let index = |column: &'static str| {
            header.iter().position(|h| h == column).ok_or(Error::MissingColumn { path: path.clone(), column })
        };
        let [file_at, role_at, text_at, speed_at, depth_at] =
            [index("file")?, index("role")?, index("text")?, index("speed_mm_s")?, index("depth_mm")?];
        let mut recordings = Vec::new();
        let mut seen = HashSet::new();
        for (k, record) in reader.records().enumerate() {
            let line = k as u64 + 2;
            let record = record.map_err(|source| Error::Csv { path: path.clone(), line, source })?;
            let bad = |field: &'static str, what: String| Error::Field { path: path.clone(), line, field, what };
            let get = |at: usize| record.get(at).unwrap_or("");
            let name = get(file_at);
            if name.is_empty() {
                return Err(bad("file", "empty: name the event file, relative to the folder".into()));
            }
            let file = PathBuf::from(name);
            if file.is_absolute() || file.components().any(|c| c == std::path::Component::ParentDir) {
                return Err(bad("file", format!("{name:?} is not inside the folder: give a path relative to it")));
            }
            if !dir.join(&file).is_file() {
                return Err(bad("file", format!("{name:?}: no such file in {}", dir.display())));
            }
            if !seen.insert(file.clone()) {
                return Err(bad("file", format!("{name:?} is listed twice")));
            }
            let role = match get(role_at) {
                "train" => Role::Train,
                "val" => Role::Val,
                "test" => Role::Test,
                "" => return Err(bad("role", "empty: one of train, val, test".into())),
                other => return Err(bad("role", format!("{other:?} is not a role: one of train, val, test"))),
            };
            let text = get(text_at).to_string();
            if text.trim().is_empty() {
                return Err(bad("text", "empty: the printed row, as written on the board".into()));
            }
            if let Some((i, c)) = text.chars().enumerate().find(|&(_, c)| encoders::braille::cell_of(c).is_none()) {
                return Err(bad(
                    "text",
                    format!(
                        "character {c:?} (position {}) is not in the Braille table the readers read (the paper's 26 letters and the space)",
                        i + 1
                    ),
                ));
            }
            let number = |at: usize, field: &'static str, unit: &str| -> Result<f64, Error> {
                let v = get(at);
                match v.parse::<f64>() {
                    Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
                    Ok(_) => Err(bad(field, format!("{v} is not a positive number of {unit}"))),
                    Err(_) => Err(bad(field, format!("{v:?} is not a number ({unit})"))),
                }
            };
            let speed_mm_s = number(speed_at, "speed_mm_s", "mm/s")?;
            let depth_mm = number(depth_at, "depth_mm", "mm")?;
            let extra = header
                .iter()
                .enumerate()
                .filter(|(i, _)| ![file_at, role_at, text_at, speed_at, depth_at].contains(i))
                .map(|(i, h)| (h.to_string(), get(i).to_string()))
                .collect();
            recordings.push(Recording { file, role, text, speed_mm_s, depth_mm, extra, line });
        }
        if recordings.is_empty() {
            return Err(Error::Empty { path });
        }
        Ok(Recordings { dir: dir.to_path_buf(), recordings })
    }

    /// The commanded (speed, depth) pairs of `role`'s scans, by speed then depth.
    pub fn conditions(&self, role: Role) -> Vec<(f64, f64)> {
        let mut out: Vec<(f64, f64)> = Vec::new();
        for r in self.role(role) {
            if !out.contains(&(r.speed_mm_s, r.depth_mm)) {
                out.push((r.speed_mm_s, r.depth_mm));
            }
        }
        out.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        out
    }

    /// The scans of one role, in the manifest's order.
    pub fn role(&self, role: Role) -> impl Iterator<Item = &Recording> {
        self.recordings.iter().filter(move |r| r.role == role)
    }

    /// The event file of a recording.
    pub fn path(&self, r: &Recording) -> PathBuf {
        self.dir.join(&r.file)
    }

    /// Reads every event file through (each checked as `braille info` checks a file: order,
    /// range, framing) and summarises the folder per role and condition. Nothing is written.
    pub fn check(&self) -> Result<CheckSummary, Error> {
        let mut groups: BTreeMap<(Role, String, String), Group> = BTreeMap::new();
        for r in &self.recordings {
            let path = self.path(r);
            let wrap =
                |e: encoders::Error| Error::Events { path: self.dir.join(MANIFEST), line: r.line, source: Box::new(e) };
            let mut source = formats::open(&path, &OpenOptions::default()).map_err(wrap)?;
            let (mut events, mut first, mut last) = (0u64, None, 0i64);
            while let Some(chunk) = source.next_chunk().map_err(wrap)? {
                events += chunk.len() as u64;
                first.get_or_insert(chunk[0].t_us);
                last = chunk[chunk.len() - 1].t_us;
            }
            let duration_s = first.map_or(0.0, |f| (last - f) as f64 / 1e6);
            let g =
                groups.entry((r.role, format!("{}", r.speed_mm_s), format!("{}", r.depth_mm))).or_insert_with(|| {
                    Group { role: r.role, speed_mm_s: r.speed_mm_s, depth_mm: r.depth_mm, ..Group::default() }
                });
            g.scans += 1;
            g.events += events;
            g.duration_s += duration_s;
            g.characters += r.text.chars().filter(|c| *c != ' ').count();
            if events == 0 {
                g.empty_files.push(r.file.clone());
            }
        }
        let mut groups: Vec<Group> = groups.into_values().collect();
        for g in &mut groups {
            g.event_rate_hz = if g.duration_s > 0.0 { g.events as f64 / g.duration_s } else { 0.0 };
        }
        let roles = Role::ALL
            .iter()
            .map(|&role| {
                let of: Vec<&Group> = groups.iter().filter(|g| g.role == role).collect();
                RoleSummary {
                    role,
                    scans: of.iter().map(|g| g.scans).sum(),
                    events: of.iter().map(|g| g.events).sum(),
                    duration_s: of.iter().map(|g| g.duration_s).sum::<f64>() + 0.0,
                    characters: of.iter().map(|g| g.characters).sum(),
                }
            })
            .collect();
        Ok(CheckSummary { dir: self.dir.clone(), scans: self.recordings.len(), roles, groups })
    }
}

/// SIMULATED scans written as a lab would keep them (the path the recordings commands are tested
/// on): the scans of `spec` (`spec.out` is the folder) as `NNNNN.aedat4`, numbered on from the
/// folder's manifest, with no ground truth beside them, and their lines appended to the manifest
/// (created with its header if absent) with `role`, each row's text and the commanded speed and
/// depth. With `world`, the scans are those `eval words` reads for the same board, speed, depth,
/// trials and seed in that world (its scan seeds, trial `k` on its build `k mod builds`, its
/// preset and mount), not `spec`'s sensor seed and `braille simulate`'s own seeds. Returns the
/// lines written.
pub fn export(
    spec: &crate::scans::ScanSpec,
    world: Option<&crate::World>,
    role: Role,
    progress: &dyn crate::Progress,
) -> crate::Result<Vec<Recording>> {
    use rayon::prelude::*;
    let dir = &spec.out;
    std::fs::create_dir_all(dir).map_err(|source| crate::Error::Io { path: dir.clone(), source })?;
    let manifest = dir.join(MANIFEST);
    let (mut text, first) = if manifest.exists() {
        let existing = Recordings::open(dir)?;
        let next = existing
            .recordings
            .iter()
            .filter_map(|r| r.file.file_stem()?.to_str()?.parse::<u64>().ok())
            .max()
            .map_or(existing.recordings.len() as u64, |n| n.max(existing.recordings.len() as u64))
            + 1;
        let text =
            std::fs::read_to_string(&manifest).map_err(|source| crate::Error::Io { path: manifest.clone(), source })?;
        (text, next)
    } else {
        (format!("{}\n", COLUMNS.join(",")), 1)
    };
    if !text.ends_with('\n') {
        text.push('\n');
    }
    let scanner = crate::scans::Scanner::of(spec)?;
    let kind = spec.board_kind()?;
    // the world's scans: its preset's setup, its board print, its builds
    let in_world = match world {
        Some(w) => {
            let setup = w.setup();
            let board = w.board(&setup, &kind)?;
            let sensors = w.sensors_at(&setup, spec.resolution)?;
            Some((w, setup, board, sensors))
        }
        None => None,
    };
    let rows: Vec<usize> = match spec.row {
        Some(r) if r >= scanner.board.rows.len() => {
            return Err(crate::Error::NoSuchRow { row: r, rows: scanner.board.rows.len() });
        }
        Some(r) => vec![r],
        None => (0..scanner.board.rows.len()).collect(),
    };
    let jobs: Vec<(usize, u64)> = rows.iter().flat_map(|&r| (0..spec.trials).map(move |t| (r, t))).collect();
    progress.start("simulating scans", jobs.len() as u64);
    let written: Vec<Recording> = jobs
        .par_iter()
        .enumerate()
        .map(|(k, &(row, trial))| -> crate::Result<Recording> {
            let s = match &in_world {
                None => scanner.scan(row, trial)?,
                Some((w, setup, board, sensors)) => {
                    let seed = w.scan_seed(spec.seed, &kind, row, trial, spec.speed, spec.depth);
                    let sensor = &sensors[(trial % sensors.len() as u64) as usize];
                    sim::simulate(board, sensor, &setup.scan(spec.speed, spec.depth, row, seed))?
                }
            };
            let file = PathBuf::from(format!("{:05}.aedat4", first + k as u64));
            crate::scans::write_events(&dir.join(&file), &s.events, spec.resolution, spec.force)?;
            progress.inc();
            Ok(Recording {
                file,
                role,
                text: s.truth.row_text,
                speed_mm_s: spec.speed,
                depth_mm: spec.depth,
                extra: BTreeMap::new(),
                line: 0,
            })
        })
        .collect::<crate::Result<_>>()?;
    progress.finish();
    // each line in the header's order of columns (a lab's manifest may order them otherwise, or
    // have more); the columns this writer does not know stay empty
    let header: Vec<String> = text.lines().next().unwrap_or("").split(',').map(|h| h.trim().to_string()).collect();
    for r in &written {
        let field = |column: &str| match column {
            "file" => r.file.display().to_string(),
            "role" => role.name().to_string(),
            "text" => r.text.clone(),
            "speed_mm_s" => r.speed_mm_s.to_string(),
            "depth_mm" => r.depth_mm.to_string(),
            _ => String::new(),
        };
        text.push_str(&header.iter().map(|c| field(c)).collect::<Vec<_>>().join(","));
        text.push('\n');
    }
    let mut out = encoders::formats::AtomicFile::create(&manifest, true)?;
    std::io::Write::write_all(&mut out, text.as_bytes())
        .map_err(|source| crate::Error::Io { path: manifest.clone(), source })?;
    out.commit()?;
    // the folder as written reads back
    let back = Recordings::open(dir)?;
    Ok(back.recordings[back.recordings.len() - written.len()..].to_vec())
}

/// The scans of one role at one commanded speed and depth.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Group {
    pub role: Role,
    pub speed_mm_s: f64,
    pub depth_mm: f64,
    pub scans: usize,
    pub events: u64,
    pub duration_s: f64,
    pub event_rate_hz: f64,
    /// Printed characters (spaces not counted).
    pub characters: usize,
    /// Files that hold no events (allowed, but worth a look).
    pub empty_files: Vec<PathBuf>,
}

/// One role over every condition.
#[derive(Debug, Clone, Serialize)]
pub struct RoleSummary {
    pub role: Role,
    pub scans: usize,
    pub events: u64,
    pub duration_s: f64,
    pub characters: usize,
}

/// What `braille recordings check` reports.
#[derive(Debug, Clone, Serialize)]
pub struct CheckSummary {
    pub dir: PathBuf,
    pub scans: usize,
    pub roles: Vec<RoleSummary>,
    pub groups: Vec<Group>,
}

/// What `braille recordings check` prints: a table per role and condition, each role's totals,
/// and every event file that holds no events.
impl std::fmt::Display for CheckSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "{}: {} scans", self.dir.display(), self.scans)?;
        writeln!(f, "| role | speed (mm/s) | depth (mm) | scans | characters | events | duration (s) | events/s |")?;
        writeln!(f, "| --- | --- | --- | --- | --- | --- | --- | --- |")?;
        for g in &self.groups {
            writeln!(
                f,
                "| {} | {} | {} | {} | {} | {} | {:.1} | {:.0} |",
                g.role.name(),
                g.speed_mm_s,
                g.depth_mm,
                g.scans,
                g.characters,
                g.events,
                g.duration_s,
                g.event_rate_hz
            )?;
        }
        for r in &self.roles {
            let name = r.role.name();
            writeln!(
                f,
                "{name}: {} scans, {} characters, {} events, {:.1} s",
                r.scans, r.characters, r.events, r.duration_s
            )?;
        }
        for file in self.groups.iter().flat_map(|g| &g.empty_files) {
            writeln!(f, "note: {} holds no events", file.display())?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A folder with `manifest` and two small event files, `a.csv` and `b.csv`.
    fn folder(manifest: &str) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("a.csv"), "t_us,x,y,p\n0,1,2,1\n500000,3,4,0\n1000000,5,6,1\n").unwrap();
        std::fs::write(dir.path().join("b.csv"), "t_us,x,y,p\n0,1,2,1\n2000000,3,4,0\n").unwrap();
        std::fs::write(dir.path().join(MANIFEST), manifest).unwrap();
        dir
    }

    #[test]
    fn a_good_folder_is_summarised_per_role_and_condition() {
        let dir = folder(
            "file,role,text,speed_mm_s,depth_mm,notes\na.csv,train,HELLO WORLD,16,1.0,first\nb.csv, test ,stop,32,1.5,\n",
        );
        let r = Recordings::open(dir.path()).unwrap();
        assert_eq!(r.recordings.len(), 2);
        assert_eq!(r.recordings[1].role, Role::Test);
        assert_eq!(r.recordings[0].extra["notes"], "first");
        let s = r.check().unwrap();
        let train = &s.roles[0];
        assert_eq!(
            (train.role, train.scans, train.events, train.duration_s, train.characters),
            (Role::Train, 1, 3, 1.0, 10)
        );
        assert_eq!(s.groups.len(), 2);
        let test = &s.groups[1];
        assert_eq!((test.speed_mm_s, test.depth_mm, test.events, test.event_rate_hz), (32.0, 1.5, 2, 1.0));
    }

    #[test]
    fn a_bad_manifest_names_the_line_and_the_field() {
        let head = "file,role,text,speed_mm_s,depth_mm\n";
        for (body, want) in [
            ("a.csv,training,HELLO,16,1\n", "line 2: field `role`: \"training\" is not a role"),
            ("a.csv,train,HELLO,16,1\nc.csv,test,HELLO,16,1\n", "line 3: field `file`: \"c.csv\": no such file"),
            ("a.csv,train,HELLO 2,16,1\n", "line 2: field `text`: character '2' (position 7)"),
            ("a.csv,train,HELLO,fast,1\n", "line 2: field `speed_mm_s`: \"fast\" is not a number (mm/s)"),
            ("a.csv,train,HELLO,16,-1\n", "line 2: field `depth_mm`: -1 is not a positive number of mm"),
            (
                "a.csv,train,HELLO,16,1\nb.csv,val,HELP,16,1\na.csv,test,HELLO,16,1\n",
                "line 4: field `file`: \"a.csv\" is listed twice",
            ),
            ("a.csv,,HELLO,16,1\n", "line 2: field `role`: empty"),
            ("../a.csv,train,HELLO,16,1\n", "line 2: field `file`: \"../a.csv\" is not inside the folder"),
            ("", "no scans"),
        ] {
            let dir = folder(&format!("{head}{body}"));
            let e = Recordings::open(dir.path()).unwrap_err().to_string();
            assert!(e.starts_with(&dir.path().join(MANIFEST).display().to_string()), "{e}");
            assert!(e.contains(want), "{e}\nwanted: {want}");
        }
        let dir = folder("file,role,text,speed_mm_s\na.csv,train,HELLO,16\n");
        let e = Recordings::open(dir.path()).unwrap_err().to_string();
        assert!(e.contains("lacks the column `depth_mm`"), "{e}");
        // a bad event file is named with its manifest line and the place in the file
        let dir = folder(&format!("{head}a.csv,train,HELLO,16,1\n"));
        std::fs::write(dir.path().join("a.csv"), "t_us,x,y,p\n5,1,2,1\n4,1,2,1\n").unwrap();
        let e = Recordings::open(dir.path()).unwrap().check().unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("a.csv: at line 3: timestamp 4 us goes backwards"), "{e}");
    }

    #[test]
    fn simulated_scans_export_as_a_folder_a_lab_would_keep() {
        let dir = tempfile::tempdir().unwrap();
        let spec = |board: &str, trials: u64, speed: f64| crate::scans::ScanSpec {
            board: board.into(),
            braille: pipeline::code::BrailleCode::Grade1Letters,
            speed,
            depth: 1.0,
            row: None,
            trials,
            seed: 3,
            board_seed: None,
            sensor_seed: 101,
            realism: sim::Realism::Nominal,
            direction: sim::Direction::Forward,
            mount_compliance_um_per_n: None,
            resolution: encoders::Resolution::DVXPLORER,
            out: dir.path().to_path_buf(),
            force: false,
        };
        let a = export(&spec("text:AB/CD", 1, 32.0), None, Role::Train, &()).unwrap();
        let b = export(&spec("text:HI", 2, 48.0), None, Role::Test, &()).unwrap();
        let names: Vec<String> = a.iter().chain(&b).map(|r| r.file.display().to_string()).collect();
        assert_eq!(names, ["00001.aedat4", "00002.aedat4", "00003.aedat4", "00004.aedat4"]);
        let manifest = std::fs::read_to_string(dir.path().join(MANIFEST)).unwrap();
        assert_eq!(
            manifest,
            "file,role,text,speed_mm_s,depth_mm\n00001.aedat4,train,AB,32,1\n00002.aedat4,train,CD,32,1\n\
             00003.aedat4,test,HI,48,1\n00004.aedat4,test,HI,48,1\n"
        );
        // no ground truth beside the scans: the manifest and the event files only
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 5);
        // a lab's manifest with its columns in another order and one more: new lines follow it
        let lab = tempfile::tempdir().unwrap();
        std::fs::copy(dir.path().join("00001.aedat4"), lab.path().join("mine.aedat4")).unwrap();
        std::fs::write(
            lab.path().join(MANIFEST),
            "role,file,notes,text,depth_mm,speed_mm_s\ntrain,mine.aedat4,gel 2,AB,1,32\n",
        )
        .unwrap();
        let c = export(
            &crate::scans::ScanSpec { out: lab.path().to_path_buf(), ..spec("text:HI", 1, 48.0) },
            None,
            Role::Val,
            &(),
        )
        .unwrap();
        assert_eq!(c[0].file, PathBuf::from("00002.aedat4"));
        let manifest = std::fs::read_to_string(lab.path().join(MANIFEST)).unwrap();
        assert!(manifest.ends_with("\nval,00002.aedat4,,HI,1,48\n"), "{manifest}");
        let s = Recordings::open(dir.path()).unwrap().check().unwrap();
        assert_eq!(s.roles.iter().map(|r| r.scans).collect::<Vec<_>>(), [2, 0, 2]);
        assert!(s.groups.iter().all(|g| g.events > 0 && g.empty_files.is_empty()));
    }
}
