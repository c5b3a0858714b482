//! Braille codes: how printed text becomes six-dot cells, and cells become text again.
//!
//! Three codes: the paper's 26 letters and the space ([`BrailleCode::Grade1Letters`]), and
//! Unified English Braille uncontracted ([`BrailleCode::UebGrade1`]) and contracted
//! ([`BrailleCode::UebGrade2`]), translated both ways by liblouis itself (C, LGPL-2.1+, the
//! `liblouis` crate builds it from source) with its own UEB tables (`en-ueb-g1.ctb`,
//! `en-ueb-g2.ctb` and their includes, [`liblouis::TABLES`]). This module is the safe translator
//! over liblouis's C API. Why
//! liblouis and not the pure-Rust `louis-rs` (it misreads 3.3% of the 2,000 most frequent words
//! in contracted Braille): docs/braille.md.
//!
//! Cells are written as Unicode Braille (U+2800-U+283F); the blank cell, U+2800, and a space are
//! the same thing, the gap between words.

use crate::{Error, Result};
use encoders::braille::{Cell, cell_of, letter_of};
use liblouis::{TABLES, ffi};
use std::sync::OnceLock;

/// A Braille code: the rules from print to cells and back.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum BrailleCode {
    /// The paper's: the 26 letters (either case, read as capitals) and the space, one cell each.
    #[cfg_attr(feature = "clap", value(name = "grade1-letters"))]
    Grade1Letters,
    /// Unified English Braille, uncontracted: capitals, digits, punctuation, indicators.
    #[cfg_attr(feature = "clap", value(name = "ueb-g1"))]
    #[serde(rename = "ueb-g1")]
    UebGrade1,
    /// Unified English Braille, contracted (Grade 2): as [`Self::UebGrade1`], with the
    /// contractions of published English text.
    #[cfg_attr(feature = "clap", value(name = "ueb-g2"))]
    #[serde(rename = "ueb-g2")]
    UebGrade2,
}

impl BrailleCode {
    /// The name on the command line and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            BrailleCode::Grade1Letters => "grade1-letters",
            BrailleCode::UebGrade1 => "ueb-g1",
            BrailleCode::UebGrade2 => "ueb-g2",
        }
    }

    /// The liblouis table the code is translated by, if any.
    pub fn liblouis_table(self) -> Option<&'static str> {
        match self {
            BrailleCode::Grade1Letters => None,
            BrailleCode::UebGrade1 => Some("en-ueb-g1.ctb"),
            BrailleCode::UebGrade2 => Some("en-ueb-g2.ctb"),
        }
    }

    /// The code's translator, made once per process and shared.
    pub fn translator(self) -> Result<&'static Translator> {
        static G1L: OnceLock<Translator> = OnceLock::new();
        static G1: OnceLock<Translator> = OnceLock::new();
        static G2: OnceLock<Translator> = OnceLock::new();
        let cell = match self {
            BrailleCode::Grade1Letters => &G1L,
            BrailleCode::UebGrade1 => &G1,
            BrailleCode::UebGrade2 => &G2,
        };
        if let Some(t) = cell.get() {
            return Ok(t);
        }
        let t = Translator::new(self)?;
        Ok(cell.get_or_init(|| t))
    }
}

impl std::fmt::Display for BrailleCode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The folder the vendored tables are written to (liblouis reads tables from files): once per
/// machine and table version, in a folder of the system's temporary folder named by the tables'
/// hash.
fn table_dir() -> Result<&'static std::path::Path> {
    static DIR: OnceLock<std::path::PathBuf> = OnceLock::new();
    if let Some(d) = DIR.get() {
        return Ok(d);
    }
    // FNV-1a over names and contents: a new table version gets a new folder.
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for (name, text) in TABLES {
        for b in name.bytes().chain(text.bytes()) {
            hash = (hash ^ u64::from(b)).wrapping_mul(0x100_0000_01b3);
        }
    }
    let dir = std::env::temp_dir().join(format!("braille-liblouis-{hash:016x}"));
    let io = |path: &std::path::Path, source| Error::Io { path: path.to_path_buf(), source };
    std::fs::create_dir_all(&dir).map_err(|e| io(&dir, e))?;
    for (name, text) in TABLES {
        let path = dir.join(name);
        if std::fs::read_to_string(&path).ok().as_deref() == Some(text) {
            continue;
        }
        // Written beside and renamed, so a concurrent reader never sees half a table.
        let partial = dir.join(format!("{name}.{}.partial", std::process::id()));
        std::fs::write(&partial, text).map_err(|e| io(&partial, e))?;
        std::fs::rename(&partial, &path).map_err(|e| io(&path, e))?;
    }
    Ok(DIR.get_or_init(|| dir))
}

/// liblouis keeps its compiled tables and buffers in globals: one call at a time.
static LIBLOUIS: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// A code's translation both ways. Built once per code ([`BrailleCode::translator`]) and shared
/// by every stream: translation keeps no state between calls.
#[derive(Debug)]
pub struct Translator {
    code: BrailleCode,
    /// liblouis's table list: the Unicode Braille display table, then the code's table.
    tables: Option<std::ffi::CString>,
}

