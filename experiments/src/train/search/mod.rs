//! Training on a tactile dataset nobody has tuned for: a recipe derived from the data
//! ([`DataProfile`], [`derived_recipe`]) and a validation-driven search around it ([`SearchSpace`],
//! [`run_trials`], [`read_logs`], [`winner`]) that can be spread over machines (`--shard I/N`, one log per
//! shard, and `--collect` over the logs).
//!
//! Nothing here knows a dataset: every default is a rule on the training split's durations,
//! event counts and signal steps, documented in docs/training.md. The test split is never read
//! to choose; the search validates on the folder's own validation split, or on a stratified
//! hold-out of the training split.

use crate::error::{Error, Result};
use crate::train::fit::{EvalTest, TactileData, TrainedSnn, train_on};
use crate::train::recipe::{SnnRecipe, TrainerChoice};
use encoders::dataset::{Dataset, DatasetKind, SampleData, Split};
use learn::data::TactileEncoding;
use learn::train::{EpochReport, Observer};
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

mod logs;
mod markdown;
mod profile;
mod run;
mod space;
mod trials;

pub use logs::*;
pub use markdown::*;
pub use profile::*;
pub use run::*;
pub use space::*;
pub use trials::*;

#[cfg(test)]
mod tests {
    use super::*;

    /// An events dataset of 10 training samples lasting 1 s.
    fn events_profile() -> DataProfile {
        DataProfile {
            data: "x".into(),
            kind: "events".into(),
            channels: 3,
            classes: 4,
            train_samples: 10,
            duration_us: 1_000_000,
            events_per_sample: Some(40.0),
            signal_step: None,
            period_us: 0,
        }
    }

    /// A trial as its log would hold it, scored `score`.
    fn logged(trial: usize, point: SearchPoint, recipe: SnnRecipe, score: f64) -> Trial {
        Trial {
            trial,
            point,
            recipe,
            score,
            seed_scores: Vec::new(),
            best_val_accuracy: score,
            best_epoch: 1,
            epochs_run: 1,
            final_train_accuracy: 1.0,
            undone_epochs: 0,
            val_accuracy: vec![score],
            seconds: 1.0,
            shard: "0/1".into(),
            profile: events_profile(),
        }
    }

    #[test]
    fn the_budget_keeps_time_for_the_combination_and_the_final_models() {
        use std::time::Duration;
        let min = |m: f64| Duration::from_secs_f64(60.0 * m);
        let space = SearchSpace::default(); // 3 seeds per trial, 20% held out
        let b = Budget::finishing(min(60.0), &space, 3);
        // the combination, then 3 one-seed final models on 1.25x the samples: 2.25 trials
        assert!((b.reserve_trials - 2.25).abs() < 1e-9, "{}", b.reserve_trials);
        assert!(b.allows(min(61.0), None), "the first trial always starts");
        // 4-minute trials: one more fits until 60 - 4 x 3.25 = 47 minutes
        assert!(b.allows(min(46.9), Some(min(4.0))));
        assert!(!b.allows(min(47.1), Some(min(4.0))));
        // a shard keeps nothing back
        let s = Budget::shard(min(60.0));
        assert!(s.allows(min(55.9), Some(min(4.0))) && !s.allows(min(56.1), Some(min(4.0))));
    }

    #[test]
    fn the_derived_step_alone_draws_the_points_it_drew_before_the_step_was_a_dimension() {
        // raw1350's successive-halving search (2026-12-01): 48 points, 34 of them drawn, logged
        // before the step joined the space
        let log = include_str!("../../../../docs/results/search/raw1350-halving/rung-0.jsonl");
        let logged: Vec<Trial> = log.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
        let d = logged[0].point;
        let base = SnnRecipe {
            recurrent: d.recurrent,
            hidden: vec![d.hidden],
            dropout: d.dropout,
            lr: d.lr,
            init_gain: d.init_gain,
            ..logged[0].recipe.clone()
        };
        let points = SearchSpace { trials: logged.len(), ..SearchSpace::default() }.points(&base);
        assert_eq!(points, logged.iter().map(|t| t.point).collect::<Vec<_>>());
        // and a point at the derived step is written as before, without the field
        let line = serde_json::to_string(&d).unwrap();
        assert!(!line.contains("step_scale"), "{line}");
        assert_eq!(points[0].recipe(&base, &SearchSpace::default()).dt_us, base.dt_us);
    }

