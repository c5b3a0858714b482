//! Throughput of the event-file CSV decoder beside bare `csv`-crate reading of the same file (no
//! checks of order or range, no events built): the decoder's overhead over the crate.
use encoders::formats::{EventSource, OpenOptions, csv::Decoder};
use std::io::Write;
use std::time::Instant;

fn main() {
    let n: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(5_000_000);
    let path = std::env::temp_dir().join("csv_decode_compare.csv");
    {
        let mut f = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        writeln!(f, "# resolution: 640x480\nt_us,x,y,p").unwrap();
        for i in 0..n {
            writeln!(f, "{},{},{},{}", i * 3, (i * 7) % 640, (i * 13) % 480, i % 2).unwrap();
        }
    }
    for round in 0..3 {
        let t = Instant::now();
        let mut d = Decoder::open(&path, &OpenOptions::default()).unwrap();
        let mut count = 0usize;
        let mut sum = 0i64;
        while let Some(c) = d.next_chunk().unwrap() {
            count += c.len();
            sum += c.iter().map(|e| e.t_us + e.x as i64).sum::<i64>();
        }
        let ours = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let mut r = csv::ReaderBuilder::new().comment(Some(b'#')).has_headers(true).from_path(&path).unwrap();
        let mut rec = csv::ByteRecord::new();
        let (mut count2, mut sum2) = (0usize, 0i64);
        let p = |b: &[u8]| -> i64 { b.iter().fold(0i64, |v, c| v * 10 + (c - b'0') as i64) };
        while r.read_byte_record(&mut rec).unwrap() {
            let (t_us, x, _y, _p) = (p(&rec[0]), p(&rec[1]), p(&rec[2]), &rec[3]);
            let _pos = rec.position().map(|q| q.line());
            count2 += 1;
            sum2 += t_us + x;
        }
        let theirs = t.elapsed().as_secs_f64();
        assert_eq!((count, sum), (count2, sum2));
        println!(
            "round {round}: {n} events: ours {:.1} Mev/s, csv crate {:.1} Mev/s (ratio {:.2})",
            n as f64 / ours / 1e6,
            n as f64 / theirs / 1e6,
            theirs / ours
        );
    }
}
