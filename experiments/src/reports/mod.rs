//! Each report part as a function that returns data, its Markdown, and its files and figures
//! ([`figures`]), which the part's own command and `braille report` both write.

pub mod all;
pub mod chars;
pub mod chips;
pub mod envelope;
pub mod figures;
pub mod icub;
pub mod jobs;
pub mod letters;
pub mod tactile;
pub mod ueb;
pub mod words;
