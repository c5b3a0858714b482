//! Tactile datasets kept as folders of CSV files, in the layout of the iCub Braille recordings
//! (Müller-Cleve et al. 2022), for any number of channels and classes:
//!
//! - event data: `samples.csv` (sample, letter, label, ...), `events.csv` (sample, taxel, pol,
//!   t_s), `split.csv` (sample, split);
//! - analog data: `raw.csv` (sample, letter, label, ..., t_idx, then one column per channel) and
//!   `split.csv`.
//!
//! Events get `x = channel`, `y = 0`; analog samples keep their frames for an encoder such as
//! [`crate::sigma_delta`].

use crate::error::{Error, Location, Result};
use crate::event::{Event, Polarity, Resolution};
use serde::Serialize;
use std::collections::HashMap;

use std::path::{Path, PathBuf};

/// Which part of a fixed split a sample belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Split {
    Train,
    Validation,
    Test,
}

impl Split {
    fn parse(s: &str) -> Option<Split> {
        match s.trim().to_ascii_lowercase().as_str() {
            "train" => Some(Split::Train),
            "val" | "valid" | "validation" => Some(Split::Validation),
            "test" => Some(Split::Test),
            _ => None,
        }
    }
}

/// What a sample holds.
#[derive(Debug, Clone, PartialEq)]
pub enum SampleData {
    /// Events in time order, `t_us` from the sample's start.
    Events(Vec<Event>),
    /// `frames.len() / channels` frames of `channels` values, sampled every `period_us`.
    Analog { frames: Vec<f32> },
}

#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    pub id: u64,
    pub label: usize,
    pub split: Split,
    pub data: SampleData,
}

/// The kind of data a dataset folder holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DatasetKind {
    Events,
    Analog,
}

#[derive(Debug, Clone)]
pub struct Dataset {
    pub dir: PathBuf,
    pub kind: DatasetKind,
    /// Class names by label.
    pub classes: Vec<String>,
    pub channels: usize,
    /// Sampling period of analog data (the caller's setting; 0 for event data).
    pub period_us: i64,
    pub samples: Vec<Sample>,
}

impl Dataset {
    /// Loads a dataset folder. `period_us` is the sampling period of analog data (40 Hz, 25 000
    /// us, for the iCub recordings), ignored for event data.
    pub fn load(dir: &Path, period_us: i64) -> Result<Dataset> {
        let split = read_split(&dir.join("split.csv"))?;
        if dir.join("raw.csv").exists() {
            load_analog(dir, period_us, &split)
        } else if dir.join("events.csv").exists() {
            load_events(dir, &split)
        } else {
            Err(Error::Unsupported {
                path: dir.to_path_buf(),
                what: "not a dataset folder: expected raw.csv (analog data) or samples.csv and events.csv (event data)"
                    .into(),
            })
        }
    }

    /// The sensor geometry of the events: one row of `channels` taxels.
    pub fn resolution(&self) -> Resolution {
        Resolution::new(self.channels as u16, 1)
    }

    pub fn split(&self, split: Split) -> impl Iterator<Item = &Sample> {
        self.samples.iter().filter(move |s| s.split == split)
    }

    /// The samples of the classes `names` only, relabelled `0..names.len()` in that order (a
    /// benchmark's class subset, such as the NIR paper's seven Braille letters); a name the
    /// dataset lacks is an error that lists its classes.
    pub fn select_classes(&self, names: &[String]) -> Result<Dataset> {
        let mut map = vec![None; self.classes.len()];
        for (new, name) in names.iter().enumerate() {
            let old = self.classes.iter().position(|c| c == name).ok_or_else(|| {
                Error::config(
                    "classes",
                    format!("{}: no class `{name}` (the classes are {})", self.dir.display(), self.classes.join(", ")),
                )
            })?;
            if map[old].replace(new).is_some() {
                return Err(Error::config("classes", format!("class `{name}` is named twice")));
            }
        }
        let samples =
            self.samples.iter().filter_map(|s| map[s.label].map(|label| Sample { label, ..s.clone() })).collect();
        Ok(Dataset {
            dir: self.dir.clone(),
            kind: self.kind,
            classes: names.to_vec(),
            channels: self.channels,
            period_us: self.period_us,
            samples,
        })
    }
}

/// A CSV file read row by row (the `csv` crate: RFC 4180 quoting, fields trimmed, blank lines
/// skipped), with columns found by name and errors that name the file and the line.
struct Table {
    path: PathBuf,
    reader: csv::Reader<std::fs::File>,
    record: csv::StringRecord,
    header: Vec<String>,
    line_no: u64,
}

