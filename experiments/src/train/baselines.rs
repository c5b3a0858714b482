//! The non-spiking floors of a tactile dataset (`braille baselines --data DIR`): linear models on
//! each sample's events counted in time bins, per input (channel and polarity), with each
//! input's first-event time. Ridge regression on one-hot targets and multinomial logistic
//! regression, their bin count and regularisation chosen on the same validation hold-out as the
//! SNN search, then refitted on the whole training split. The test split is scored only when
//! asked.

use crate::error::{Error, Result};
use crate::train::fit::{EvalTest, TactileData};
use learn::data::SpikeSet;
use rayon::prelude::*;
use serde::Serialize;

/// One floor's result.
#[derive(Debug, Clone, Serialize)]
pub struct Baseline {
    pub model: String,
    /// What was chosen on validation (bins, regularisation).
    pub choice: String,
    pub features: usize,
    /// Weights and biases.
    pub parameters: usize,
    /// Multiply-accumulates per sample (the features' binning not counted).
    pub macs_per_sample: u64,
    pub val_accuracy: f64,
    /// The refitted model on the whole training split.
    pub train_accuracy: f64,
    pub test_accuracy: Option<f64>,
    pub seconds: f64,
}

/// Bin counts tried.
pub const BINS: [usize; 3] = [5, 10, 20];
/// Ridge penalties tried (on standardised features).
pub const RIDGE_ALPHAS: [f64; 8] = [0.001, 0.01, 0.1, 1.0, 10.0, 100.0, 1000.0, 10000.0];
/// Logistic regression's L2 penalties tried.
pub const LOGISTIC_L2: [f64; 3] = [1e-4, 1e-3, 1e-2];

/// Per sample: counts per input in `bins` equal time bins over the set's steps, then each
/// input's first-event time as a share of the sample (1 if it has none).
pub fn features(set: &SpikeSet, bins: usize) -> Vec<Vec<f64>> {
    let n = set.n_inputs;
    set.trains
        .iter()
        .map(|train| {
            let mut f = vec![0.0; n * bins + n];
            for v in &mut f[n * bins..] {
                *v = 1.0;
            }
            let steps = set.steps.max(1);
            for k in 0..train.n_steps().min(steps) {
                let (inputs, counts) = train.step(k);
                let b = (k * bins / steps).min(bins - 1);
                for (&i, &c) in inputs.iter().zip(counts) {
                    let i = i as usize;
                    f[i * bins + b] += c as f64;
                    let first = &mut f[n * bins + i];
                    *first = first.min(k as f64 / steps as f64);
                }
            }
            f
        })
        .collect()
}

/// Standardisation fitted on a training matrix.
struct Scaler {
    mean: Vec<f64>,
    scale: Vec<f64>,
}

impl Scaler {
    fn fit(x: &[Vec<f64>]) -> Scaler {
        let d = x.first().map_or(0, |r| r.len());
        let n = x.len().max(1) as f64;
        let mut mean = vec![0.0; d];
        for r in x {
            for (m, v) in mean.iter_mut().zip(r) {
                *m += v / n;
            }
        }
        let mut var = vec![0.0; d];
        for r in x {
            for ((s, v), m) in var.iter_mut().zip(r).zip(&mean) {
                *s += (v - m) * (v - m) / n;
            }
        }
        Scaler { mean, scale: var.into_iter().map(|v| if v > 1e-12 { 1.0 / v.sqrt() } else { 0.0 }).collect() }
    }

    fn apply(&self, x: &[Vec<f64>]) -> Vec<Vec<f64>> {
        x.iter().map(|r| r.iter().zip(&self.mean).zip(&self.scale).map(|((v, m), s)| (v - m) * s).collect()).collect()
    }
}