    #[test]
    fn a_searched_step_is_a_neighbour_a_draw_and_a_dimension_of_the_combination() {
        let base = SnnRecipe { dt_us: 10_000, ..SnnRecipe::default() };
        let space = SearchSpace { step_scale: vec![1.0, 2.0], trials: 40, ..SearchSpace::default() };
        let pts = space.points(&base);
        let d = SearchPoint::derived(&base);
        // the step's neighbour is the last of the 14 neighbours (3 time constants, recurrence,
        // gain, 2 rates, 2 readouts, 2 sizes, 2 dropouts, then the step), after the dropout's
        let k = pts.iter().position(|p| *p == SearchPoint { step_scale: 2.0, ..d }).unwrap();
        assert_eq!(k, 14);
        assert_ne!(pts[13].dropout, d.dropout);
        let drawn = &pts[k + 1..];
        assert!(drawn.iter().any(|p| p.step_scale == 1.0) && drawn.iter().any(|p| p.step_scale == 2.0));
        let r = pts[k].recipe(&base, &space);
        assert_eq!((r.dt_us, r.tau_mem_us, r.tau_out_us), (20_000, base.tau_mem_us, base.tau_out_us));
        assert!(serde_json::to_string(&pts[k]).unwrap().contains("\"step_scale\":2.0"));
        // the combination takes the step from its best neighbour
        let trial = |k: usize, point: SearchPoint, score: f64| logged(k, point, point.recipe(&base, &space), score);
        let trials = vec![
            trial(0, d, 0.5),
            trial(1, SearchPoint { step_scale: 2.0, ..d }, 0.6),
            trial(2, SearchPoint { lr: 5e-4, ..d }, 0.55),
        ];
        assert_eq!(combination(&trials, &base), Some(SearchPoint { step_scale: 2.0, lr: 5e-4, ..d }));
        // the table gains the step's column only when the steps differ
        assert!(trials_markdown(&trials).contains("| step (ms) |") && trials_markdown(&trials).contains("| 20 |"));
        assert!(!trials_markdown(&trials[..1]).contains("step (ms)"));
        for bad in [0.0, -1.0, f64::NAN] {
            let e = SearchSpace { step_scale: vec![1.0, bad], ..SearchSpace::default() }.check().unwrap_err();
            assert!(e.to_string().contains("step scale"), "{e}");
        }
    }

    #[test]
    fn nice_floor_takes_the_1_2_5_value_below() {
        assert_eq!(nice_floor(13_000.0), 10_000.0);
        assert_eq!(nice_floor(19_999.0), 10_000.0);
        assert_eq!(nice_floor(20_000.0), 20_000.0);
        assert_eq!(nice_floor(7.0), 5.0);
        assert_eq!(nice_floor(0.2), 1.0);
    }

    #[test]
    fn the_derived_recipe_scales_with_the_samples_duration() {
        let p = DataProfile { duration_us: 1_300_000, ..events_profile() };
        let r = derived_recipe(&p);
        assert_eq!(r.dt_us, 10_000);
        assert!((r.tau_mem_us - 108_333.3).abs() < 1.0);
        let slow = derived_recipe(&DataProfile { duration_us: 13_000_000, signal_step: Some(0.5), ..p });
        assert_eq!(slow.dt_us, 100_000);
        assert!((slow.tau_mem_us / r.tau_mem_us - 10.0).abs() < 1e-9);
        assert_eq!(slow.sigma_delta, 0.5);
    }

