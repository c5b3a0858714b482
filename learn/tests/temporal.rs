//! The conventional networks train on burn, whose flex backend seeds one process-wide generator
//! (initialisation and dropout draw from it): this file is its own test process, and its tests
//! hold one lock, so that a seed repeats its weights.

use encoders::spike_train::SpikeTrain;
use learn::data::SpikeSet;
use learn::temporal::{TemporalConfig, TemporalKind, train};
use learn::train::{Silent, TrainConfig};
use rand::SeedableRng;

static BURN_RNG: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn burn_rng() -> std::sync::MutexGuard<'static, ()> {
    BURN_RNG.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Three classes that differ only in when input 0 fires (early, middle, late) and one that
/// never fires it: counts alone cannot tell the first three apart.
fn timing_set(per_class: usize, seed: u64) -> SpikeSet {
    use rand::Rng;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let steps = 30;
    let (mut trains, mut labels) = (Vec::new(), Vec::new());
    for label in 0..4 {
        for _ in 0..per_class {
            let mut dense = vec![0f32; steps * 2];
            if label < 3 {
                dense[(4 + 10 * label + rng.random_range(0..3)) * 2] = 2.0;
            }
            // noise on input 1 everywhere
            for _ in 0..3 {
                dense[rng.random_range(0..steps) * 2 + 1] += 1.0;
            }
            trains.push(SpikeTrain::from_dense(0, 1000, 2, &dense));
            labels.push(label);
        }
    }
    SpikeSet {
        n_inputs: 2,
        steps,
        dt_us: 1000,
        classes: (0..4).map(|c| c.to_string()).collect(),
        trains,
        labels,
        dropped_events: 0,
    }
}

fn quick(seed: u64) -> TrainConfig {
    TrainConfig { epochs: 25, batch_size: 16, lr: 1e-2, seed, ..TrainConfig::default() }
}

#[test]
fn each_kind_learns_when_an_input_fires_and_a_seed_repeats_its_weights() {
    let _rng = burn_rng();
    let (train_set, val) = (timing_set(24, 1), timing_set(8, 2));
    for kind in [TemporalKind::Gru, TemporalKind::Lstm, TemporalKind::Tcn] {
        let cfg = TemporalConfig { kind, hidden: 16, blocks: 2, kernel: 3, steps_per_bin: 2, dropout: 0.1 };
        let a = train(&cfg, &train_set, Some(&val), &quick(3), &mut Silent);
        assert!(a.best_val_accuracy > 0.9, "{kind:?}: {}", a.best_val_accuracy);
        let b = train(&cfg, &train_set, Some(&val), &quick(3), &mut Silent);
        assert_eq!(a.evaluate(&val).0, b.evaluate(&val).0, "{kind:?}: the same seed, other weights");
    }
}
