//! The scoring primitives every crate shares, so that a training loop, a reader, a baseline and a
//! report count a hit the same way: a readout's predicted class ([`argmax`]), and predictions
//! against labels ([`hits`], [`accuracy`]). `experiments::eval::scoring` builds the confusion
//! matrices and word metrics on them.

/// The index of the largest value; the first on ties (as burn's argmax); 0 when empty.
pub fn argmax(v: impl IntoIterator<Item = f32>) -> usize {
    let mut best = (0, f32::NEG_INFINITY);
    for (i, x) in v.into_iter().enumerate() {
        if x > best.1 {
            best = (i, x);
        }
    }
    best.0
}

/// How many predictions equal their label (pairs in order; the shorter side ends the count).
pub fn hits(predicted: impl IntoIterator<Item = usize>, labels: impl IntoIterator<Item = usize>) -> usize {
    predicted.into_iter().zip(labels).filter(|(p, l)| p == l).count()
}

/// `hits` over `n`; 0 when `n` is 0.
pub fn accuracy(hits: usize, n: usize) -> f64 {
    if n == 0 { 0.0 } else { hits as f64 / n as f64 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn argmax_takes_the_first_of_equals_and_hits_count_matching_pairs() {
        assert_eq!(argmax([0.1, 0.7, 0.7, -1.0]), 1);
        assert_eq!(argmax([]), 0);
        assert_eq!(argmax([f32::NAN, 2.0]), 1);
        assert_eq!(hits([1, 2, 3, 4], [1, 0, 3]), 2);
        assert_eq!(accuracy(3, 4), 0.75);
        assert_eq!(accuracy(0, 0), 0.0);
    }
}
