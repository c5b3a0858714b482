//! The streaming reader of one stream, and `read_all` for a whole recording.

use super::config::MAX_HELD_EVENTS;
use super::{Cell, ReadOutput, ReadWord, ReaderConfig, ReaderStats, Speller, Timing, Window, WindowClassifier};
use crate::classify::WindowModel;
use crate::error::{Error, Result};
use crate::grid::{Column, GridMark};
use crate::speed::{SpeedEstimate, SpeedEstimator};
use crate::words::{Detection, FilterOutput, ReadChar, TemporalFilter};
use encoders::braille::Cell as BrailleCell;
use encoders::pooling::PoolMap;
use encoders::{Event, Resolution};
use std::hint::select_unpredictable;

/// The streaming reader of one stream: the shared models, and this stream's state of each.
pub struct StreamReader<'m, S: WindowClassifier = WindowModel, C: WindowClassifier = WindowModel> {
    cfg: ReaderConfig,
    /// The speed being read at (`None` while events are held for the first estimate), and the
    /// bin length it gives.
    speed_mm_s: Option<f64>,
    bin_us: i64,
    /// With [`Timing::Estimated`]: the estimator, its last three estimates (a ring) and their
    /// median, the speed the reader moves to at the next bin boundary.
    pub(super) estimator: Option<SpeedEstimator>,
    recent_mm_s: Vec<f64>,
    recent_head: usize,
    wanted_mm_s: Option<f64>,
    /// Events held before the first estimate.
    held: Vec<Event>,
    /// With `ReaderConfig::denoise`: the background-activity filter every event passes first.
    denoiser: Option<encoders::denoise::BackgroundActivityFilter>,
    frames: usize,
    map: PoolMap,
    cells: usize,
    /// The last `frames` bins, a ring: `ring[head]` is the oldest once full; and the end of each.
    ring: Vec<Vec<Cell>>,
    ring_end_us: Vec<i64>,
    head: usize,
    /// The bin being filled: dense counts (16 bits: half the cache lines of a float, and no cell
    /// of a bin nears 65 535 events; they saturate there) and a sink for masked events after
    /// them, and the cells touched, the first `touched_len` of `touched`, which has room for
    /// every cell and one more: each event writes its cell at `touched_len` and moves it on only
    /// when the cell was empty, so that the scattered events take no branch ([`scatter`]).
    acc: Vec<u16>,
    touched: Vec<u32>,
    touched_len: usize,
    /// Start of the bin being filled (set by the first event).
    bin_start: Option<i64>,
    /// Bins in the ring that hold an event.
    nonempty: usize,
    last_t: i64,
    /// The first event's time (the start of the span the background rate is estimated over).
    first_t: Option<i64>,
    segmenter: &'m S,
    classifier: &'m C,
    segmenter_state: S::State,
    classifier_state: C::State,
    filter: TemporalFilter,
    speller: &'m Speller,
    word: Vec<ReadChar>,
    /// Characters of `word` given out so far (a one-column cell waits for the cell grid).
    word_given: usize,
    /// The cell grid's marks of the current word's characters, and the last two-column marks of
    /// the words before it (at most [`GRID_HISTORY`]).
    word_marks: Vec<GridMark>,
    grid_history: Vec<GridMark>,
    pending: Vec<FilterOutput>,
    pub stats: ReaderStats,
}

/// Two-column marks kept from earlier words for the cell grid (it looks at the nearest two).
const GRID_HISTORY: usize = 4;

/// One event into the bin being filled (`acc`, `2 * cells` counts and a sink after them, and the
/// first `touched_len` of `touched`); whether the event fell outside the sensor or the mask. No
/// branch depends on the event: a masked event (about half of them, at random) adds to the sink,
/// which is never read, and a cell's first event moves `touched_len` on (at most every cell is
/// touched, so it stays inside `touched`, which has room for one more).
#[inline(always)]
fn scatter(
    map: &PoolMap,
    cells: u32,
    acc: &mut [u16],
    touched: &mut [u32],
    touched_len: &mut usize,
    e: &Event,
) -> bool {
    // `select_unpredictable`: LLVM's x86 pass that turns selects in loops into branches did so
    // here once the speed estimator's count left this loop (2026-12-02: the reader ~14% slower)
    let cell = map.cell_or_max(e.x, e.y);
    let masked = cell == u32::MAX;
    let i = select_unpredictable(masked, 2 * cells, (e.polarity.index() as u32 * cells).wrapping_add(cell));
    let a = acc[i as usize];
    touched[*touched_len] = i;
    *touched_len += usize::from((a == 0) & !masked);
    acc[i as usize] = select_unpredictable(a == u16::MAX, a, a.wrapping_add(1));
    masked
}