impl Table {
    fn open(path: &Path) -> Result<Table> {
        let file = std::fs::File::open(path).map_err(|e| Error::Io { path: path.into(), source: e })?;
        let mut reader = csv::ReaderBuilder::new().trim(csv::Trim::All).flexible(true).from_reader(file);
        let header: Vec<String> =
            reader.headers().map_err(|e| csv_error(path, e))?.iter().map(str::to_string).collect();
        if header.is_empty() {
            return Err(Error::Empty { path: path.into(), expected: "a header line".into() });
        }
        Ok(Table { path: path.into(), reader, record: csv::StringRecord::new(), header, line_no: 1 })
    }

    fn column(&self, name: &str) -> Result<usize> {
        self.header.iter().position(|h| h == name).ok_or_else(|| Error::Parse {
            path: self.path.clone(),
            at: Location::Line(1),
            field: name.into(),
            expected: format!("a column named `{name}`"),
            found: self.header.join(","),
        })
    }

    /// The next row's fields, or `None` at the end.
    fn next_row(&mut self) -> Result<Option<Vec<String>>> {
        loop {
            if !self.reader.read_record(&mut self.record).map_err(|e| csv_error(&self.path, e))? {
                return Ok(None);
            }
            self.line_no = self.record.position().map_or(self.line_no + 1, |p| p.line());
            if self.record.iter().all(str::is_empty) {
                continue;
            }
            if self.record.len() != self.header.len() {
                return Err(Error::Parse {
                    path: self.path.clone(),
                    at: Location::Line(self.line_no),
                    field: "row".into(),
                    expected: format!("{} fields as in the header", self.header.len()),
                    found: self.record.iter().collect::<Vec<_>>().join(","),
                });
            }
            return Ok(Some(self.record.iter().map(str::to_string).collect()));
        }
    }

    fn parse<T: std::str::FromStr>(&self, fields: &[String], col: usize, expected: &str) -> Result<T> {
        fields[col].parse().map_err(|_| Error::Parse {
            path: self.path.clone(),
            at: Location::Line(self.line_no),
            field: self.header[col].clone(),
            expected: expected.into(),
            found: fields[col].clone(),
        })
    }
}

/// A `csv` error as ours: I/O errors keep their source, malformed rows name the line.
fn csv_error(path: &Path, e: csv::Error) -> Error {
    let line = e.position().map_or(0, |p| p.line());
    match e.into_kind() {
        csv::ErrorKind::Io(source) => Error::Io { path: path.into(), source },
        csv::ErrorKind::Utf8 { err, .. } => Error::Parse {
            path: path.into(),
            at: Location::Line(line),
            field: "row".into(),
            expected: "UTF-8 text".into(),
            found: err.to_string(),
        },
        other => Error::Parse {
            path: path.into(),
            at: Location::Line(line),
            field: "row".into(),
            expected: "a CSV row".into(),
            found: format!("{other:?}"),
        },
    }
}

fn read_split(path: &Path) -> Result<HashMap<u64, Split>> {
    let mut t = Table::open(path)?;
    let (cs, cp) = (t.column("sample")?, t.column("split")?);
    let mut out = HashMap::new();
    while let Some(f) = t.next_row()? {
        let id: u64 = t.parse(&f, cs, "a sample number")?;
        let split = Split::parse(&f[cp]).ok_or_else(|| Error::Parse {
            path: t.path.clone(),
            at: Location::Line(t.line_no),
            field: "split".into(),
            expected: "train, validation or test".into(),
            found: f[cp].clone(),
        })?;
        out.insert(id, split);
    }
    Ok(out)
}

/// Records a class name for a label, checking that one label always has one name.
fn register(classes: &mut Vec<String>, label: usize, name: &str, t: &Table) -> Result<()> {
    if classes.len() <= label {
        classes.resize(label + 1, String::new());
    }
    if classes[label].is_empty() {
        classes[label] = name.to_string();
    } else if classes[label] != name {
        return Err(Error::Parse {
            path: t.path.clone(),
            at: Location::Line(t.line_no),
            field: "letter".into(),
            expected: format!("{:?} (the name of label {label} so far)", classes[label]),
            found: name.into(),
        });
    }
    Ok(())
}

fn split_of(split: &HashMap<u64, Split>, id: u64, t: &Table) -> Result<Split> {
    split.get(&id).copied().ok_or_else(|| Error::Parse {
        path: t.path.clone(),
        at: Location::Line(t.line_no),
        field: "sample".into(),
        expected: "a sample listed in split.csv".into(),
        found: id.to_string(),
    })
}

