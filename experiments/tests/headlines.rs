//! Golden tests of the README's REAL headlines: the search's final models, as shipped, scored
//! again on their test splits on the event-driven engine, against the figures the committed
//! search reports give (each seed to the hundredth of a point, and their mean), and the mean
//! against the README's row.

use experiments::eval::tactile::{SplitChoice, eval_split};
use snn::engine::Mode;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The per-seed test accuracies (percent, as printed) and their mean, from a committed
/// `search.md`'s table of final models.
fn committed(report: &str) -> (Vec<String>, String) {
    let text = std::fs::read_to_string(root().join(report)).unwrap();
    let table = text.split("| seed | final train accuracy | test accuracy (engine) | minutes |").nth(1).unwrap();
    let seeds: Vec<String> = table
        .lines()
        .skip(2)
        .take_while(|l| l.starts_with('|'))
        .map(|l| l.split('|').nth(3).unwrap().trim().trim_end_matches('%').to_string())
        .collect();
    let mean = text.split("Mean test accuracy over 3 seeds: **").nth(1).unwrap().split('%').next().unwrap();
    (seeds, mean.to_string())
}

fn check(set: &str, run: &str) {
    let (seeds, mean) = committed(&format!("docs/results/search/{run}/search.md"));
    assert_eq!(seeds.len(), 3, "{run}: {seeds:?}");
    let mut sum = 0.0;
    for (k, figure) in seeds.iter().enumerate() {
        let file = if k == 0 { format!("{run}.safetensors") } else { format!("{run}.seed{}.safetensors", k + 1) };
        let model = root().join("models/search").join(file);
        let (e, _) =
            eval_split(&model, &root().join("data/icub_braille").join(set), SplitChoice::Test, Mode::Stepped).unwrap();
        let pct = 100.0 * e.accuracy;
        assert_eq!(&format!("{pct:.2}"), figure, "{}: seed {}", model.display(), k + 1);
        sum += pct;
    }
    let recomputed = format!("{:.2}", sum / 3.0);
    assert_eq!(recomputed, mean, "{run}: the mean of the seeds");
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    assert!(readme.contains(&format!("{mean}%")), "the README quotes {run}'s mean {mean}%");
}

#[test]
fn raw1350s_headline_is_the_mean_of_its_three_shipped_seeds() {
    check("raw1350", "raw1350-warmup");
}

#[test]
fn th10s_headline_is_the_mean_of_its_three_shipped_seeds() {
    check("th10", "th10-warmup");
}
