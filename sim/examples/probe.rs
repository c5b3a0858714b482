use sim::*;
use std::time::Instant;
fn main() {
    let board = Board::new(BoardKind::Text("A".into()), BoardGeometry { position_sigma_mm: 0.0, height_sigma_mm: 0.0, ..Default::default() }, 1).unwrap();
    let sensor = Sensor::new(CameraConfig::default().without_noise(), GelConfig::default(), 7).unwrap();
    let mut base = 0.0;
    for d in [0.2, 0.4, 0.6, 0.8, 1.0, 1.2, 1.5] {
        let t = Instant::now();
        let s = simulate(&board, &sensor, &ScanConfig { depth_mm: d, speed_mm_s: 8.0, speed_ripple: 0.0, misalignment_sigma_mm: 0.0, ..Default::default() }).unwrap();
        let n = s.events.len() as f64;
        if d == 0.2 { base = n; }
        let on = s.events.iter().filter(|e| e.polarity == encoders::Polarity::On).count();
        let st = stamp::Stamp::new(&sensor.gel, 0.5, 0.5, d, 18.6/640.0, 1.0);
        println!("d={d} events={n} gain={:.2} on/off={:.2} width_px={} {:.2}s", n/base - 1.0, on as f64/(n - on as f64), st.width_px(0.05), t.elapsed().as_secs_f64());
    }
    for v in [8.0, 16.0, 24.0, 32.0] {
        let s = simulate(&board, &sensor, &ScanConfig { depth_mm: 1.0, speed_mm_s: v, ..Default::default() }).unwrap();
        println!("v={v} events={}", s.events.len());
    }
    let board = Board::new(BoardKind::Sab, BoardGeometry::default(), 1).unwrap();
    let sensor = Sensor::new(CameraConfig::default(), GelConfig::default(), 7).unwrap();
    let t = Instant::now();
    let s = simulate(&board, &sensor, &ScanConfig::default()).unwrap();
    println!("SAB row 0 at 8 mm/s 1.5 mm: {} events, {:.1} s sensor time, {:.2} s wall", s.events.len(), s.truth.timeline.end_s, t.elapsed().as_secs_f64());
}