impl<'m, S: WindowClassifier, C: WindowClassifier> StreamReader<'m, S, C> {
    pub fn new(
        cfg: ReaderConfig,
        resolution: Resolution,
        segmenter: &'m S,
        classifier: &'m C,
        speller: &'m Speller,
    ) -> Result<StreamReader<'m, S, C>> {
        cfg.validate()?;
        let map = PoolMap::new(resolution, cfg.labeler.pool, Some(&cfg.labeler.active_cols))?;
        let cells = map.output.pixels();
        let frames = cfg.labeler.frames;
        let estimator = match cfg.timing {
            Timing::Estimated { .. } => Some(SpeedEstimator::new(cfg.estimator.clone(), resolution)?),
            Timing::Given { .. } | Timing::Paper => None,
        };
        let speed_mm_s = cfg.initial_speed_mm_s();
        let reference = cfg.labeler.reference_speed_mm_s;
        let denoiser = match cfg.denoise {
            Some(settings) => {
                Some(encoders::denoise::BackgroundActivityFilter::new(resolution, settings).map_err(|why| {
                    Error::Setting { name: "denoise", value: why, expected: "a background-activity filter's settings" }
                })?)
            }
            None => None,
        };
        Ok(StreamReader {
            bin_us: cfg.labeler.bin_us(speed_mm_s.unwrap_or(reference)),
            filter: TemporalFilter::new(&cfg.scaled_filter(speed_mm_s.unwrap_or(reference))),
            speed_mm_s,
            estimator,
            recent_mm_s: Vec::with_capacity(3),
            recent_head: 0,
            wanted_mm_s: None,
            held: Vec::new(),
            denoiser,
            frames,
            cells,
            map,
            ring: Vec::with_capacity(frames),
            ring_end_us: Vec::with_capacity(frames),
            head: 0,
            acc: vec![0; 2 * cells + 1],
            touched: vec![0; 2 * cells + 1],
            touched_len: 0,
            bin_start: None,
            nonempty: 0,
            last_t: i64::MIN,
            first_t: None,
            cfg,
            segmenter_state: segmenter.new_state(),
            classifier_state: classifier.new_state(),
            segmenter,
            classifier,
            speller,
            word: Vec::new(),
            word_given: 0,
            word_marks: Vec::new(),
            grid_history: Vec::new(),
            pending: Vec::new(),
            stats: ReaderStats { speed_mm_s, ..ReaderStats::default() },
        })
    }

    /// Bytes the reader holds (its window, the bin being filled, the open segment and word, the
    /// speed estimator's window and any events held for its first estimate): what bounds its
    /// memory on an endless stream.
    pub fn memory_bytes(&self) -> usize {
        let cell = std::mem::size_of::<Cell>();
        self.ring.iter().map(|b| b.capacity() * cell).sum::<usize>()
            + self.ring_end_us.capacity() * 8
            + self.acc.capacity() * 2
            + self.touched.capacity() * 4
            + self.word.iter().map(|c| std::mem::size_of::<ReadChar>() + c.probs.capacity() * 4).sum::<usize>()
            + self.pending.capacity() * std::mem::size_of::<FilterOutput>()
            + (self.word_marks.capacity() + self.grid_history.capacity()) * std::mem::size_of::<GridMark>()
            + self.estimator.as_ref().map_or(0, SpeedEstimator::memory_bytes)
            + self.held.capacity() * std::mem::size_of::<Event>()
            + self.denoiser.as_ref().map_or(0, encoders::denoise::BackgroundActivityFilter::memory_bytes)
    }

    /// The frame (bin) length at the speed being read at.
    pub fn bin_us(&self) -> i64 {
        self.bin_us
    }

    /// The speed being read at (`None` while waiting for the first estimate).
    pub fn speed_mm_s(&self) -> Option<f64> {
        self.speed_mm_s
    }

    /// The estimator's latest estimate (with [`Timing::Estimated`]).
    pub fn last_estimate(&self) -> Option<SpeedEstimate> {
        self.estimator.as_ref().and_then(SpeedEstimator::last)
    }

    /// This stream's state of the segmentation network and of the classifier.
    pub fn states(&self) -> (&S::State, &C::State) {
        (&self.segmenter_state, &self.classifier_state)
    }

    /// The states, once the stream is read.
    pub fn into_states(self) -> (S::State, C::State) {
        (self.segmenter_state, self.classifier_state)
    }

    /// Hands in one event; what it completes is appended to `out`. Events must come in time
    /// order (the `event` index in the error is the count handed in so far).
    pub fn push(&mut self, e: &Event, out: &mut Vec<ReadOutput>) -> Result<()> {
        if e.t_us < self.last_t {
            return Err(Error::OutOfOrder { index: self.stats.events, t_us: e.t_us, previous_t_us: self.last_t });
        }
        self.last_t = e.t_us;
        self.stats.events += 1;
        if let Some(d) = self.denoiser.as_mut() {
            // the span the background rate is estimated over starts at the first filtered event
            self.first_t.get_or_insert(e.t_us);
            if !d.retain(e) {
                self.stats.events_denoised += 1;
                return Ok(());
            }
        }
        if let Some(est) = self.estimator.as_mut() {
            est.push(e);
            if est.due(e.t_us)
                && let Some(x) = est.update(e.t_us)
            {
                self.estimated(x);
            }
        }
        if self.speed_mm_s.is_none() {
            self.held.push(*e);
            let span_us = e.t_us - self.held[0].t_us;
            if self.wanted_mm_s.is_none()
                && (span_us as f64) < self.cfg.hold_ms * 1e3
                && self.held.len() < MAX_HELD_EVENTS
            {
                return Ok(());
            }
            return self.release_held(out);
        }
        self.bin_event(e, out)
    }

    /// Starts reading at the first estimate (or, without one, at the reference speed) and reads
    /// the events held until then.
    fn release_held(&mut self, out: &mut Vec<ReadOutput>) -> Result<()> {
        let speed = self.wanted_mm_s.unwrap_or(self.cfg.labeler.reference_speed_mm_s);
        self.set_speed(speed);
        for e in std::mem::take(&mut self.held) {
            self.bin_event(&e, out)?;
        }
        Ok(())
    }

    /// An estimate: the median of the last three is the speed to read at.
    fn estimated(&mut self, x: SpeedEstimate) {
        self.stats.speed_estimates += 1;
        if self.recent_mm_s.len() < 3 {
            self.recent_mm_s.push(x.speed_mm_s);
        } else {
            self.recent_mm_s[self.recent_head] = x.speed_mm_s;
            self.recent_head = (self.recent_head + 1) % 3;
        }
        let mut r = self.recent_mm_s.clone();
        r.sort_by(f64::total_cmp);
        self.wanted_mm_s = Some(if r.len() == 2 { 0.5 * (r[0] + r[1]) } else { r[r.len() / 2] });
    }

    fn set_speed(&mut self, speed_mm_s: f64) {
        if self.speed_mm_s.is_some() {
            self.stats.speed_changes += 1;
        }
        self.speed_mm_s = Some(speed_mm_s);
        self.stats.speed_mm_s = Some(speed_mm_s);
        self.bin_us = self.cfg.labeler.bin_us(speed_mm_s);
        self.filter.set_durations(&self.cfg.scaled_filter(speed_mm_s));
    }

    /// At a bin boundary: moves to the wanted speed when it is far enough from the current one.
    fn retune(&mut self) {
        if let (Some(now), Some(want)) = (self.speed_mm_s, self.wanted_mm_s)
            && (want / now - 1.0).abs() > self.cfg.retune_fraction
        {
            self.set_speed(want);
        }
    }

    /// One event into the bin being filled.
    fn bin_event(&mut self, e: &Event, out: &mut Vec<ReadOutput>) -> Result<()> {
        let start = *self.bin_start.get_or_insert(e.t_us);
        if e.t_us >= start + self.bin_us {
            self.advance_to(e.t_us, out)?;
        }
        let masked = scatter(&self.map, self.cells as u32, &mut self.acc, &mut self.touched, &mut self.touched_len, e);
        self.stats.events_masked += u64::from(masked);
        Ok(())
    }

    /// Hands in events in time order (a chunk of a stream): [`push`](Self::push) for each, with
    /// the events inside one bin (and before the estimator's next update) accumulated in a tight
    /// loop.
    pub fn push_all(&mut self, events: &[Event], out: &mut Vec<ReadOutput>) -> Result<()> {
        if self.denoiser.is_some() {
            // every event through the filter: no run of a bin binned at once
            return events.iter().try_for_each(|e| self.push(e, out));
        }
        let mut k = 0;
        while k < events.len() {
            self.push(&events[k], out)?;
            k += 1;
            if self.speed_mm_s.is_none() {
                continue;
            }
            let end = self.bin_start.map_or(i64::MIN, |s| s + self.bin_us);
            let due = self.estimator.as_ref().map_or(i64::MAX, |s| s.next_update_us().unwrap_or(i64::MIN));
            let cells = self.cells as u32;
            let (mut last, mut masked, start) = (self.last_t, 0u64, k);
            let (map, acc, touched, mut n_touched) =
                (&self.map, &mut self.acc[..], &mut self.touched[..], self.touched_len);
            while k < events.len() {
                let e = &events[k];
                if e.t_us >= end || e.t_us < last || e.t_us >= due {
                    break;
                }
                last = e.t_us;
                masked += u64::from(scatter(map, cells, acc, touched, &mut n_touched, e));
                k += 1;
            }
            // the run has no update due inside it
            if let Some(s) = self.estimator.as_mut() {
                s.push_run(&events[start..k]);
            }
            self.last_t = last;
            self.touched_len = n_touched;
            self.stats.events += (k - start) as u64;
            self.stats.events_masked += masked;
        }
        Ok(())
    }

    /// Closes every bin that ends at or before `t_us` (each a frame).
    pub fn advance_to(&mut self, t_us: i64, out: &mut Vec<ReadOutput>) -> Result<()> {
        let Some(mut start) = self.bin_start else { return Ok(()) };
        while t_us >= start + self.bin_us {
            self.close_bin(start + self.bin_us, out)?;
            start += self.bin_us;
            self.retune();
            // a long silence: once the window is empty, skip to the bin holding `t_us` (the
            // filter still sees the time pass)
            if self.nonempty == 0 && self.touched_len == 0 && t_us >= start + self.bin_us {
                let skip = (t_us - start) / self.bin_us;
                let target = start + skip * self.bin_us;
                // the frames at which the filter closes a segment or a word, on the frame grid
                while let Some(d) = self.filter.next_deadline().filter(|&d| d <= target) {
                    let frame = start + (d - start + self.bin_us - 1).div_euclid(self.bin_us) * self.bin_us;
                    self.filter.tick(frame.max(d), &mut self.pending);
                }
                self.filter.tick(target, &mut self.pending);
                self.stats.frames += skip as u64;
                self.stats.frames_empty += skip as u64;
                start = target;
                self.drain(out);
            }
        }
        self.bin_start = Some(start);
        Ok(())
    }

    /// The stream's uncorrelated activity per pixel so far, estimated by the background-activity
    /// filter from the events it dropped (`None` without a filter or before time has passed).
    pub fn background_rate_hz_per_pixel(&self) -> Option<f64> {
        let span_us = self.last_t - self.first_t?;
        self.denoiser.as_ref()?.background_rate_hz_per_pixel(span_us)
    }

    /// The stream has ended: events still held are read, the bin being filled closes and the
    /// open character and word are given out.
    pub fn finish(&mut self, out: &mut Vec<ReadOutput>) -> Result<()> {
        self.stats.background_hz_per_pixel = self.background_rate_hz_per_pixel();
        if self.speed_mm_s.is_none() && !self.held.is_empty() {
            self.release_held(out)?;
        }
        if let Some(start) = self.bin_start {
            self.close_bin(start + self.bin_us, out)?;
            self.bin_start = Some(start + self.bin_us);
            self.filter.finish(start + self.bin_us, &mut self.pending);
        }
        self.drain(out);
        if !self.word.is_empty() {
            self.end_word(out);
        }
        Ok(())
    }

    fn close_bin(&mut self, t_end_us: i64, out: &mut Vec<ReadOutput>) -> Result<()> {
        let mut bin = if self.ring.len() == self.frames {
            let old = std::mem::take(&mut self.ring[self.head]);
            self.nonempty -= usize::from(!old.is_empty());
            old
        } else {
            Vec::new()
        };
        bin.clear();
        for &i in &self.touched[..self.touched_len] {
            bin.push(Cell { input: i, count: f32::from(std::mem::take(&mut self.acc[i as usize])) });
        }
        self.touched_len = 0;
        self.nonempty += usize::from(!bin.is_empty());
        if self.ring.len() < self.frames {
            self.ring.push(bin);
            self.ring_end_us.push(t_end_us);
        } else {
            self.ring[self.head] = bin;
            self.ring_end_us[self.head] = t_end_us;
            self.head = (self.head + 1) % self.frames;
        }
        self.stats.frames += 1;
        if self.ring.len() == self.frames {
            self.frame(t_end_us)?;
        }
        self.drain(out);
        Ok(())
    }

    fn frame(&mut self, t_end_us: i64) -> Result<()> {
        if self.nonempty == 0 {
            self.stats.frames_empty += 1;
            self.filter.tick(t_end_us, &mut self.pending);
            return Ok(());
        }
        let (a, b) = self.ring.split_at(self.head);
        let (ea, eb) = self.ring_end_us.split_at(self.head);
        let window = Window {
            t_end_us,
            bin_us: self.bin_us,
            height: self.map.output.height as usize,
            width: self.map.output.width as usize,
            bins: [b, a],
            ends_us: [eb, ea],
        };
        self.stats.segmenter_calls += 1;
        let seg = self.segmenter.classify(&mut self.segmenter_state, &window)?;
        let present = seg.get(1).copied().unwrap_or(0.0);
        if present <= self.cfg.present_threshold {
            self.filter.tick(t_end_us, &mut self.pending);
            return Ok(());
        }
        self.stats.classifier_calls += 1;
        let probs = self.classifier.classify(&mut self.classifier_state, &window)?;
        let (k, &p) = probs
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1).then(b.0.cmp(&a.0)))
            .ok_or(Error::Mismatch { what: "the character classifier gave no probabilities" })?;
        let letter = crate::words::Alphabet::of_classes(probs.len()).symbol(k);
        self.filter.detect(&Detection { t_us: t_end_us, letter, confidence: p }, Some(&probs), &mut self.pending);
        Ok(())
    }

    fn drain(&mut self, out: &mut Vec<ReadOutput>) {
        for o in std::mem::take(&mut self.pending) {
            match o {
                FilterOutput::Char { mut c, new_word } => {
                    c.speed_mm_s = self.speed_mm_s;
                    if new_word && !self.word.is_empty() {
                        self.end_word(out);
                    }
                    self.stats.characters += 1;
                    self.word_marks.push(self.grid_mark(&c));
                    self.word.push(c);
                    self.give_chars(out, false);
                    if self.word.len() >= self.cfg.max_word_chars.max(1) {
                        self.end_word(out);
                    }
                }
                FilterOutput::WordEnd => {
                    if !self.word.is_empty() {
                        self.end_word(out);
                    }
                }
            }
        }
    }

    /// Where character `c` passed, for the cell grid: its segment's middle, and for a cell of
    /// one column the labeler's shift taken off (the classifiers' windows of a lone column end
    /// that much later than a two-column cell's), so that every mark stands at its cell's last
    /// column.
    fn grid_mark(&self, c: &ReadChar) -> GridMark {
        let cell = BrailleCell::from_unicode(c.letter).unwrap_or(BrailleCell::EMPTY);
        let middle_us = (c.t_start_us + c.t_end_us) / 2;
        let shift_us = match (Column::of(cell), c.speed_mm_s) {
            (Some(_), Some(v)) if v > 0.0 => {
                (self.cfg.labeler.single_column_shift_ms * 1e3 * self.cfg.labeler.reference_speed_mm_s / v) as i64
            }
            _ => 0,
        };
        GridMark { t_us: middle_us - shift_us, two_columns: cell.two_columns(), speed_mm_s: c.speed_mm_s }
    }

    /// Gives out the word's characters not yet given: a one-column cell once a character follows
    /// it (or, with `all`, at the word's end), placed on the cell grid first.
    fn give_chars(&mut self, out: &mut Vec<ReadOutput>, all: bool) {
        while self.word_given < self.word.len() {
            let i = self.word_given;
            let cell = BrailleCell::from_unicode(self.word[i].letter);
            let one_column = cell.and_then(Column::of);
            if let (Some(grid), Some(cell), Some(_)) = (&self.cfg.cell_grid, cell, one_column) {
                if i + 1 == self.word.len() && !all {
                    return;
                }
                let n = self.grid_history.len();
                let mut marks = Vec::with_capacity(n + self.word_marks.len());
                marks.extend_from_slice(&self.grid_history);
                marks.extend_from_slice(&self.word_marks);
                if let Some(column) = grid.column_at(&marks, n + i) {
                    let c = &mut self.word[i];
                    c.letter = column.holding(cell).unicode();
                    column.place_probs(&mut c.probs);
                }
            }
            out.push(ReadOutput::Char(self.word[self.word_given].clone()));
            self.word_given += 1;
        }
    }

    fn end_word(&mut self, out: &mut Vec<ReadOutput>) {
        self.give_chars(out, true);
        self.word_given = 0;
        let two = self.word_marks.drain(..).filter(|m| m.two_columns);
        self.grid_history.extend(two);
        let extra = self.grid_history.len().saturating_sub(GRID_HISTORY);
        self.grid_history.drain(..extra);
        let chars = std::mem::take(&mut self.word);
        let raw: String = chars.iter().map(|c| c.letter).collect();
        let text = self.speller.correct(&chars);
        let (lexicon_score_per_char, unreadable) = match self.cfg.abstain_below_score_per_char {
            Some(least) => {
                let score = crate::abstain::score_per_char(&chars);
                (score, score.is_some_and(|s| s < least))
            }
            None => (None, false),
        };
        self.stats.words += 1;
        self.stats.words_unreadable += u64::from(unreadable);
        out.push(ReadOutput::Word(ReadWord { text, raw, chars, lexicon_score_per_char, unreadable }));
    }
}

/// What [`read_all`] gives: the words, the counters and each model's state at the end.
pub struct ReadAll<S, C> {
    pub words: Vec<ReadWord>,
    pub stats: ReaderStats,
    pub segmenter: S,
    pub classifier: C,
}

/// Reads a whole stream of events (in time order): the words.
pub fn read_all<S: WindowClassifier, C: WindowClassifier>(
    events: &[Event],
    cfg: ReaderConfig,
    resolution: Resolution,
    segmenter: &S,
    classifier: &C,
    speller: &Speller,
) -> Result<ReadAll<S::State, C::State>> {
    let mut r = StreamReader::new(cfg, resolution, segmenter, classifier, speller)?;
    let mut out = Vec::new();
    let mut words = Vec::new();
    let mut keep = |out: &mut Vec<ReadOutput>| {
        words.extend(out.drain(..).filter_map(|o| match o {
            ReadOutput::Word(w) => Some(w),
            ReadOutput::Char(_) => None,
        }))
    };
    r.push_all(events, &mut out)?;
    keep(&mut out);
    r.finish(&mut out)?;
    keep(&mut out);
    let stats = r.stats.clone();
    let (segmenter, classifier) = r.into_states();
    Ok(ReadAll { words, stats, segmenter, classifier })
}
