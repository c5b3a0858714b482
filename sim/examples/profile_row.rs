//! Simulates one SAB row repeatedly (for a profiler): `cargo run --release -p sim --example
//! profile_row -- [clean|nominal|harsh] [speed_mm_s] [repeats] [row]`; prints each run's time and a
//! hash of its events.
use sim::{Board, BoardKind, Realism, simulate};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("harsh", |s| s.as_str());
    let realism = *Realism::ALL.iter().find(|r| r.to_string() == name).expect("clean|nominal|harsh");
    let speed: f64 = args.get(2).map_or(Ok(32.0), |s| s.parse()).expect("a speed in mm/s");
    let repeats: usize = args.get(3).map_or(Ok(5), |s| s.parse()).expect("a count");
    let row: usize = args.get(4).map_or(Ok(0), |s| s.parse()).expect("a row of the SAB board");
    let setup = realism.setup();
    let board = Board::new(BoardKind::Sab, setup.geometry.clone(), Board::default_seed(&BoardKind::Sab)).unwrap();
    let sensor = setup.sensor(encoders::Resolution::DVXPLORER, 1).unwrap();
    let scan = setup.scan(speed, 1.5, row, 0);
    for _ in 0..repeats {
        let t = std::time::Instant::now();
        let s = simulate(&board, &sensor, &scan).unwrap();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        // FNV-1a over every event: a change that keeps the stream bit for bit keeps the hash.
        let hash = s.events.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, e| {
            let v = [e.t_us as u64, u64::from(e.x), u64::from(e.y), e.polarity as u64];
            v.iter().fold(h, |h, &x| (h ^ x).wrapping_mul(0x100_0000_01b3))
        });
        println!("{} events, hash {hash:016x}, in {ms:.0} ms", s.events.len());
    }
}
