//! Each report part as a function that returns data, and its Markdown: the binary writes the
//! files and draws the figures.

pub mod chars;
pub mod chips;
pub mod icub;
pub mod words;