fn load_analog(dir: &Path, period_us: i64, split: &HashMap<u64, Split>) -> Result<Dataset> {
    if period_us <= 0 {
        return Err(Error::config("sampling period", format!("must be positive, got {period_us} us")));
    }
    let mut t = Table::open(&dir.join("raw.csv"))?;
    let (cs, cl, cn, ct) = (t.column("sample")?, t.column("label")?, t.column("letter")?, t.column("t_idx")?);
    let first_channel = ct + 1;
    let channels = t.header.len() - first_channel;
    if channels == 0 {
        return Err(Error::Parse {
            path: t.path.clone(),
            at: Location::Line(1),
            field: "channels".into(),
            expected: "one column per channel after t_idx".into(),
            found: t.header.join(","),
        });
    }
    let mut classes = Vec::new();
    let mut samples: Vec<Sample> = Vec::new();
    let mut index: HashMap<u64, usize> = HashMap::new();
    let mut next_t: HashMap<u64, u64> = HashMap::new();
    while let Some(f) = t.next_row()? {
        let id: u64 = t.parse(&f, cs, "a sample number")?;
        let label: usize = t.parse(&f, cl, "a class label (0, 1, ...)")?;
        let t_idx: u64 = t.parse(&f, ct, "a frame index")?;
        register(&mut classes, label, &f[cn], &t)?;
        let i = match index.get(&id) {
            Some(&i) => i,
            None => {
                let s = Sample {
                    id,
                    label,
                    split: split_of(split, id, &t)?,
                    data: SampleData::Analog { frames: Vec::new() },
                };
                samples.push(s);
                index.insert(id, samples.len() - 1);
                samples.len() - 1
            }
        };
        let expected_t = next_t.entry(id).or_insert(0);
        if t_idx != *expected_t || samples[i].label != label {
            return Err(Error::Parse {
                path: t.path.clone(),
                at: Location::Line(t.line_no),
                field: "t_idx".into(),
                expected: format!("frame {} of sample {id} with label {}", expected_t, samples[i].label),
                found: format!("frame {t_idx}, label {label}"),
            });
        }
        *expected_t += 1;
        for c in first_channel..f.len() {
            let v: f32 = t.parse(&f, c, "a number")?;
            if !v.is_finite() {
                return Err(Error::Parse {
                    path: t.path.clone(),
                    at: Location::Line(t.line_no),
                    field: t.header[c].clone(),
                    expected: "a finite number".into(),
                    found: f[c].clone(),
                });
            }
            if let SampleData::Analog { frames } = &mut samples[i].data {
                frames.push(v);
            }
        }
    }
    Ok(Dataset { dir: dir.into(), kind: DatasetKind::Analog, classes, channels, period_us, samples })
}

fn load_events(dir: &Path, split: &HashMap<u64, Split>) -> Result<Dataset> {
    let mut t = Table::open(&dir.join("samples.csv"))?;
    let (cs, cl, cn) = (t.column("sample")?, t.column("label")?, t.column("letter")?);
    let mut classes = Vec::new();
    let mut samples = Vec::new();
    let mut index = HashMap::new();
    while let Some(f) = t.next_row()? {
        let id: u64 = t.parse(&f, cs, "a sample number")?;
        let label: usize = t.parse(&f, cl, "a class label (0, 1, ...)")?;
        register(&mut classes, label, &f[cn], &t)?;
        index.insert(id, samples.len());
        samples.push(Sample { id, label, split: split_of(split, id, &t)?, data: SampleData::Events(Vec::new()) });
    }
    let mut t = Table::open(&dir.join("events.csv"))?;
    let (cs, cc, cp, ct) = (t.column("sample")?, t.column("taxel")?, t.column("pol")?, t.column("t_s")?);
    let mut channels = 0usize;
    while let Some(f) = t.next_row()? {
        let id: u64 = t.parse(&f, cs, "a sample number")?;
        let taxel: u16 = t.parse(&f, cc, "a channel number from 0 to 65535")?;
        let pol: u8 = t.parse(&f, cp, "1 (ON) or 0 (OFF)")?;
        let t_s: f64 = t.parse(&f, ct, "a time in seconds")?;
        if !t_s.is_finite() || pol > 1 {
            let (field, found) = if pol > 1 { ("pol", &f[cp]) } else { ("t_s", &f[ct]) };
            return Err(Error::Parse {
                path: t.path.clone(),
                at: Location::Line(t.line_no),
                field: field.into(),
                expected: if pol > 1 { "1 (ON) or 0 (OFF)".into() } else { "a finite time in seconds".into() },
                found: found.clone(),
            });
        }
        let &i = index.get(&id).ok_or_else(|| Error::Parse {
            path: t.path.clone(),
            at: Location::Line(t.line_no),
            field: "sample".into(),
            expected: "a sample listed in samples.csv".into(),
            found: id.to_string(),
        })?;
        channels = channels.max(taxel as usize + 1);
        let e = Event::new((t_s * 1e6).round() as i64, taxel, 0, Polarity::from_on(pol == 1));
        if let SampleData::Events(ev) = &mut samples[i].data {
            if ev.last().is_some_and(|l: &Event| l.t_us > e.t_us) {
                return Err(Error::TimestampBackwards {
                    path: t.path.clone(),
                    at: Location::Line(t.line_no),
                    t_us: e.t_us,
                    previous_us: ev.last().map_or(0, |l| l.t_us),
                });
            }
            ev.push(e);
        }
    }
    Ok(Dataset { dir: dir.into(), kind: DatasetKind::Events, classes, channels, period_us: 0, samples })
}
