//! A Braille code against liblouis's own test cases: the YAML files of liblouis's
//! `tests/braille-specs/` (e.g. `en-ueb-g2_backward.yaml`, vendored in `liblouis/tests/`),
//! each case run through [`pipeline::code::Translator`] in its direction and compared exactly.
//!
//! liblouis's YAML repeats its `flags:` and `tests:` keys, so it is read here line by line as
//! liblouis's own harness reads it in order: `flags: {testmode: ...}` sets the direction of the
//! `tests:` that follow (`forward` by default; `bothDirections` makes each case a forward and a
//! backward case), and each case is a flow sequence `[input, expected, options]`. Strings take
//! YAML's quoting and then liblouis's escapes (`\\`, `\xHHHH`, `\s`). What is compared is the
//! text: a case's expected emphasis (`expected_typeform`) is not, as the reader has none, and a
//! case liblouis itself marks as failing (`xfail`) is counted apart.

use crate::{Error, Result};
use pipeline::code::{BrailleCode, Translator, parse_cells, unicode};
use std::path::{Path, PathBuf};

/// Which way a case translates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Direction {
    /// Print to cells.
    Forward,
    /// Cells to print.
    Backward,
}

/// One test case of a spec file.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SpecCase {
    /// The case's line in the file (1-based).
    pub line: usize,
    pub direction: Direction,
    pub input: String,
    pub expected: String,
    /// liblouis's own harness expects liblouis to fail this case (`xfail`).
    pub xfail: bool,
}

/// A case whose translation differs from the expected.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SpecFailure {
    pub line: usize,
    pub direction: Direction,
    pub input: String,
    pub expected: String,
    pub got: String,
    pub xfail: bool,
}

/// Agreement over the cases of one direction.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct Agreement {
    /// Cases liblouis's harness expects to pass.
    pub cases: usize,
    pub agree: usize,
    /// Cases liblouis's harness marks as failing (`xfail`), and how many of them agree here.
    pub xfail_cases: usize,
    pub xfail_agree: usize,
}

impl Agreement {
    /// Agreement over every case, xfail included (what the headline quotes).
    pub fn rate_all(&self) -> f64 {
        (self.agree + self.xfail_agree) as f64 / (self.cases + self.xfail_cases).max(1) as f64
    }
}

/// A spec file run through a code.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SpecReport {
    pub file: PathBuf,
    pub code: BrailleCode,
    pub backward: Agreement,
    pub forward: Agreement,
    /// Block-form cases (`- - input`), which carry emphasis only and are not read here.
    pub skipped_block_cases: usize,
    pub failures: Vec<SpecFailure>,
}

/// What `braille translate --spec` prints: each direction's agreement, then every case that differs.
impl std::fmt::Display for SpecReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "{} through {} (liblouis):", self.file.display(), self.code)?;
        for (name, a) in [("backward (cells to print)", self.backward), ("forward (print to cells)", self.forward)] {
            if a.cases + a.xfail_cases == 0 {
                continue;
            }
            writeln!(
                f,
                "  {name}: {}/{} cases agree ({:.1}%); of the {} that liblouis itself is expected to fail (xfail), {} agree; all: {:.1}%",
                a.agree,
                a.cases,
                100.0 * a.agree as f64 / a.cases.max(1) as f64,
                a.xfail_cases,
                a.xfail_agree,
                100.0 * a.rate_all()
            )?;
        }
        if self.skipped_block_cases > 0 {
            writeln!(f, "  {} block-form case(s) not read (emphasis only)", self.skipped_block_cases)?;
        }
        for c in &self.failures {
            let way = match c.direction {
                Direction::Forward => "forward",
                Direction::Backward => "backward",
            };
            let xfail = if c.xfail { " (xfail)" } else { "" };
            writeln!(f, "  line {} {way}{xfail}: {:?} -> {:?}, expected {:?}", c.line, c.input, c.got, c.expected)?;
        }
        Ok(())
    }
}