/// Solves `a x = b` for a symmetric positive definite `a` (row-major `d x d`) and `c` right-hand
/// sides (`b` row-major `d x c`) by Cholesky factorisation; `None` if `a` is not positive
/// definite.
pub fn cholesky_solve(a: &[f64], b: &[f64], d: usize, c: usize) -> Option<Vec<f64>> {
    let mut l = vec![0.0; d * d];
    for i in 0..d {
        for j in 0..=i {
            let s: f64 = a[i * d + j] - (0..j).map(|k| l[i * d + k] * l[j * d + k]).sum::<f64>();
            if i == j {
                if s <= 0.0 {
                    return None;
                }
                l[i * d + i] = s.sqrt();
            } else {
                l[i * d + j] = s / l[j * d + j];
            }
        }
    }
    let mut x = b.to_vec();
    for col in 0..c {
        for i in 0..d {
            let s: f64 = (0..i).map(|k| l[i * d + k] * x[k * c + col]).sum();
            x[i * c + col] = (x[i * c + col] - s) / l[i * d + i];
        }
        for i in (0..d).rev() {
            let s: f64 = (i + 1..d).map(|k| l[k * d + i] * x[k * c + col]).sum();
            x[i * c + col] = (x[i * c + col] - s) / l[i * d + i];
        }
    }
    Some(x)
}

/// A linear classifier: `scores = x W + b`, `W` row-major `d x classes`.
struct Linear {
    w: Vec<f64>,
    b: Vec<f64>,
    classes: usize,
}

impl Linear {
    fn predict(&self, x: &[f64]) -> usize {
        let c = self.classes;
        let mut best = (0, f64::NEG_INFINITY);
        for k in 0..c {
            let s = self.b[k] + x.iter().enumerate().map(|(i, v)| v * self.w[i * c + k]).sum::<f64>();
            if s > best.1 {
                best = (k, s);
            }
        }
        best.0
    }

    fn accuracy(&self, x: &[Vec<f64>], y: &[usize]) -> f64 {
        let predicted: Vec<usize> = x.par_iter().map(|r| self.predict(r)).collect();
        crate::eval::scoring::accuracy(crate::eval::scoring::hits(predicted, y.iter().copied()), y.len())
    }
}

/// Ridge regression on one-hot targets (features and targets centred, so the intercept is not
/// penalised).
fn ridge(x: &[Vec<f64>], y: &[usize], classes: usize, alpha: f64) -> Result<Linear> {
    let (n, d) = (x.len(), x.first().map_or(0, |r| r.len()));
    let ymean: Vec<f64> =
        (0..classes).map(|k| y.iter().filter(|&&l| l == k).count() as f64 / n.max(1) as f64).collect();
    // x is standardised (mean zero on its training rows), so X^T X and X^T Y need no centring
    let xtx: Vec<f64> = (0..d)
        .into_par_iter()
        .flat_map_iter(|i| (0..d).map(move |j| (i, j)))
        .map(|(i, j)| x.iter().map(|r| r[i] * r[j]).sum::<f64>())
        .collect();
    let mut a = xtx;
    for i in 0..d {
        a[i * d + i] += alpha;
    }
    let mut xty = vec![0.0; d * classes];
    for (r, &l) in x.iter().zip(y) {
        for i in 0..d {
            for k in 0..classes {
                xty[i * classes + k] += r[i] * ((l == k) as u8 as f64 - ymean[k]);
            }
        }
    }
    let w = cholesky_solve(&a, &xty, d, classes).ok_or(Error::Singular { alpha })?;
    Ok(Linear { w, b: ymean, classes })
}

