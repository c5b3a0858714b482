//! `braille plot`: a scan as a heat map (events per pooled pixel, ON and OFF) and as an event
//! raster (pooled column against time), as a PNG.

use anyhow::{Context, Result, bail};
use encoders::Polarity;
use encoders::formats::{self, OpenOptions};
use plotters::prelude::*;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Event file (.aedat4, .csv, .npy).
    file: PathBuf,
    /// PNG to write.
    #[arg(long)]
    out: PathBuf,
    /// Spatial pooling of the pictures (the paper: 4).
    #[arg(long, default_value_t = 4)]
    pool: u16,
    /// Heat-map window: start and length in seconds from the first event [default: the busiest
    /// 0.35 s, one character at 8 mm/s].
    #[arg(long)]
    window_start_s: Option<f64>,
    #[arg(long, default_value_t = 0.35)]
    window_s: f64,
    /// Title; "simulated" belongs in it for simulated data.
    #[arg(long, default_value = "")]
    title: String,
    #[arg(long)]
    force: bool,
}

pub fn run(args: Args) -> Result<()> {
    if args.out.exists() && !args.force {
        bail!("{}: exists; pass --force to overwrite it", args.out.display());
    }
    let (info, events) = formats::read_all(&args.file, &OpenOptions::default())?;
    if events.is_empty() {
        bail!("{}: no events to plot", args.file.display());
    }
    let res = info.resolution.unwrap_or_else(|| {
        let (w, h) = events.iter().fold((0, 0), |(w, h), e| (w.max(e.x), h.max(e.y)));
        encoders::Resolution::new(w + 1, h + 1)
    });
    let pool = args.pool.max(1) as usize;
    let (pw, ph) = ((res.width as usize).div_ceil(pool), (res.height as usize).div_ceil(pool));
    let t0 = events[0].t_us;
    let t1 = events[events.len() - 1].t_us;
    let span_s = ((t1 - t0) as f64 * 1e-6).max(1e-6);

    // Raster: pooled column against time.
    let time_bins = 900usize;
    let mut raster = vec![(0u32, 0u32); time_bins * pw];
    for e in &events {
        let b = (((e.t_us - t0) as f64 * 1e-6 / span_s) * (time_bins - 1) as f64) as usize;
        let cell = &mut raster[b * pw + e.x as usize / pool];
        if e.polarity == Polarity::On { cell.0 += 1 } else { cell.1 += 1 }
    }
    // Heat map over a window: by default the one with the most events.
    let win_us = (args.window_s * 1e6) as i64;
    let start_us = match args.window_start_s {
        Some(s) => t0 + (s * 1e6) as i64,
        None => busiest_window(&events, win_us),
    };
    let mut heat = vec![(0u32, 0u32); pw * ph];
    for e in events.iter().filter(|e| e.t_us >= start_us && e.t_us < start_us + win_us) {
        let cell = &mut heat[(e.y as usize / pool) * pw + e.x as usize / pool];
        if e.polarity == Polarity::On { cell.0 += 1 } else { cell.1 += 1 }
    }

    crate::charts::register_fonts();
    let root = BitMapBackend::new(&args.out, (1200, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let title = if args.title.is_empty() { args.file.display().to_string() } else { args.title.clone() };
    let root = root.titled(&title, ("sans-serif", 22))?;
    let (top, bottom) = root.split_vertically(420);
    let heat_title = format!(
        "heat map: {:.2}-{:.2} s, {}x{} (pooled by {pool}); orange ON, blue OFF",
        (start_us - t0) as f64 * 1e-6,
        (start_us - t0 + win_us) as f64 * 1e-6,
        pw,
        ph
    );
    draw_grid(&top, &heat, pw, ph, (0.0, pw as f64), (0.0, ph as f64), &heat_title, "column", "row", true)?;
    let raster_title = format!("event raster: pooled column against time ({} events)", events.len());
    draw_grid(
        &bottom,
        &raster,
        pw,
        time_bins,
        (0.0, pw as f64),
        (0.0, span_s),
        &raster_title,
        "column",
        "time (s)",
        false,
    )
    .map(|_| ())?;
    root.present().with_context(|| format!("writing {}", args.out.display()))?;
    eprintln!("wrote {}", args.out.display());
    Ok(())
}

fn busiest_window(events: &[encoders::Event], win_us: i64) -> i64 {
    let (mut best, mut best_start, mut j) = (0usize, events[0].t_us, 0usize);
    for i in 0..events.len() {
        while events[j].t_us < events[i].t_us - win_us {
            j += 1;
        }
        if i - j > best {
            best = i - j;
            best_start = events[j].t_us;
        }
    }
    best_start
}

/// Draws counts `(on, off)` of an `nx` by `ny` grid as coloured cells: orange for ON, blue for OFF,
/// brightness by the log count.
#[allow(clippy::too_many_arguments)]
fn draw_grid(
    area: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
    grid: &[(u32, u32)],
    nx: usize,
    ny: usize,
    x_range: (f64, f64),
    y_range: (f64, f64),
    caption: &str,
    x_label: &str,
    y_label: &str,
    flip_y: bool,
) -> Result<()> {
    let y = if flip_y { y_range.1..y_range.0 } else { y_range.0..y_range.1 };
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 16))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(50)
        .build_cartesian_2d(x_range.0..x_range.1, y)?;
    chart.configure_mesh().disable_mesh().x_desc(x_label).y_desc(y_label).draw()?;
    let max = grid.iter().map(|&(a, b)| a + b).max().unwrap_or(1).max(1) as f64;
    let (dx, dy) = ((x_range.1 - x_range.0) / nx as f64, (y_range.1 - y_range.0) / ny as f64);
    chart.draw_series(grid.iter().enumerate().filter(|(_, c)| c.0 + c.1 > 0).map(|(i, &(on, off))| {
        let (ix, iy) = (i % nx, i / nx);
        let level = ((1.0 + (on + off) as f64).ln() / (1.0 + max).ln()).clamp(0.0, 1.0);
        let on_share = on as f64 / (on + off) as f64;
        let v = |share: f64| (255.0 * (1.0 - level * share)) as u8;
        let color = RGBColor(v(1.0 - on_share), v(0.5), v(on_share));
        let x0 = x_range.0 + ix as f64 * dx;
        let y0 = y_range.0 + iy as f64 * dy;
        Rectangle::new([(x0, y0), (x0 + dx, y0 + dy)], color.filled())
    }))?;
    Ok(())
}