/// Read a spec file's cases in order.
pub fn parse_spec(path: &Path) -> Result<Vec<SpecCase>> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::Data { path: path.to_path_buf(), what: format!("cannot read: {e}") })?;
    parse_spec_text(&text)
        .map_err(|(line, what)| Error::Data { path: path.to_path_buf(), what: format!("line {line}: {what}") })
}

/// The number of block-form cases (`  - - input` lines), which [`parse_spec_text`] leaves out.
fn block_cases(text: &str) -> usize {
    text.lines().filter(|l| l.trim_start().starts_with("- - ")).count()
}

#[derive(Clone, Copy)]
enum TestMode {
    Forward,
    Backward,
    Both,
    /// Hyphenation, display and the rest: not translation both ways.
    Other,
}

fn parse_spec_text(text: &str) -> std::result::Result<Vec<SpecCase>, (usize, String)> {
    let mut mode = TestMode::Forward;
    let mut cases = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let trimmed = raw.trim();
        if let Some(flags) = trimmed.strip_prefix("flags:") {
            mode = if flags.contains("bothDirections") {
                TestMode::Both
            } else if flags.contains("testmode: backward") {
                TestMode::Backward
            } else if flags.contains("testmode: forward") || !flags.contains("testmode") {
                TestMode::Forward
            } else {
                TestMode::Other
            };
            continue;
        }
        let Some(item) = trimmed.strip_prefix("- [") else { continue };
        let items = flow_items(item).map_err(|what| (line, what))?;
        if items.len() < 2 {
            return Err((line, format!("a case of {} items (input and expected at least)", items.len())));
        }
        let input = liblouis_unescape(&scalar(&items[0]).map_err(|w| (line, w))?);
        let expected = liblouis_unescape(&scalar(&items[1]).map_err(|w| (line, w))?);
        let options = items.get(2).map(String::as_str).unwrap_or("");
        let xfail_in = |direction: &str| {
            options.contains("xfail")
                && (!options.contains("backward") && !options.contains("forward") || options.contains(direction))
        };
        match mode {
            TestMode::Forward => cases.push(SpecCase {
                line,
                direction: Direction::Forward,
                input,
                expected,
                xfail: xfail_in("forward"),
            }),
            TestMode::Backward => cases.push(SpecCase {
                line,
                direction: Direction::Backward,
                input,
                expected,
                xfail: xfail_in("backward"),
            }),
            TestMode::Both => {
                cases.push(SpecCase {
                    line,
                    direction: Direction::Forward,
                    input: input.clone(),
                    expected: expected.clone(),
                    xfail: xfail_in("forward"),
                });
                cases.push(SpecCase {
                    line,
                    direction: Direction::Backward,
                    input: expected,
                    expected: input,
                    xfail: xfail_in("backward"),
                });
            }
            TestMode::Other => {}
        }
    }
    Ok(cases)
}

/// The top-level items of a flow sequence whose opening `[` is already taken off; the options
/// item (and `key: value` items after it) is kept as raw text.
fn flow_items(s: &str) -> std::result::Result<Vec<String>, String> {
    let mut items = Vec::new();
    let mut current = String::new();
    let mut depth = 0usize;
    let mut quote: Option<char> = None;
    let mut chars = s.chars().peekable();
    while let Some(c) = chars.next() {
        match quote {
            Some(q) => {
                current.push(c);
                if q == '"' && c == '\\' {
                    if let Some(n) = chars.next() {
                        current.push(n);
                    }
                } else if c == q {
                    if q == '\'' && chars.peek() == Some(&'\'') {
                        current.push(chars.next().unwrap_or('\''));
                    } else {
                        quote = None;
                    }
                }
            }
            None => match c {
                '"' | '\'' if current.trim().is_empty() => {
                    quote = Some(c);
                    current.push(c);
                }
                '{' | '[' => {
                    depth += 1;
                    current.push(c);
                }
                '}' if depth > 0 => {
                    depth -= 1;
                    current.push(c);
                }
                ']' if depth > 0 => {
                    depth -= 1;
                    current.push(c);
                }
                ']' => {
                    items.push(current.trim().to_string());
                    return Ok(items);
                }
                ',' if depth == 0 => {
                    items.push(current.trim().to_string());
                    current.clear();
                }
                _ => current.push(c),
            },
        }
    }
    Err("a flow sequence with no closing `]`".into())
}

