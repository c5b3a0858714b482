//! A robustness sweep on a small board: every level is scored for every model, the Markdown names
//! each level, and the sweep repeats from its seed.

use experiments::eval::chars::CharModel;
use experiments::eval::robustness::{Nuisance, SweepSpec, markdown, sweep};
use sim::{BoardKind, Realism};

/// One nuisance on a text board at 1.5 mm, one scan a row and level, seed 3.
fn spec(base: Realism, nuisance: Nuisance, text: &str, speed_mm_s: f64, world: corpus::world::World) -> SweepSpec {
    SweepSpec {
        base,
        nuisances: vec![nuisance],
        board: BoardKind::Text(text.into()),
        speed_mm_s,
        depth_mm: 1.5,
        trials: 1,
        seed: 3,
        world,
        models_dir: "models".into(),
    }
}

#[test]
fn a_sweep_scores_every_level_and_repeats() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let model = CharModel::load(&root.join("models/clean/resnet-lite-normaug.safetensors")).unwrap();
    let spec = spec(Realism::Clean, Nuisance::Misalignment, "HELP", 16.0, corpus::world::World::test(Realism::Clean));
    let models = vec![("resnet".to_string(), &model)];
    let r = sweep(&spec, &models, &()).unwrap();
    let c = &r.curves[0];
    assert_eq!(c.levels, Nuisance::Misalignment.levels());
    assert_eq!(c.accuracy[0].len(), c.levels.len());
    // one scan of four characters per level: every figure over all printed is a share of 4
    for a in &c.accuracy_all_windows[0] {
        assert_eq!((a * 4.0).round() / 4.0, *a, "{a} is not k/4");
    }
    // Measured with these seeds (the sweep repeats exactly, below): the labeler finds all four
    // windows at every level and the clean ResNet, trained at 8 mm/s, reads two of the four at
    // 16 mm/s whatever the misalignment. A change of the simulator, the labeler or the model
    // that moves a level shows here.
    assert_eq!(c.windows, [4; 5]);
    assert_eq!(c.accuracy_all_windows, [[0.5; 5]], "{c:?}");
    // Over every printed character the accuracy cannot exceed the accuracy over found windows.
    for (a, all) in c.accuracy[0].iter().zip(&c.accuracy_all_windows[0]) {
        assert!(all <= a || c.windows.iter().all(|&w| w == 0), "{all} > {a}");
    }
    let md = markdown(&r);
    assert!(md.contains("SIMULATED") && md.contains("| 0.6 |"), "{md}");
    assert_eq!(sweep(&spec, &models, &()).unwrap().curves[0].accuracy, c.accuracy);
}

#[test]
fn a_words_sweep_reads_every_level_with_every_reader_and_names_each_cliff() {
    use experiments::eval::robustness_words::{CLIFF, markdown_words, sweep_words};
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let files = pipeline::shipped::reader_for(
        &root.join("models/nominal"),
        snn::model_file::Arch::Snn,
        pipeline::code::BrailleCode::Grade1Letters,
    );
    let reader = pipeline::classify::ReaderModels::load(
        &files.segmenter,
        &files.classifier,
        pipeline::classify::SnnRunner::Sliding,
    )
    .unwrap();
    let spec =
        spec(Realism::Nominal, Nuisance::NoiseRate, "CAT", 64.0, corpus::world::World::validation(Realism::Nominal));
    let readers = vec![("snn".to_string(), &reader)];
    let r = sweep_words(&spec, &readers, &()).unwrap();
    let c = &r.curves[0];
    assert_eq!(c.levels, Nuisance::NoiseRate.word_levels());
    assert_eq!((c.words_none[0].len(), c.words_lexicon[0].len()), (c.levels.len(), c.levels.len()));
    // one word a scan: 1 - WER is 1 (read), 0 (missed or misread) or below zero (inserted words)
    for a in c.words_none[0].iter().chain(&c.words_lexicon[0]) {
        assert!(*a <= 1.0 && a.fract() == 0.0, "{a}");
    }
    // the cliff is the first level under the bar, and every level under it is named
    let first_under = c.levels.iter().zip(&c.words_lexicon[0]).find(|(_, a)| **a < CLIFF).map(|(l, _)| *l);
    assert_eq!(c.cliff[0], first_under);
    assert_eq!(c.under[0].first().copied(), first_under);
    let md = markdown_words(&r, "the test");
    assert!(md.contains("SIMULATED") && md.contains("## Cliffs") && md.contains("| 2 |"), "{md}");
    // the sweep repeats from its seed
    assert_eq!(sweep_words(&spec, &readers, &()).unwrap().curves[0].words_lexicon, c.words_lexicon);
}