/// Multinomial logistic regression with an L2 penalty, full-batch Adam from zero (seedless:
/// deterministic).
fn logistic(x: &[Vec<f64>], y: &[usize], classes: usize, l2: f64) -> Linear {
    let (n, d, c) = (x.len(), x.first().map_or(0, |r| r.len()), classes);
    let mut m = Linear { w: vec![0.0; d * c], b: vec![0.0; c], classes: c };
    let (mut mw, mut vw, mut mb, mut vb) = (vec![0.0; d * c], vec![0.0; d * c], vec![0.0; c], vec![0.0; c]);
    let (lr, b1, b2, eps) = (0.05, 0.9, 0.999, 1e-8);
    for step in 1..=300 {
        // gradient of the mean cross-entropy, summed over chunks of samples in parallel
        let (gw, gb) = x
            .par_chunks(256)
            .zip(y.par_chunks(256))
            .map(|(xs, ys)| {
                let (mut gw, mut gb) = (vec![0.0; d * c], vec![0.0; c]);
                let mut p = vec![0.0; c];
                for (r, &l) in xs.iter().zip(ys) {
                    for (k, pk) in p.iter_mut().enumerate() {
                        *pk = m.b[k] + r.iter().enumerate().map(|(i, v)| v * m.w[i * c + k]).sum::<f64>();
                    }
                    let top = p.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                    let z: f64 = p
                        .iter_mut()
                        .map(|v| {
                            *v = (*v - top).exp();
                            *v
                        })
                        .sum();
                    for (k, pk) in p.iter_mut().enumerate() {
                        *pk = *pk / z - (k == l) as u8 as f64;
                        gb[k] += *pk;
                    }
                    for (i, v) in r.iter().enumerate() {
                        for k in 0..c {
                            gw[i * c + k] += v * p[k];
                        }
                    }
                }
                (gw, gb)
            })
            .reduce(
                || (vec![0.0; d * c], vec![0.0; c]),
                |(mut a, mut b), (x, y)| {
                    a.iter_mut().zip(x).for_each(|(a, x)| *a += x);
                    b.iter_mut().zip(y).for_each(|(b, y)| *b += y);
                    (a, b)
                },
            );
        let (c1, c2) = (1.0 - b1_pow(b1, step), 1.0 - b1_pow(b2, step));
        for (j, g) in gw.into_iter().enumerate() {
            let g = g / n as f64 + l2 * m.w[j];
            mw[j] = b1 * mw[j] + (1.0 - b1) * g;
            vw[j] = b2 * vw[j] + (1.0 - b2) * g * g;
            m.w[j] -= lr * (mw[j] / c1) / ((vw[j] / c2).sqrt() + eps);
        }
        for (k, g) in gb.into_iter().enumerate() {
            let g = g / n as f64;
            mb[k] = b1 * mb[k] + (1.0 - b1) * g;
            vb[k] = b2 * vb[k] + (1.0 - b2) * g * g;
            m.b[k] -= lr * (mb[k] / c1) / ((vb[k] / c2).sqrt() + eps);
        }
    }
    m
}

fn b1_pow(b: f64, step: usize) -> f64 {
    b.powi(step as i32)
}

