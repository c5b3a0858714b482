//! Summary statistics of a stream, accumulated chunk by chunk.

use crate::event::Event;
use serde::Serialize;

#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct StreamStats {
    pub events: u64,
    pub on: u64,
    pub off: u64,
    pub t_first_us: Option<i64>,
    pub t_last_us: Option<i64>,
    pub max_x: Option<u16>,
    pub max_y: Option<u16>,
}

impl StreamStats {
    pub fn add(&mut self, events: &[Event]) {
        let (Some(first), Some(last)) = (events.first(), events.last()) else { return };
        self.t_first_us.get_or_insert(first.t_us);
        self.t_last_us = Some(last.t_us);
        let mut on = 0u64;
        let (mut mx, mut my) = (self.max_x.unwrap_or(0), self.max_y.unwrap_or(0));
        for e in events {
            on += e.polarity.is_on() as u64;
            mx = mx.max(e.x);
            my = my.max(e.y);
        }
        self.max_x = Some(mx);
        self.max_y = Some(my);
        self.events += events.len() as u64;
        self.on += on;
        self.off += events.len() as u64 - on;
    }

    /// Time from the first to the last event, in seconds.
    pub fn duration_s(&self) -> f64 {
        match (self.t_first_us, self.t_last_us) {
            (Some(a), Some(b)) => (b - a) as f64 * 1e-6,
            _ => 0.0,
        }
    }

    /// Events per second over the duration (0 for fewer than two distinct times).
    pub fn rate_hz(&self) -> f64 {
        let d = self.duration_s();
        if d > 0.0 { self.events as f64 / d } else { 0.0 }
    }

    /// ON events per OFF event (`None` without OFF events).
    pub fn on_off_ratio(&self) -> Option<f64> {
        (self.off > 0).then(|| self.on as f64 / self.off as f64)
    }
}
/// What `braille info` reports of an event file: its format and declared metadata, and the
/// statistics of every event, read chunk by chunk with bounded memory.
#[derive(Debug, Clone, Serialize)]
pub struct FileSummary {
    pub path: std::path::PathBuf,
    pub format: crate::formats::Format,
    pub resolution: Option<String>,
    pub source: Option<String>,
    pub events: u64,
    pub duration_s: f64,
    pub event_rate_hz: f64,
    pub on: u64,
    pub off: u64,
    pub on_off_ratio: Option<f64>,
    pub t_first_us: Option<i64>,
    pub t_last_us: Option<i64>,
    pub max_x: Option<u16>,
    pub max_y: Option<u16>,
}

/// What `braille info` prints: one field per line.
impl std::fmt::Display for FileSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let opt = |v: Option<String>| v.unwrap_or_else(|| "-".into());
        let num = |v: Option<i64>| opt(v.map(|v| v.to_string()));
        writeln!(f, "file         {}", self.path.display())?;
        writeln!(f, "format       {}", self.format)?;
        writeln!(f, "resolution   {}", self.resolution.as_deref().unwrap_or("not declared"))?;
        if let Some(s) = &self.source {
            writeln!(f, "source       {s}")?;
        }
        writeln!(f, "events       {} ({} ON, {} OFF)", self.events, self.on, self.off)?;
        writeln!(f, "ON/OFF ratio {}", opt(self.on_off_ratio.map(|v| format!("{v:.3}"))))?;
        writeln!(f, "duration     {:.6} s", self.duration_s)?;
        writeln!(f, "event rate   {:.1} events/s", self.event_rate_hz)?;
        writeln!(f, "time range   {} .. {} us", num(self.t_first_us), num(self.t_last_us))?;
        let (x, y) = (num(self.max_x.map(i64::from)), num(self.max_y.map(i64::from)));
        writeln!(f, "max x, y     {x}, {y}")
    }
}

impl FileSummary {
    /// Reads every event of the file at `path`.
    pub fn of(path: &std::path::Path, options: &crate::formats::OpenOptions) -> crate::Result<FileSummary> {
        let mut source = crate::formats::open(path, options)?;
        let mut stats = StreamStats::default();
        while let Some(chunk) = source.next_chunk()? {
            stats.add(chunk);
        }
        let info = source.info();
        Ok(FileSummary {
            path: path.to_path_buf(),
            format: info.format,
            resolution: info.resolution.map(|r| r.to_string()),
            source: info.source.clone(),
            events: stats.events,
            duration_s: stats.duration_s(),
            event_rate_hz: stats.rate_hz(),
            on: stats.on,
            off: stats.off,
            on_off_ratio: stats.on_off_ratio(),
            t_first_us: stats.t_first_us,
            t_last_us: stats.t_last_us,
            max_x: stats.max_x,
            max_y: stats.max_y,
        })
    }
}