/// A YAML scalar's value: double-quoted with YAML's escapes, single-quoted with `''`, or plain.
fn scalar(s: &str) -> std::result::Result<String, String> {
    if let Some(inner) = s.strip_prefix('"').and_then(|r| r.strip_suffix('"')) {
        let mut out = String::new();
        let mut chars = inner.chars();
        while let Some(c) = chars.next() {
            if c != '\\' {
                out.push(c);
                continue;
            }
            match chars.next() {
                Some('"') => out.push('"'),
                Some('\\') => out.push('\\'),
                Some('/') => out.push('/'),
                Some('n') => out.push('\n'),
                Some('t') => out.push('\t'),
                Some('0') => out.push('\0'),
                Some(k @ ('x' | 'u' | 'U')) => {
                    let n = match k {
                        'x' => 2,
                        'u' => 4,
                        _ => 8,
                    };
                    let hex: String = chars.by_ref().take(n).collect();
                    let code = u32::from_str_radix(&hex, 16).map_err(|_| format!("bad escape \\{k}{hex} in {s}"))?;
                    out.push(char::from_u32(code).ok_or_else(|| format!("no character {hex} in {s}"))?);
                }
                Some(other) => return Err(format!("unknown escape \\{other} in {s}")),
                None => return Err(format!("a lone backslash ends {s}")),
            }
        }
        Ok(out)
    } else if let Some(inner) = s.strip_prefix('\'').and_then(|r| r.strip_suffix('\'')) {
        Ok(inner.replace("''", "'"))
    } else {
        Ok(s.to_string())
    }
}

/// liblouis's escapes in a test string, applied after YAML's: `\\`, `\xHHHH`, `\yHHHHH`,
/// `\s` (space) and the C control escapes. An unknown escape stays as written.
fn liblouis_unescape(s: &str) -> String {
    let mut out = String::new();
    let chars: Vec<char> = s.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c != '\\' || i + 1 >= chars.len() {
            out.push(c);
            i += 1;
            continue;
        }
        let k = chars[i + 1];
        let hex = |n: usize| -> Option<char> {
            let h: String = chars.get(i + 2..i + 2 + n)?.iter().collect();
            char::from_u32(u32::from_str_radix(&h, 16).ok()?)
        };
        let (value, used) = match k {
            '\\' => (Some('\\'), 2),
            's' => (Some(' '), 2),
            't' => (Some('\t'), 2),
            'n' => (Some('\n'), 2),
            'r' => (Some('\r'), 2),
            'f' => (Some('\x0c'), 2),
            'v' => (Some('\x0b'), 2),
            'e' => (Some('\x1b'), 2),
            'x' | 'X' => (hex(4), 6),
            'y' | 'Y' => (hex(5), 7),
            _ => (None, 1),
        };
        match value {
            Some(v) => {
                out.push(v);
                i += used;
            }
            None => {
                out.push(c);
                i += 1;
            }
        }
    }
    out
}

/// Braille as compared: the blank cell written as a space (the spec files' display,
/// `unicode-without-blank.dis`, shows it so).
fn blank_as_space(s: &str) -> String {
    s.replace('\u{2800}', " ")
}

