//! Input shared by the benches: a seeded synthetic DVXplorer stream.

use encoders::{Event, Polarity, Resolution};

/// `n` events on a 640x480 sensor at about 1 M events/s, in time order, clustered in a band of
/// columns as a sliding contact makes them. Deterministic (xorshift, fixed seed).
pub fn dvxplorer_stream(n: usize, seed: u64) -> Vec<Event> {
    let res = Resolution::DVXPLORER;
    let mut s = seed | 1;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    let mut t = 0i64;
    (0..n)
        .map(|i| {
            let r = next();
            t += (r & 1) as i64; // about one event per microsecond
            let band = (i / 20_000) % 8;
            let x = (band * 80 + (r >> 8) as usize % 120).min(res.width as usize - 1) as u16;
            let y = ((r >> 24) % res.height as u64) as u16;
            Event::new(t, x, y, Polarity::from_on((r >> 40) & 1 == 1))
        })
        .collect()
}
