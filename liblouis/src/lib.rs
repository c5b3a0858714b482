//! liblouis, the Braille translator of screen readers and Braille embossers (C, LGPL-2.1 or
//! later), vendored in `c/` and built into this crate by its build script, with the tables it
//! translates Unified English Braille by (`tables/`, same licence). This crate holds the raw C
//! API ([`ffi`]) and the tables' text ([`TABLES`]); the safe translator that uses them is
//! `pipeline::code::Translator`. README.md names the upstream commit.

pub mod ffi {
    //! liblouis's C API (`c/liblouis.h`, built with 32-bit wide characters). Every call into it
    //! is unsafe: liblouis keeps its compiled tables and buffers in globals, so callers hold one
    //! lock around each call.
    use std::os::raw::{c_char, c_int, c_ushort};

    /// liblouis's wide character, as this build configures it (`lou_charSize()` returns 4).
    pub type Widechar = u32;
    /// `lou_setLogLevel`'s level that logs nothing.
    pub const LOG_OFF: c_int = 0x7FFF_FFFF;

    unsafe extern "C" {
        pub fn lou_translateString(
            table_list: *const c_char,
            inbuf: *const Widechar,
            inlen: *mut c_int,
            outbuf: *mut Widechar,
            outlen: *mut c_int,
            typeform: *mut c_ushort,
            spacing: *mut c_char,
            mode: c_int,
        ) -> c_int;
        pub fn lou_backTranslateString(
            table_list: *const c_char,
            inbuf: *const Widechar,
            inlen: *mut c_int,
            outbuf: *mut Widechar,
            outlen: *mut c_int,
            typeform: *mut c_ushort,
            spacing: *mut c_char,
            mode: c_int,
        ) -> c_int;
        pub fn lou_getTable(table_list: *const c_char) -> *const std::ffi::c_void;
        pub fn lou_setLogLevel(level: c_int);
        pub fn lou_charSize() -> c_int;
    }
}

/// The vendored tables, by file name: the contracted and uncontracted UEB tables and every table
/// they include. liblouis reads tables from files, so a user writes these to a folder and names
/// that folder in the table list.
pub const TABLES: [(&str, &str); 10] = [
    ("en-ueb-g2.ctb", include_str!("../tables/en-ueb-g2.ctb")),
    ("en-ueb-g1.ctb", include_str!("../tables/en-ueb-g1.ctb")),
    ("en-ueb-chardefs.uti", include_str!("../tables/en-ueb-chardefs.uti")),
    ("en-ueb-math.ctb", include_str!("../tables/en-ueb-math.ctb")),
    ("braille-patterns.cti", include_str!("../tables/braille-patterns.cti")),
    ("text_nabcc.dis", include_str!("../tables/text_nabcc.dis")),
    ("spaces.uti", include_str!("../tables/spaces.uti")),
    ("latinLetterDef6Dots.uti", include_str!("../tables/latinLetterDef6Dots.uti")),
    ("latinUppercaseComp6.uti", include_str!("../tables/latinUppercaseComp6.uti")),
    ("unicode.dis", include_str!("../tables/unicode.dis")),
];

#[cfg(test)]
mod tests {
    #[test]
    fn the_library_is_built_with_32_bit_characters_and_the_tables_are_there() {
        // SAFETY: a plain query of a build constant.
        assert_eq!(unsafe { super::ffi::lou_charSize() }, 4);
        for (name, text) in super::TABLES {
            assert!(text.len() > 100, "{name} is {} bytes", text.len());
        }
    }
}
