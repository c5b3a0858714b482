//! What every decoder target checks: whatever the bytes, the decoder ends in events or an error,
//! never a panic, a hang or an allocation beyond its limits; what it hands out is well formed.

use encoders::formats::EventSource;

pub fn drain<S: EventSource>(opened: encoders::Result<S>) {
    if let Ok(mut decoder) = opened {
        while let Ok(Some(chunk)) = decoder.next_chunk() {
            assert!(!chunk.is_empty());
            assert!(chunk.windows(2).all(|w| w[0].t_us <= w[1].t_us));
        }
    }
}