#[derive(Clone, Copy)]
enum Way {
    Forward,
    Backward,
}

impl Translator {
    /// Compile the code's tables, which liblouis keeps for the process
    /// ([`BrailleCode::translator`] shares one translator per code).
    pub fn new(code: BrailleCode) -> Result<Self> {
        let tables = match code.liblouis_table() {
            None => None,
            Some(table) => {
                let dir = table_dir()?;
                let list = format!("{},{}", dir.join("unicode.dis").display(), dir.join(table).display());
                let list = std::ffi::CString::new(list).map_err(|_| Error::BrailleTable {
                    table: table.to_string(),
                    what: format!("the folder {} holds a NUL byte", dir.display()),
                })?;
                let _guard = LIBLOUIS.lock().unwrap_or_else(|e| e.into_inner());
                // SAFETY: plain calls into liblouis with a NUL-terminated table list, under the lock.
                let compiled = unsafe {
                    if ffi::lou_charSize() != 4 {
                        return Err(Error::BrailleTable {
                            table: table.to_string(),
                            what: "liblouis was built with 16-bit characters".into(),
                        });
                    }
                    ffi::lou_setLogLevel(ffi::LOG_OFF);
                    !ffi::lou_getTable(list.as_ptr()).is_null()
                };
                if !compiled {
                    return Err(Error::BrailleTable {
                        table: table.to_string(),
                        what: format!("liblouis could not compile {}", list.to_string_lossy()),
                    });
                }
                Some(list)
            }
        };
        Ok(Translator { code, tables })
    }

    /// One call into liblouis, the output buffer grown until the whole input is translated.
    fn liblouis(&self, tables: &std::ffi::CStr, way: Way, input: &str) -> Result<String> {
        let inbuf: Vec<ffi::Widechar> = input.chars().map(|c| c as u32).collect();
        if inbuf.is_empty() {
            return Ok(String::new());
        }
        let mut capacity = inbuf.len() * 4 + 64;
        loop {
            let mut outbuf = vec![0 as ffi::Widechar; capacity];
            let mut inlen = inbuf.len() as i32;
            let mut outlen = capacity as i32;
            // Reading back, liblouis takes emphasis indicators (italic, bold, underline) as
            // emphasis only when it is given a typeform buffer to write it to; without one they
            // come out as print (`\46/`). The emphasis itself is not kept.
            let mut typeform = match way {
                Way::Forward => Vec::new(),
                Way::Backward => vec![0 as std::os::raw::c_ushort; capacity],
            };
            let typeform_ptr = if typeform.is_empty() { std::ptr::null_mut() } else { typeform.as_mut_ptr() };
            let _guard = LIBLOUIS.lock().unwrap_or_else(|e| e.into_inner());
            // SAFETY: `inlen` is `inbuf`'s length, `outlen` `outbuf`'s and the typeform
            // buffer's (when there is one); no spacing.
            let ok = unsafe {
                let f = match way {
                    Way::Forward => ffi::lou_translateString,
                    Way::Backward => ffi::lou_backTranslateString,
                };
                f(
                    tables.as_ptr(),
                    inbuf.as_ptr(),
                    &mut inlen,
                    outbuf.as_mut_ptr(),
                    &mut outlen,
                    typeform_ptr,
                    std::ptr::null_mut(),
                    0,
                )
            };
            if ok == 0 {
                return Err(Error::BrailleTable {
                    table: self.code.liblouis_table().unwrap_or_default().to_string(),
                    what: format!("liblouis could not translate {input:?}"),
                });
            }
            if (inlen as usize) < inbuf.len() && capacity < inbuf.len() * 64 + 1024 {
                capacity *= 4;
                continue;
            }
            outbuf.truncate(outlen.max(0) as usize);
            return Ok(outbuf.into_iter().filter_map(char::from_u32).collect());
        }
    }

    pub fn code(&self) -> BrailleCode {
        self.code
    }

    /// Print to cells, the blank cell between words. A character the code cannot write is an
    /// error naming it and its place.
    pub fn to_cells(&self, text: &str) -> Result<Vec<Cell>> {
        let untranslatable = |index: usize, character: char| Error::Untranslatable {
            code: self.code,
            text: text.to_string(),
            index,
            character,
        };
        match &self.tables {
            None => text.chars().enumerate().map(|(i, c)| cell_of(c).ok_or_else(|| untranslatable(i, c))).collect(),
            Some(tables) => {
                let braille = self.liblouis(tables, Way::Forward, text)?;
                let cells: Option<Vec<Cell>> = braille.chars().map(cell_of_unicode).collect();
                if let Some(cells) = cells {
                    return Ok(cells);
                }
                // liblouis writes a character its table lacks as an escape in eight-dot cells
                // (`☺` as `⠄⡳⠭⠆⠖⠒⠁⠄`), which a six-dot board cannot print: the first character
                // whose cells alone are not all six-dot is named.
                for (index, character) in text.chars().enumerate() {
                    let alone = self.liblouis(tables, Way::Forward, &character.to_string())?;
                    if alone.chars().any(|c| cell_of_unicode(c).is_none()) {
                        return Err(untranslatable(index, character));
                    }
                }
                Err(Error::BrailleTable {
                    table: self.code.liblouis_table().unwrap_or_default().to_string(),
                    what: format!("the cells of {text:?} are not all six-dot: {braille:?}"),
                })
            }
        }
    }