    #[test]
    fn points_are_distinct_start_at_the_derived_recipe_and_shards_split_them() {
        let base = derived_recipe(&events_profile());
        let space = SearchSpace { trials: 12, ..SearchSpace::default() };
        let pts = space.points(&base);
        assert_eq!(pts.len(), 12);
        assert_eq!(pts[0], SearchPoint::derived(&base));
        assert_eq!(pts, space.points(&base), "the same draw on every shard");
        for (i, p) in pts.iter().enumerate() {
            assert!(!pts[..i].contains(p));
        }
        // the neighbours first: one dimension away from the derived point
        assert_eq!((pts[1].tau_scale, pts[1].hidden), (0.5, 256));
        assert!(pts[1..10].iter().all(|p| p.hidden == 256 && p.dropout == pts[0].dropout));
        // the base's depth is kept, every layer at the point's width
        assert_eq!(pts[1].recipe(&base, &space).hidden, vec![256]);
        let deep = SnnRecipe { hidden: vec![256, 64], ..base.clone() };
        let p = SearchPoint { hidden: 512, ..SearchPoint::derived(&deep) };
        assert_eq!(p.recipe(&deep, &space).hidden, vec![512, 512]);
        let shards: Vec<Shard> = (0..3).map(|i| Shard::parse(&format!("{i}/3")).unwrap()).collect();
        for k in 0..12 {
            assert_eq!(shards.iter().filter(|s| s.runs(k)).count(), 1);
        }
        // the combination: each dimension's best neighbour
        let trial = |k: usize, point: SearchPoint, score: f64| logged(k, point, point.recipe(&base, &space), score);
        let d = pts[0];
        let trials = vec![
            trial(0, d, 0.5),
            trial(1, SearchPoint { tau_scale: 2.0, ..d }, 0.7),
            trial(2, SearchPoint { tau_scale: 4.0, ..d }, 0.6),
            trial(3, SearchPoint { recurrent: false, ..d }, 0.4),
            trial(4, SearchPoint { lr: 2e-3, ..d }, 0.55),
            // two dimensions away: not a neighbour, whatever its score
            trial(5, SearchPoint { hidden: 512, dropout: 0.0, ..d }, 0.9),
        ];
        let c = combination(&trials, &base).unwrap();
        assert_eq!(c, SearchPoint { tau_scale: 2.0, lr: 2e-3, ..d });
        let mut with_c = trials.clone();
        with_c.push(trial(6, c, 0.8));
        assert_eq!(combination(&with_c, &base), None, "already run");
        assert_eq!(winner(&with_c).unwrap().trial, 5);
        // epochs the loss-spike guard undid: counted in the table, kept by the log, absent from
        // the logs of runs without it
        let mut guarded = trial(7, d, 0.5);
        guarded.undone_epochs = 2;
        assert!(trials_markdown(std::slice::from_ref(&guarded)).contains("1 (1; 2 undone by the guard)"));
        assert!(!trials_markdown(&trials).contains("undone"));
        let back: Trial = serde_json::from_str(&serde_json::to_string(&guarded).unwrap()).unwrap();
        assert_eq!(back.undone_epochs, 2);
        assert!(!serde_json::to_string(&trials[0]).unwrap().contains("undone"));
        assert!(Shard::parse("3/3").is_err() && Shard::parse("1").is_err() && Shard::parse("0/0").is_err());
    }

    #[test]
    fn successive_halving_spends_the_budget_of_the_trials_it_replaces() {
        let space = SearchSpace { halving: Some(Halving::DEFAULT), ..SearchSpace::default() };
        let h = Halving::DEFAULT;
        // 16 trials of 60 epochs: 48 points of 7 epochs, 16 of 20, 5 of 60
        let first = h.first_rung_points(space.trials);
        let rungs: Vec<(usize, usize, usize)> = (0..3)
            .map(|r| {
                let rs = h.rung_space(r, &space);
                (h.rung_points(r, first), rs.epochs, rs.score_epochs)
            })
            .collect();
        assert_eq!(rungs, [(48, 7, 1), (16, 20, 2), (5, 60, 5)]);
        let epochs: usize = rungs.iter().map(|(n, e, _)| n * e).sum();
        assert!((epochs as f64 / (16.0 * 60.0) - 1.0).abs() < 0.01, "{epochs}");
        assert_eq!(h.rung_space(2, &space), space, "the last rung is the space itself");
        assert!(SearchSpace { halving: Some(Halving { eta: 1, rungs: 3 }), ..space.clone() }.check().is_err());
        // promotion: the best scores, ties to the earlier point, NaN last
        let t = |trial: usize, score: f64| {
            let recipe = SnnRecipe::preset("default").unwrap();
            logged(trial, SearchPoint::derived(&recipe), recipe, score)
        };
        let ran = [t(0, 0.5), t(1, f64::NAN), t(2, 0.7), t(3, 0.5), t(4, 0.6)];
        assert_eq!(promoted(&ran, 3), [2, 4, 0]);
        assert_eq!(promoted(&ran, 5), [2, 4, 0, 3, 1]);
    }