/// The floors on `data`: validation on the recipe's hold-out (`val_fraction`, `val_seed` as the
/// SNN search's), then the choice refitted on the whole training split.
pub fn baselines(data: &TactileData, val_fraction: f64, val_seed: u64, eval_test: EvalTest) -> Result<Vec<Baseline>> {
    let (train, val) = data.hold_out(val_fraction, val_seed)?;
    let classes = data.classes.len();
    let prepared = |set_fit: &SpikeSet, others: &[&SpikeSet], bins: usize| {
        let fit = features(set_fit, bins);
        let s = Scaler::fit(&fit);
        (s.apply(&fit), others.iter().map(|o| s.apply(&features(o, bins))).collect::<Vec<_>>())
    };
    let mut out = Vec::new();
    // ridge: bins and alpha on validation
    let started = std::time::Instant::now();
    let mut best = (0usize, 0.0f64, -1.0f64);
    for bins in BINS {
        let (xt, xv) = prepared(&train, &[&val], bins);
        for alpha in RIDGE_ALPHAS {
            let acc = ridge(&xt, &train.labels, classes, alpha)?.accuracy(&xv[0], &val.labels);
            // ties go to the stronger penalty
            if acc > best.2 || (acc == best.2 && bins == best.0) {
                best = (bins, alpha, acc);
            }
        }
    }
    let (bins, alpha, val_acc) = best;
    let (xa, xs) = prepared(&data.train, &[&data.test], bins);
    let m = ridge(&xa, &data.train.labels, classes, alpha)?;
    out.push(Baseline {
        model: "ridge regression".into(),
        choice: format!("{bins} bins, alpha {alpha}"),
        features: xa.first().map_or(0, |r| r.len()),
        parameters: m.w.len() + m.b.len(),
        macs_per_sample: m.w.len() as u64,
        val_accuracy: val_acc,
        train_accuracy: m.accuracy(&xa, &data.train.labels),
        test_accuracy: (eval_test == EvalTest::Yes).then(|| m.accuracy(&xs[0], &data.test.labels)),
        seconds: started.elapsed().as_secs_f64(),
    });
    // logistic regression: on the ridge's bins, L2 on validation
    let started = std::time::Instant::now();
    let (xt, xv) = prepared(&train, &[&val], bins);
    let mut best = (0.0, -1.0);
    for l2 in LOGISTIC_L2 {
        let acc = logistic(&xt, &train.labels, classes, l2).accuracy(&xv[0], &val.labels);
        if acc > best.1 {
            best = (l2, acc);
        }
    }
    let m = logistic(&xa, &data.train.labels, classes, best.0);
    out.push(Baseline {
        model: "logistic regression".into(),
        choice: format!("{bins} bins, L2 {}", best.0),
        features: xa.first().map_or(0, |r| r.len()),
        parameters: m.w.len() + m.b.len(),
        macs_per_sample: m.w.len() as u64,
        val_accuracy: best.1,
        train_accuracy: m.accuracy(&xa, &data.train.labels),
        test_accuracy: (eval_test == EvalTest::Yes).then(|| m.accuracy(&xs[0], &data.test.labels)),
        seconds: started.elapsed().as_secs_f64(),
    });
    Ok(out)
}

/// `braille baselines`' results: the dataset's profile, the floors and the networks.
#[derive(Debug, Clone, Serialize)]
pub struct BaselinesTable {
    pub profile: crate::train::search::DataProfile,
    pub baselines: Vec<Baseline>,
    pub networks: Vec<crate::train::networks::NetworkResult>,
}

impl BaselinesTable {
    /// The table ([`markdown`]) and, with networks, their trials.
    pub fn markdown(&self) -> String {
        let mut md = markdown(&self.baselines, &self.networks);
        if !self.networks.is_empty() {
            md += &format!("\nThe networks' trials:\n\n{}", crate::train::networks::trials_markdown(&self.networks));
        }
        md
    }

    /// `baselines.md` (headed by the command that made it and how validation and test were
    /// used) and `baselines.json` in `dir`; existing files are kept unless `force`.
    pub fn write(
        &self,
        dir: &std::path::Path,
        command: &str,
        validation: &str,
        eval_test: EvalTest,
        force: bool,
    ) -> Result<()> {
        let (md, json) = (dir.join("baselines.md"), dir.join("baselines.json"));
        for p in [&md, &json] {
            if p.exists() && !force {
                return Err(Error::Exists { path: p.clone() });
            }
        }
        std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
        let test = match eval_test {
            EvalTest::Yes => "scored once per final model, after every choice",
            EvalTest::No => "not looked at",
        };
        let header = format!(
            "# Baselines on `{}`\n\nGenerated by `{command}`. Validation: {validation}; the test split {test}.\n\n",
            self.profile.data
        );
        std::fs::write(&md, header + &self.markdown()).map_err(|source| Error::Io { path: md.clone(), source })?;
        crate::write_json(&json, self, force)?;
        Ok(())
    }
}

