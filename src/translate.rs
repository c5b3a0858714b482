//! `braille translate`: print to Braille cells and back through a Braille code (the paper's
//! letters, or Unified English Braille grade 1 or 2 by liblouis's tables), or a code against one
//! of liblouis's own test files (`--spec`).

use anyhow::{Context, Result, bail};
use experiments::eval::braille_spec::check_spec;
use pipeline::code::{BrailleCode, parse_cells, unicode};
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The Braille code.
    #[arg(long, value_enum, default_value_t = BrailleCode::UebGrade2)]
    braille: BrailleCode,
    /// Print to translate into cells (Unicode Braille, U+2800 between words); `-` translates
    /// standard input line by line.
    #[arg(long, value_name = "TEXT", conflicts_with_all = ["to_text", "spec"])]
    to_cells: Option<String>,
    /// Cells to translate into print: Unicode Braille (U+2800-U+283F), a space or U+2800 for
    /// the blank; `-` translates standard input line by line.
    #[arg(long, value_name = "CELLS", conflicts_with = "spec")]
    to_text: Option<String>,
    /// One of liblouis's YAML test files (tests/braille-specs/; en-ueb-g1_backward.yaml and
    /// en-ueb-g2_backward.yaml are in liblouis/tests/): run every case through the code
    /// and report the agreement and each case that differs.
    #[arg(long, value_name = "FILE")]
    spec: Option<PathBuf>,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let translator = args.braille.translator()?;
    if let Some(text) = &args.to_cells {
        each_input(text, |line| {
            let cells = translator.to_cells(line)?;
            let braille = unicode(&cells);
            Ok(if args.json {
                let dots: Vec<u8> = cells.iter().map(|c| c.0).collect();
                serde_json::json!({"code": args.braille, "text": line, "cells": braille, "dots_bits": dots}).to_string()
            } else {
                braille
            })
        })?;
    } else if let Some(braille) = &args.to_text {
        each_input(braille, |line| {
            let text = translator.to_text(&parse_cells(line)?);
            Ok(if args.json {
                serde_json::json!({"code": args.braille, "cells": line, "text": text}).to_string()
            } else {
                text
            })
        })?;
    } else if let Some(spec) = &args.spec {
        crate::common::emit(&check_spec(spec, args.braille)?, args.json)?;
    } else {
        bail!("give --to-cells TEXT, --to-text CELLS or --spec FILE");
    }
    Ok(())
}

/// Translate the argument, or with `-` each line of standard input (a line that fails is an
/// error naming its number).
fn each_input(arg: &str, mut translate: impl FnMut(&str) -> Result<String>) -> Result<()> {
    if arg != "-" {
        println!("{}", translate(arg)?);
        return Ok(());
    }
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    for (i, line) in std::io::stdin().lines().enumerate() {
        let line = line?;
        let translated = translate(&line).with_context(|| format!("standard input line {}", i + 1))?;
        writeln!(out, "{translated}")?;
    }
    Ok(())
}