    /// Cells to print. UEB's indicators are resolved (capitals, digits, contractions); a
    /// sequence the code gives no meaning is written as liblouis writes it (e.g. `\456/` for a
    /// lone dots-456 cell). With the paper's letters, a cell that is no letter reads `?`.
    pub fn to_text(&self, cells: &[Cell]) -> String {
        match &self.tables {
            None => cells.iter().map(|&c| if c == Cell::EMPTY { ' ' } else { letter_of(c).unwrap_or('?') }).collect(),
            Some(tables) => {
                let braille = unicode(cells);
                // The tables compiled when the translator was made: a failure here would be
                // liblouis's own, and the cells read as nothing rather than stop a stream.
                self.liblouis(tables, Way::Backward, &braille).unwrap_or_default()
            }
        }
    }
}

/// The cell a Unicode Braille character (U+2800-U+283F) or a space writes; `None` for anything
/// else, eight-dot patterns included.
pub fn cell_of_unicode(c: char) -> Option<Cell> {
    Cell::from_unicode(c).or((c == ' ').then_some(Cell::EMPTY))
}

/// Cells written as Unicode Braille, a space (or U+2800) for the blank. A character that is
/// neither is an error naming it and its place.
pub fn parse_cells(braille: &str) -> Result<Vec<Cell>> {
    braille
        .chars()
        .enumerate()
        .map(|(index, character)| cell_of_unicode(character).ok_or(Error::NotBraille { index, character }))
        .collect()
}

/// Cells as Unicode Braille, U+2800 for the blank.
pub fn unicode(cells: &[Cell]) -> String {
    cells.iter().map(|c| c.unicode()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_papers_letters_translate_one_cell_each_and_refuse_the_rest() {
        let t = BrailleCode::Grade1Letters.translator().unwrap();
        assert_eq!(unicode(&t.to_cells("Ab z").unwrap()), "⠁⠃⠀⠵");
        assert_eq!(t.to_text(&t.to_cells("the cat").unwrap()), "THE CAT");
        match t.to_cells("a1") {
            Err(Error::Untranslatable { index: 1, character: '1', .. }) => {}
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn contracted_ueb_writes_and_reads_uebs_signs() {
        let t = BrailleCode::UebGrade2.translator().unwrap();
        // Whole-word contractions (the, and, children), a capital, digits, punctuation.
        let cases = [
            ("the children and the water", "⠮⠀⠡⠝⠀⠯⠀⠮⠀⠺⠁⠞⠻"),
            ("Hello, World! 123.", "⠠⠓⠑⠇⠇⠕⠂⠀⠠⠸⠺⠖⠀⠼⠁⠃⠉⠲"),
            ("knowledge", "⠅"),
        ];
        for (text, braille) in cases {
            let cells = t.to_cells(text).unwrap();
            assert_eq!(unicode(&cells), braille, "{text}");
            assert_eq!(t.to_text(&cells), text, "{braille}");
        }
        assert_eq!(t.to_text(&parse_cells("⠹").unwrap()), "this");
    }

    #[test]
    fn uncontracted_ueb_spells_every_letter() {
        let t = BrailleCode::UebGrade1.translator().unwrap();
        let cells = t.to_cells("the Children").unwrap();
        assert_eq!(unicode(&cells), "⠞⠓⠑⠀⠠⠉⠓⠊⠇⠙⠗⠑⠝");
        assert_eq!(t.to_text(&cells), "the Children");
    }

    #[test]
    fn a_character_ueb_cannot_write_is_named() {
        let t = BrailleCode::UebGrade2.translator().unwrap();
        match t.to_cells("ok ☺ no") {
            Err(Error::Untranslatable { index: 3, character: '☺', .. }) => {}
            other => panic!("{other:?}"),
        }
        // Letters beyond ASCII are UEB's own signs.
        assert_eq!(unicode(&t.to_cells("é").unwrap()), "⠘⠌⠑");
    }

    #[test]
    fn braille_text_parses_to_cells_and_refuses_print() {
        assert_eq!(parse_cells("⠁ ⠀⠿").unwrap(), vec![Cell(1), Cell::EMPTY, Cell::EMPTY, Cell(0b11_1111)]);
        match parse_cells("⠁a") {
            Err(Error::NotBraille { index: 1, character: 'a' }) => {}
            other => panic!("{other:?}"),
        }
        // Eight-dot patterns are not six-dot cells.
        assert!(parse_cells("\u{2840}").is_err());
    }
}