/// Run every case of a spec file through a code's translator.
pub fn check_spec(path: &Path, code: BrailleCode) -> Result<SpecReport> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::Data { path: path.to_path_buf(), what: format!("cannot read: {e}") })?;
    let cases = parse_spec_text(&text)
        .map_err(|(line, what)| Error::Data { path: path.to_path_buf(), what: format!("line {line}: {what}") })?;
    let translator = code.translator().map_err(|e| Error::Pipeline(Box::new(e)))?;
    let mut report = SpecReport {
        file: path.to_path_buf(),
        code,
        backward: Agreement::default(),
        forward: Agreement::default(),
        skipped_block_cases: block_cases(&text),
        failures: Vec::new(),
    };
    for case in cases {
        let got = translate_case(translator, &case);
        let agree = got.as_deref().ok() == Some(&*expected_form(&case));
        let tally = match case.direction {
            Direction::Forward => &mut report.forward,
            Direction::Backward => &mut report.backward,
        };
        match (case.xfail, agree) {
            (false, a) => {
                tally.cases += 1;
                tally.agree += usize::from(a);
            }
            (true, a) => {
                tally.xfail_cases += 1;
                tally.xfail_agree += usize::from(a);
            }
        }
        if !agree {
            report.failures.push(SpecFailure {
                line: case.line,
                direction: case.direction,
                input: case.input.clone(),
                expected: case.expected.clone(),
                got: got.unwrap_or_else(|e| format!("error: {e}")),
                xfail: case.xfail,
            });
        }
    }
    Ok(report)
}

fn expected_form(case: &SpecCase) -> String {
    match case.direction {
        Direction::Forward => blank_as_space(&case.expected),
        Direction::Backward => case.expected.clone(),
    }
}

fn translate_case(t: &Translator, case: &SpecCase) -> std::result::Result<String, String> {
    match case.direction {
        Direction::Forward => t.to_cells(&case.input).map(|c| blank_as_space(&unicode(&c))).map_err(|e| e.to_string()),
        // A case whose braille holds a pattern beyond six dots cannot be read from a six-dot
        // board; it is scored as a failure.
        Direction::Backward => parse_cells(&case.input).map(|c| t.to_text(&c)).map_err(|e| e.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flow_cases_take_yamls_quotes_liblouis_escapes_and_the_direction() {
        let spec = "flags: {testmode: bothDirections}\ntests:\n  - [\"a!\", ⠁⠖]\n  - ['a\"', ⠁⠴] # quote\n\
                    flags: {testmode: backward}\ntests:\n  - [⠈, \\\\4/]\n  - [\":)\", ⠒⠐⠜, xfail: {backward: true}]\n\
                    \x20 - - ⠨⠂\n    - test\n";
        let cases = parse_spec_text(spec).unwrap();
        assert_eq!(cases.len(), 6);
        assert_eq!(
            (cases[0].direction, cases[0].input.as_str(), cases[0].expected.as_str()),
            (Direction::Forward, "a!", "⠁⠖")
        );
        assert_eq!(
            (cases[1].direction, cases[1].input.as_str(), cases[1].expected.as_str()),
            (Direction::Backward, "⠁⠖", "a!")
        );
        assert_eq!(cases[3].expected, "a\"");
        assert_eq!((cases[4].line, cases[4].expected.as_str()), (7, "\\4/"));
        assert!(cases[5].xfail && cases[5].direction == Direction::Backward);
        assert_eq!(block_cases(spec), 1);
    }

    #[test]
    fn liblouis_escapes() {
        assert_eq!(liblouis_unescape("\\x201f"), "\u{201f}");
        assert_eq!(liblouis_unescape("a\\sb"), "a b");
        assert_eq!(liblouis_unescape("\\\\45/"), "\\45/");
        assert_eq!(liblouis_unescape("\\q"), "\\q");
    }

    #[test]
    fn a_case_with_no_expected_value_names_its_line() {
        assert_eq!(parse_spec_text("tests:\n  - [⠁]\n").unwrap_err().0, 2);
        assert_eq!(parse_spec_text("tests:\n  - [⠁, a\n").unwrap_err().0, 2);
    }
}
