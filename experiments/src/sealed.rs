//! The sealed test sets: the test boards printed anew, scanned by sensor builds and with scan
//! seeds no run has read ([`corpus::world::World::sealed`]), and read only by a report's `--final`
//! run. Each such run records its read in the ledger of docs/protocol.md ([`record`]), so that a
//! headline can say how many times its sealed set was read; the aim is once.

use crate::{Error, Result};
use std::path::Path;

/// The heading of the sealed sets' ledger in docs/protocol.md; its table follows it.
pub const LEDGER_HEADING: &str = "### Sealed test sets: every read";

/// One read of a sealed set.
#[derive(Debug, Clone)]
pub struct SealedRead {
    /// The set, as the ledger names it (`Table I (RAB), nominal`).
    pub set: String,
    /// The command that read it.
    pub command: String,
    /// Where the report was written.
    pub out: String,
}

/// Appends `read` to the ledger in `protocol` (docs/protocol.md) with today's UTC date, and
/// returns how many times its set has now been read, this read included. A protocol file without
/// the ledger's heading is an error that names it.
pub fn record(protocol: &Path, read: &SealedRead) -> Result<usize> {
    let io = |source| Error::Io { path: protocol.to_path_buf(), source };
    let text = std::fs::read_to_string(protocol).map_err(io)?;
    let Some(at) = text.find(LEDGER_HEADING) else {
        return Err(Error::Data { path: protocol.to_path_buf(), what: format!("no `{LEDGER_HEADING}` section") });
    };
    // the ledger's table: the first run of lines starting with `|` after the heading
    let after = at + LEDGER_HEADING.len();
    let lines: Vec<&str> = text[after..].split_inclusive('\n').collect();
    let (mut offset, mut in_table, mut end, mut reads) = (after, false, None, 0);
    for line in &lines {
        if line.starts_with('|') {
            in_table = true;
            let cells: Vec<&str> = line.split('|').map(str::trim).collect();
            if cells.get(2) == Some(&read.set.as_str()) {
                reads += 1;
            }
        } else if in_table {
            end = Some(offset);
            break;
        }
        offset += line.len();
    }
    if !in_table {
        return Err(Error::Data { path: protocol.to_path_buf(), what: format!("no table after `{LEDGER_HEADING}`") });
    }
    let end = end.unwrap_or(text.len());
    let cell = |s: &str| s.replace('|', "\\|");
    let row = format!("| {} | {} | `{}` | {} |\n", utc_date(), cell(&read.set), cell(&read.command), cell(&read.out));
    let mut out = String::with_capacity(text.len() + row.len() + 1);
    out.push_str(&text[..end]);
    if !out.ends_with('\n') {
        out.push('\n');
    }
    out.push_str(&row);
    out.push_str(&text[end..]);
    std::fs::write(protocol, out).map_err(io)?;
    Ok(reads + 1)
}

/// Puts a line under the title of a report's Markdown file: the sealed set it read (its sensor
/// builds and scan seed), and how many times that set has been read.
pub fn stamp(md: &Path, set: &str, reads: usize, sensors: &[u64], seed: u64) -> Result<()> {
    let io = |source| Error::Io { path: md.to_path_buf(), source };
    let text = std::fs::read_to_string(md).map_err(io)?;
    let (title, rest) = text.split_once('\n').unwrap_or((&text, ""));
    let times = if reads == 1 { "once".to_string() } else { format!("{reads} times") };
    let line = format!(
        "**SEALED test set** ({set}): the test boards printed anew, sensor builds {sensors:?}, scan seed {seed}; read {times}, each read in docs/protocol.md."
    );
    std::fs::write(md, format!("{title}\n\n{line}\n{rest}")).map_err(io)
}

/// Today's date in UTC, `YYYY-MM-DD`.
fn utc_date() -> String {
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let (y, m, d) = civil_from_days((secs / 86_400) as i64);
    format!("{y:04}-{m:02}-{d:02}")
}

/// The proleptic Gregorian date of a count of days since 1970-01-01 (Howard Hinnant's
/// `civil_from_days`, chrono-compatible date algorithms).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_follow_the_calendar() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(20_794), (2026, 12, 7));
        assert_eq!(civil_from_days(11_016), (2000, 2, 29));
    }

    #[test]
    fn a_read_is_appended_to_the_ledger_and_counted_per_set() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("protocol.md");
        let ledger = format!(
            "# P\n\n{LEDGER_HEADING}\n\n| date | set | command | output |\n| --- | --- | --- | --- |\n\n## After\n"
        );
        std::fs::write(&p, ledger).unwrap();
        let read =
            |set: &str| SealedRead { set: set.into(), command: "braille report chars --final".into(), out: "o".into() };
        assert_eq!(record(&p, &read("Table I")).unwrap(), 1);
        assert_eq!(record(&p, &read("words")).unwrap(), 1);
        assert_eq!(record(&p, &read("Table I")).unwrap(), 2);
        let text = std::fs::read_to_string(&p).unwrap();
        assert_eq!(text.matches("| Table I |").count(), 2);
        // the rows stay in the table, before the next section
        let table_end = text.find("\n\n## After").unwrap();
        assert!(text[..table_end].ends_with("| `braille report chars --final` | o |"), "{text}");
        // a protocol without the ledger is refused, naming what is missing
        std::fs::write(&p, "# P\n").unwrap();
        assert!(record(&p, &read("x")).unwrap_err().to_string().contains("Sealed test sets"));
    }
}