    #[test]
    fn a_seed_scores_the_epochs_it_kept_not_those_the_guard_undid() {
        let epoch = |epoch, val_accuracy: f64, undone| {
            let mut r = learn::train::EpochReport::without_spikes(
                epoch,
                1e-3,
                (1.0, 1, 1),
                (0.5, val_accuracy),
                std::time::Instant::now(),
            );
            r.undone = undone;
            r
        };
        // epoch 3 undone (no validation): the last two kept are epochs 2 and 4
        let h = [epoch(1, 0.2, false), epoch(2, 0.6, false), epoch(3, f64::NAN, true), epoch(4, 0.8, false)];
        assert_eq!(validated(&h), [0.2, 0.6, 0.8]);
        assert!((seed_score(&h, 2) - 0.7).abs() < 1e-12);
        assert!((seed_score(&h, 10) - 1.6 / 3.0).abs() < 1e-12);
        assert_eq!(seed_score(&h[..2], 1), 0.6);
    }

    #[test]
    fn the_profile_measures_durations_and_the_signal_step_on_the_training_split_only() {
        use encoders::dataset::Sample;
        use encoders::event::{Event, Polarity};
        // analog: 2 channels, 40 frames at 10 ms; channel 0 steps by 3, channel 1 by 0 or 5
        let frames = |n: usize, step: f32| -> Vec<f32> {
            (0..n).flat_map(|k| [3.0 * k as f32, if k % 2 == 0 { 0.0 } else { step }]).collect()
        };
        let sample =
            |id, split, n, step| Sample { id, label: 0, split, data: SampleData::Analog { frames: frames(n, step) } };
        let data = Dataset {
            dir: "sensor_a".into(),
            kind: DatasetKind::Analog,
            classes: vec!["a".into()],
            channels: 2,
            period_us: 10_000,
            samples: vec![
                sample(0, Split::Train, 40, 5.0),
                sample(1, Split::Train, 40, 5.0),
                // the test split is not measured: a longer sample with another step
                sample(2, Split::Test, 400, 50.0),
            ],
        };
        let p = DataProfile::of(&data).unwrap();
        assert_eq!((p.train_samples, p.duration_us, p.kind.as_str()), (2, 400_000, "analog"));
        // steps: 39 of 3 (channel 0) and 39 of 5 (channel 1) per sample: the median is 5
        assert_eq!(p.signal_step, Some(5.0));
        assert_eq!(derived_recipe(&p).sigma_delta, 5.0);
        assert_eq!(derived_recipe(&p).dt_us, 2_000, "400 ms / 100 = 4 ms -> 2 ms");
        // events: the duration is the 95th percentile of the last event's time
        let ev = |id, t_last: i64| Sample {
            id,
            label: 0,
            split: Split::Train,
            data: SampleData::Events(vec![Event::new(0, 0, 0, Polarity::On), Event::new(t_last, 1, 0, Polarity::Off)]),
        };
        let data = Dataset {
            dir: "sensor_b".into(),
            kind: DatasetKind::Events,
            classes: vec!["a".into()],
            channels: 2,
            period_us: 0,
            samples: (0..100).map(|i| ev(i, 1_000 * (i as i64 + 1))).collect(),
        };
        let p = DataProfile::of(&data).unwrap();
        assert_eq!((p.duration_us, p.events_per_sample, p.signal_step), (95_001, Some(2.0), None));
    }
}