/// The floors, and the networks if searched, as one Markdown table: what validation chose, its
/// score, the test split (the networks: mean and sample s.d. of the final models over seeds, each
/// seed's score), the size and the work per sample.
pub fn markdown(rows: &[Baseline], networks: &[crate::train::networks::NetworkResult]) -> String {
    let mut s = String::from(
        "| model | chosen on validation | validation | test | parameters | MACs / sample | minutes |\n| --- | --- | --- | --- | --- | --- | --- |\n",
    );
    for b in rows {
        s += &format!(
            "| {} | {} | {:.1}% | {} | {} | {} | {:.1} |\n",
            b.model,
            b.choice,
            100.0 * b.val_accuracy,
            b.test_accuracy.map_or("not looked at".into(), |a| format!("{:.1}%", 100.0 * a)),
            b.parameters,
            b.macs_per_sample,
            b.seconds / 60.0
        );
    }
    for n in networks {
        let Some(t) = n.chosen() else {
            s += &format!("| {} | no trial fitted the budget | | | | | |\n", n.kind.name());
            continue;
        };
        let per: Vec<String> =
            n.finals.iter().filter_map(|f| f.test_accuracy).map(|a| format!("{:.1}", 100.0 * a)).collect();
        let test = match n.test_mean_sd() {
            Some((m, sd)) if per.len() > 1 => {
                format!("**{:.1}%** ({:.1}; seeds {})", 100.0 * m, 100.0 * sd, per.join(" / "))
            }
            Some((m, _)) => format!("{:.1}%", 100.0 * m),
            None => "not looked at".into(),
        };
        let minutes =
            (n.trials.iter().map(|t| t.seconds).sum::<f64>() + n.finals.iter().map(|f| f.seconds).sum::<f64>()) / 60.0;
        s += &format!(
            "| {} ({} final {}) | {} (best epoch {}; {} {}) | {:.1}% | {} | {} | {} | {:.1} |\n",
            n.kind.name(),
            n.finals.len(),
            if n.finals.len() == 1 { "seed" } else { "seeds" },
            t.config.describe(),
            t.best_epoch,
            n.trials.len(),
            if n.trials.len() == 1 { "trial" } else { "trials" },
            100.0 * t.val_accuracy,
            test,
            n.parameters,
            n.macs_per_sample,
            minutes
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_solves_a_known_system_and_refuses_a_singular_one() {
        // a = [[4, 2], [2, 3]], x = [[1, 2], [-1, 0]] -> b = a x
        let a = [4.0, 2.0, 2.0, 3.0];
        let b = [2.0, 8.0, -1.0, 4.0];
        let x = cholesky_solve(&a, &b, 2, 2).unwrap();
        for (got, want) in x.iter().zip([1.0, 2.0, -1.0, 0.0]) {
            assert!((got - want).abs() < 1e-12, "{x:?}");
        }
        assert!(cholesky_solve(&[1.0, 1.0, 1.0, 1.0], &[1.0, 1.0], 2, 1).is_none());
    }

    #[test]
    fn linear_models_separate_separable_classes() {
        // three classes on two informative features, one constant feature (scaled to zero)
        let x: Vec<Vec<f64>> =
            (0..90).map(|i| vec![(i % 3) as f64 + 0.1 * ((i * 7) % 5) as f64, ((i % 3) as f64).powi(2), 1.0]).collect();
        let y: Vec<usize> = (0..90).map(|i| i % 3).collect();
        let s = Scaler::fit(&x);
        let xs = s.apply(&x);
        assert!(ridge(&xs, &y, 3, 0.1).unwrap().accuracy(&xs, &y) > 0.99);
        assert!(logistic(&xs, &y, 3, 1e-4).accuracy(&xs, &y) > 0.99);
        // labels that the features cannot tell apart stay at chance
        let shuffled: Vec<usize> = (0..90).map(|i| (i / 3) % 3).collect();
        assert!(ridge(&xs, &shuffled, 3, 0.1).unwrap().accuracy(&xs, &shuffled) < 0.6);
    }
}
