//! Guided or unguided frames: a guided render's image frames are traced by the
//! guided kernel or by the unguided one, whichever has lately given the image
//! more for its time (docs/guiding.md, "Guided and unguided frames"). Both are
//! unbiased estimates of the same image. Without a time limit every frame
//! counts as its 64 samples, so the choice, which reads only frames already
//! traced, leaves the image unbiased; in a timed render each kind's frames
//! weigh the inverse of its variance ([`FrameRace::frame_weight`]). The GPU and
//! CPU renderers both follow a [`FrameRace`].

use crate::shared;

/// The kernel that traces a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameKind {
    /// Guided sampling; the recording rows record their targets, and the table
    /// learns as the schedule says.
    Guided,
    /// BSDF and light sampling alone, as with guiding off: nothing recorded.
    Unguided,
}

/// Whether a guided render's image frames may be traced unguided (`--unguided-frames`).
/// Where the command line leaves it out, `rlpt render` takes
/// [`default_unguided_frames`]; the library's default is `Never`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum UnguidedFrames {
    /// Each image frame by the kernel a [`FrameRace`] names.
    Auto,
    /// Every frame guided.
    #[default]
    Never,
}

/// `rlpt render`'s `--unguided-frames` where it is not given: the race where the
/// render has a time budget (`timed`), its scene no Russian roulette and one GPU
/// renders it; every frame guided elsewhere. Without roulette a guided sample
/// gains little and costs more, so at equal time the race gives the frames
/// where guiding does not pay to the unguided kernel; with roulette guided
/// frames win by far and its measuring frames only cost a short render; with
/// `--spp` a seed's image stays the same from run to run, which a race of
/// measured times would not keep (docs/guiding.md, "Where guiding loses").
pub fn default_unguided_frames(timed: bool, roulette: bool, several_gpus: bool) -> UnguidedFrames {
    if timed && !roulette && !several_gpus {
        UnguidedFrames::Auto
    } else {
        UnguidedFrames::Never
    }
}

/// The kind of the frame traced after `traced` frames, `guided_traced` of
/// them guided, of a guided render whose image starts after `learning_frames`,
/// given its race (None: every frame guided). The last of two or more learning
/// frames is unguided: it is among the learning frames, whose mean is at most one
/// frame of the image (`crate::film::Learned`), and measures the
/// unguided kind before the image starts, so that the race need not try it on
/// the image (where, far noisier than the guided frames, it would spoil a short
/// render). The race starts once the guided frames traced reach
/// `RECORD_FIRST_FRAMES` or its head start's share of a timed render is spent
/// ([`FrameRace::head_start_over`]): the first guided frames record every pixel
/// row's targets (or one row in a first stride), learn after each frame and trace
/// a table that knows little, so they cost more and give less than the guided
/// frames after them; judged by them, guiding would lose the race before it had
/// learned anything.
///
/// A timed render's first [`RACE_OPENING`] image frames are unguided where no
/// learning frame was (`FrameRace::opens_unguided`): they time the unguided
/// kind and measure its variance before any guided frame is spent, and where
/// the budget fits fewer than [`RACE_MIN_FRAMES`] of them no frame is guided
/// ([`FrameRace::explores`]).
pub fn frame_kind(race: Option<&FrameRace>, traced: u32, guided_traced: u32, learning_frames: u32) -> FrameKind {
    match race {
        Some(_) if learning_frames >= 2 && traced + 1 == learning_frames => FrameKind::Unguided,
        Some(r)
            if traced >= learning_frames
                && (r.opens_unguided(traced, guided_traced, learning_frames) || !r.explores()) =>
        {
            FrameKind::Unguided
        }
        Some(r) if traced >= learning_frames && r.head_start_over(guided_traced) => r.next(),
        _ => FrameKind::Guided,
    }
}

/// The frames before a guided render's image starts: the `n` learning frames
/// asked for, and where the race may trace unguided frames and `n` > 0, one
/// unguided frame after them ([`frame_kind`]), so that the guided frames keep
/// their learning frames and learned roulette its start.
pub fn frames_before_image(n: u32, unguided_frames: bool) -> u32 {
    if unguided_frames && n > 0 {
        n + 1
    } else {
        n
    }
}

/// Frames of each kind measured before the race chooses by efficiency.
pub const RACE_START_FRAMES: u32 = 1;
/// A timed render's image opens with this many unguided frames: the second
/// measures the unguided kind's variance (the first has no mean before it to
/// measure against), which the guided head start's weights read.
pub const RACE_OPENING: u32 = 2;
/// A kind's frame weighs at most this many times the other's, and at least its
/// inverse ([`FrameRace::frame_weight`]).
pub const RACE_WEIGHT_RANGE: f64 = 256.0;
/// A timed render whose budget fits fewer than this many unguided frames (timed
/// by its first) traces none guided: after the head start's share, the
/// [`RACE_OPENING`] frames and the unguided burst, a guided burst, each frame taken to
/// last at least an unguided one, would not fit [`RACE_EXPLORE_SHARE`] of the
/// time left, so the head start's frames would be all the guided frames there
/// are, spent on a table that could never repay them (about 26.7 frames;
/// docs/guiding.md, "Short renders").
pub const RACE_MIN_FRAMES: f64 =
    (RACE_BURST as f64 / RACE_EXPLORE_SHARE + RACE_OPENING as f64 + RACE_BURST as f64) / (1.0 - RACE_HEAD_START_SHARE);
/// The head start's guided frames, which the race does not weigh, take at most
/// this share of a timed render's budget (but its first frame): a short render's
/// first frames are most of its image, and where guiding does not pay they spoil it.
pub const RACE_HEAD_START_SHARE: f64 = 0.1;
/// A burst of the trailing kind, or the first guided one, is traced only where
/// it takes at most this share of a timed render's time left: near the end a
/// kind that trails has no time left to repay its frames, and unguided frames
/// are the baseline that guiding has to beat.
pub const RACE_EXPLORE_SHARE: f64 = 0.1;
/// The unguided kind's means of variance and time are over its last this many
/// frames, about (a running mean, then a moving one): a frame's variance is an
/// unbiased but heavy-tailed estimate, which short means would mostly underrate.
pub const RACE_WINDOW: u32 = 64;
/// The guided kind's, over fewer: its frames improve as the table learns.
pub const RACE_GUIDED_WINDOW: u32 = 8;
/// The trailing kind's frames come in bursts of this many: a kernel's first
/// frame after the other's runs from cold caches, so only the later frames of a
/// burst time it.
pub const RACE_BURST: u32 = 2;
/// The lead changes hands only where the other kind's inefficiency is below
/// this times the leader's: measurements of near ties do not flip it back and forth.
pub const RACE_HYSTERESIS: f64 = 0.97;
/// The trailing kind traces one frame per this many of its frames' time spent on
/// the leader, times how far it is behind (up to [`RACE_MAX_GAP`]): it keeps
/// being measured, and guided frames keep teaching the table, at a cost that
/// shrinks as the gap grows.
pub const RACE_MIN_GAP: f64 = 16.0;
pub const RACE_MAX_GAP: f64 = 256.0;
/// And at most this share of the image's variance comes from the trailing
/// kind's frames: where its frames are much noisier than the leader's (cheap
/// unguided frames beside a guided leader), fewer of them, so that they do not
/// spoil an image that weighs every frame alike.
pub const RACE_TRAILING_VARIANCE: f64 = 0.05;

/// What the race knows of one kind: its frames and moving means.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct KindRecord {
    pub frames: u32,
    /// Mean relative variance of the frames' mean (`crate::film::frame_variance_term`
    /// summed over the pixels, over the pixels), over the last [`RACE_WINDOW`] frames.
    pub variance: f64,
    /// Mean time of the frames (ms); the guided kind's with the learning
    /// passes' share ([`FrameRace::report_guided`]).
    pub ms: f64,
    /// Frames that timed it, and whether those were cold alone.
    timed: u32,
    cold_only: bool,
}

impl KindRecord {
    /// Takes in a frame; `warm` where the frame before it was of the same kind.
    fn add(&mut self, variance: f64, ms: f64, warm: bool, window: u32) {
        let w = 1.0 / (self.frames + 1).min(window) as f64;
        self.variance += w * (variance - self.variance);
        // Cold frames (the first of a kernel, which may carry its compilation,
        // and the first of a burst) time it only until a warm one has.
        if warm || self.timed == 0 {
            let w_ms = if self.timed == 0 || self.cold_only { 1.0 } else { 1.0 / (self.timed + 1).min(window) as f64 };
            self.ms += w_ms * (ms - self.ms);
            self.cold_only = !warm;
            self.timed += 1;
        }
        self.frames += 1;
    }

    /// Variance times time: the error an image of this kind's frames has after a
    /// given time is proportional to it; smaller is better.
    pub fn inefficiency(&self) -> f64 {
        self.variance * self.ms
    }
}

/// The kind trailing a leader and what its next burst waits for ([`FrameRace::trailing`]).
struct Trailing<'a> {
    lead: &'a KindRecord,
    other: FrameKind,
    /// The leader's time (ms) and frames since the trailing kind's last frame.
    wait_ms: f64,
    wait_frames: f64,
}

/// The choice of kernel frame by frame ([`FrameKind`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameRace {
    pub guided: KindRecord,
    pub unguided: KindRecord,
    /// Time spent on the leading kind since the other's last frame (ms), and its frames.
    since_other_ms: f64,
    since_other_frames: u32,
    /// The kind that led when the last frame was reported.
    lead: FrameKind,
    /// The last frame's kind, and how many frames of it in a row.
    last: Option<FrameKind>,
    run: u32,
    /// Mean time of the table's learning pass (ms), and the passes timed.
    learn_ms: f64,
    learns: u32,
    /// The render's time budget and time left (ms), where it has them
    /// ([`FrameRace::set_time_left`]); the head start's guided frames and their time.
    budget_ms: Option<f64>,
    time_left_ms: Option<f64>,
    head_frames: u32,
    head_ms: f64,
    /// The first unguided frame's time (ms): [`FrameRace::explores`] reads it.
    first_unguided_ms: Option<f64>,
    /// Each kind's image frames' mean relative variance, the head start's
    /// guided frames included, over about their last [`RACE_GUIDED_WINDOW`] and
    /// [`RACE_WINDOW`] frames, and the frames measured: what
    /// [`FrameRace::frame_weight`] reads (guided, unguided).
    weigh_variance: [(f64, u32); 2],
}

impl Default for FrameRace {
    fn default() -> FrameRace {
        FrameRace {
            guided: KindRecord::default(),
            unguided: KindRecord::default(),
            since_other_ms: 0.0,
            since_other_frames: 0,
            lead: FrameKind::Guided,
            last: None,
            run: 0,
            learn_ms: 0.0,
            learns: 0,
            budget_ms: None,
            time_left_ms: None,
            head_frames: 0,
            head_ms: 0.0,
            first_unguided_ms: None,
            weigh_variance: [(0.0, 0); 2],
        }
    }
}

impl FrameRace {
    /// Takes in a timed render's time left (ms), which the renderers pass before
    /// each round; the first is the render's budget.
    pub fn set_time_left(&mut self, ms: f64) {
        self.budget_ms.get_or_insert(ms);
        self.time_left_ms = Some(ms);
    }

    /// Whether the frame after `traced` frames opens a timed render's image
    /// unguided: its first [`RACE_OPENING`] image frames, where no unguided
    /// learning frame came before and no image frame was guided
    /// (`guided_traced` counts the learning frames'; [`frame_kind`]). Without a
    /// time limit the render opens guided, so that a seed's `--spp` image does
    /// not change with its race.
    pub fn opens_unguided(&self, traced: u32, guided_traced: u32, learning_frames: u32) -> bool {
        self.budget_ms.is_some()
            && learning_frames < 2
            && guided_traced == learning_frames
            && traced >= learning_frames
            && traced < learning_frames + RACE_OPENING
    }

    /// What a whole frame of `kind` weighs in a timed render's image
    /// (`crate::film::FrameWeight`): the unguided kind's mean relative variance
    /// over this kind's, within [`RACE_WEIGHT_RANGE`], so that each frame weighs
    /// the inverse of its kind's variance and a kind far noisier than the other
    /// costs the image little more than its time. 1 for an unguided frame, before
    /// both kinds are measured, and without a time limit, whose `--spp` image
    /// weighs every frame alike. The weights read only frames already traced;
    /// docs/guiding.md, "Frame weights", says what that leaves of the bias.
    pub fn frame_weight(&self, kind: FrameKind) -> f32 {
        let [(guided, g), (unguided, u)] = self.weigh_variance;
        if kind == FrameKind::Unguided || self.budget_ms.is_none() || g == 0 || u == 0 {
            return 1.0;
        }
        if guided <= 0.0 {
            return RACE_WEIGHT_RANGE as f32;
        }
        (unguided / guided).clamp(1.0 / RACE_WEIGHT_RANGE, RACE_WEIGHT_RANGE) as f32
    }

    /// Whether the race has a time budget: then its frames weigh by their kind
    /// ([`frame_weight`](Self::frame_weight)).
    pub fn timed(&self) -> bool {
        self.budget_ms.is_some()
    }

    /// Whether the race may trace guided frames: not where a timed render's
    /// budget fits fewer than [`RACE_MIN_FRAMES`] frames of the unguided kind, as
    /// its first frame timed it (always before that frame, and without a time limit).
    pub fn explores(&self) -> bool {
        match (self.budget_ms, self.first_unguided_ms) {
            (Some(budget), Some(ms)) => budget >= RACE_MIN_FRAMES * ms,
            _ => true,
        }
    }

    /// Whether a burst of `kind` fits [`RACE_EXPLORE_SHARE`] of the time left
    /// (always without a time limit). A kind not yet timed is taken to last as
    /// the head start's frames did.
    fn burst_fits(&self, kind: FrameKind) -> bool {
        let Some(left) = self.time_left_ms else { return true };
        let ms = self.frame_ms(kind).or(self.head_frame_ms()).unwrap_or(0.0);
        RACE_BURST as f64 * ms <= RACE_EXPLORE_SHARE * left
    }

    /// Whether the head start is over after `guided_traced` guided frames: they
    /// reached `RECORD_FIRST_FRAMES`, or one more, taken to last their mean, would
    /// take them past [`RACE_HEAD_START_SHARE`] of the budget (the first frame
    /// is always traced: nothing times it before).
    pub fn head_start_over(&self, guided_traced: u32) -> bool {
        self.head_start_left(guided_traced) == 0
    }

    /// The mean time of the head start's frames (ms), None before the first.
    fn head_frame_ms(&self) -> Option<f64> {
        (self.head_frames > 0).then(|| self.head_ms / self.head_frames as f64)
    }

    /// The head start's guided frames left after `guided_traced`: up to
    /// `RECORD_FIRST_FRAMES` in all, and as many as fit what is left of
    /// [`RACE_HEAD_START_SHARE`] of the budget, each taken to last the mean of
    /// those traced (any number before the first). A round of frames traced in
    /// one submission ends with it, so that the race's first frame is its own.
    pub fn head_start_left(&self, guided_traced: u32) -> u32 {
        let by_frames = shared::RECORD_FIRST_FRAMES.saturating_sub(guided_traced);
        let by_time = match (self.budget_ms, self.head_frame_ms()) {
            (Some(b), Some(mean)) => {
                ((RACE_HEAD_START_SHARE * b - self.head_ms) / mean).floor().clamp(0.0, u32::MAX as f64) as u32
            }
            _ => u32::MAX,
        };
        by_frames.min(by_time)
    }

    /// How many image frames of one kind a round traced in one submission may
    /// take after `guided_traced` guided frames: the head start's frames left
    /// ([`head_start_left`](Self::head_start_left)), then [`run_left`](Self::run_left).
    pub fn round_left(&self, guided_traced: u32) -> u32 {
        if !self.explores() {
            return u32::MAX;
        }
        match self.head_start_left(guided_traced) {
            0 => self.run_left(),
            head => head,
        }
    }

    /// Whether the race weighs a frame of `kind` traced after `traced` frames,
    /// `guided_traced` of them guided ([`frame_kind`]): every unguided frame (the
    /// learning frames' one among them) but a render's first, whose variance is
    /// measured against its own mean (no frame before it), which understates it,
    /// and a timed render's opening, measured against a mean of a frame or two,
    /// which overstates it; and the image's guided frames once the head start is over.
    pub fn weighs(&self, kind: FrameKind, traced: u32, guided_traced: u32, learning_frames: u32) -> bool {
        match kind {
            FrameKind::Unguided => traced > 0 && !self.opens_unguided(traced, guided_traced, learning_frames),
            FrameKind::Guided => traced >= learning_frames && self.head_start_over(guided_traced),
        }
    }

    /// Takes in a traced frame as [`weighs`](Self::weighs) says: into its kind's
    /// record ([`report_frame`](Self::report_frame)), or, a guided frame of the
    /// head start, its time (path tracing and learning) into the head start's.
    /// The first unguided frame's time is kept for [`explores`](Self::explores).
    pub fn report_traced(
        &mut self,
        (kind, traced, guided_traced, learning_frames): (FrameKind, u32, u32, u32),
        variance: f64,
        trace_ms: f64,
        learn_ms: Option<f64>,
        period: u32,
    ) {
        if kind == FrameKind::Unguided {
            self.first_unguided_ms.get_or_insert(trace_ms);
        }
        // The weights read every image frame's variance, the head start's too; a
        // render's first frame is measured against its own mean, which understates
        // it. The opening's second is measured against the one frame before it,
        // which doubles its expected deviation.
        let opening = kind == FrameKind::Unguided && self.opens_unguided(traced, guided_traced, learning_frames);
        let (image, slot, window) = match kind {
            FrameKind::Guided => (traced >= learning_frames, 0, RACE_GUIDED_WINDOW),
            FrameKind::Unguided => (traced > 0, 1, RACE_WINDOW),
        };
        if image {
            let v = if opening { variance / 2.0 } else { variance };
            let (mean, n) = &mut self.weigh_variance[slot];
            *n += 1;
            *mean += (v - *mean) / (*n).min(window) as f64;
        }
        if self.weighs(kind, traced, guided_traced, learning_frames) {
            self.report_frame(kind, variance, trace_ms, learn_ms, period);
        } else if kind == FrameKind::Guided {
            self.head_frames += 1;
            self.head_ms += trace_ms + learn_ms.unwrap_or(0.0);
            // The race's first frame after them is cold, of either kind.
            self.last = None;
            self.run = 0;
        }
    }

    /// The kind of the next image frame: the two alternate, unguided first, until
    /// each has [`RACE_START_FRAMES`] (in bursts of [`RACE_BURST`]); then the more efficient, and the other
    /// once the leader has had its gap's worth of time and enough frames to keep
    /// the other's share of the variance below [`RACE_TRAILING_VARIANCE`]. In a
    /// timed render a guided burst before a leader, and the other kind's burst
    /// after, only where it fits [`RACE_EXPLORE_SHARE`] of the time left.
    pub fn next(&self) -> FrameKind {
        let Some(leader) = self.leader() else {
            // Alternating in bursts, unguided first: the head start was guided,
            // and a short render's image is its first frames.
            if let Some(last) = self.last.filter(|_| self.run < RACE_BURST) {
                return last;
            }
            let guided_turn = self.unguided.frames > self.guided.frames;
            return if guided_turn && self.burst_fits(FrameKind::Guided) {
                FrameKind::Guided
            } else {
                FrameKind::Unguided
            };
        };
        let t = self.trailing(leader);
        if self.last == Some(t.other) && self.run < RACE_BURST {
            return t.other;
        }
        let due = self.since_other_ms >= t.wait_ms && self.since_other_frames as f64 >= t.wait_frames;
        if due && self.burst_fits(t.other) {
            t.other
        } else {
            leader
        }
    }

    /// What the kind trailing `leader` waits for before its next burst: the
    /// leader's time, its gap (16 to 256 times, as far as it is behind) times the
    /// burst's; and the leader's frames, enough to keep the trailing kind's share
    /// of the image's variance below [`RACE_TRAILING_VARIANCE`].
    fn trailing(&self, leader: FrameKind) -> Trailing<'_> {
        let (lead, trail, other) = match leader {
            FrameKind::Guided => (&self.guided, &self.unguided, FrameKind::Unguided),
            FrameKind::Unguided => (&self.unguided, &self.guided, FrameKind::Guided),
        };
        // A kind with zero variance (a black image) leads by any factor.
        let behind = if lead.inefficiency() > 0.0 { trail.inefficiency() / lead.inefficiency() } else { RACE_MAX_GAP };
        let gap = (RACE_MIN_GAP * behind).clamp(RACE_MIN_GAP, RACE_MAX_GAP);
        let noisier = if lead.variance > 0.0 { trail.variance / lead.variance } else { f64::INFINITY };
        let frames = (noisier / RACE_TRAILING_VARIANCE).min(u32::MAX as f64);
        let burst = RACE_BURST as f64;
        Trailing { lead, other, wait_ms: gap * burst * trail.ms, wait_frames: burst * frames }
    }

    /// How many frames of [`next`](Self::next)'s kind come in a row, as the race
    /// stands: the rest of a burst, a new burst, or the leader's frames until the
    /// trailing kind's gap and share are met, each leader frame taken to last as
    /// long as its mean (at least 1). A round of frames traced in one submission
    /// takes no more (`crate::render::GpuRenderer::render_round`).
    pub fn run_left(&self) -> u32 {
        let kind = self.next();
        let burst = RACE_BURST;
        if self.last == Some(kind) && self.run < burst && self.leader() != Some(kind) {
            return burst - self.run;
        }
        let Some(leader) = self.leader().filter(|&l| l == kind) else { return burst };
        let t = self.trailing(leader);
        // Until the time left changes, no burst of the other kind fits.
        if !self.burst_fits(t.other) {
            return u32::MAX;
        }
        let by_time = if t.lead.ms > 0.0 { (t.wait_ms - self.since_other_ms) / t.lead.ms } else { 1.0 };
        let by_frames = t.wait_frames - self.since_other_frames as f64;
        by_time.max(by_frames).ceil().clamp(1.0, u32::MAX as f64) as u32
    }

    /// Takes in a guided frame: its relative variance, its path tracing's time,
    /// the time of the learning pass after it where there was one, and how many
    /// guided frames the table learns once in (`RecordSchedule::learning_period`).
    /// The frame is charged its share of a learning pass, not the pass: the
    /// passes come after every frame at first, then one frame in `period`, and
    /// a race that charged them in full would judge a few early guided frames
    /// by a cost that the frames after them do not pay.
    pub fn report_guided(&mut self, variance: f64, trace_ms: f64, learn_ms: Option<f64>, period: u32) {
        if let Some(l) = learn_ms {
            self.learns += 1;
            self.learn_ms += (l - self.learn_ms) / self.learns.min(RACE_WINDOW) as f64;
        }
        self.report(FrameKind::Guided, variance, trace_ms + self.learn_ms / period.max(1) as f64);
    }

    /// Takes in a traced frame of either kind: a guided one as [`Self::report_guided`]
    /// does (`learn_ms` and `period` are its), an unguided one by its path
    /// tracing's time.
    pub fn report_frame(&mut self, kind: FrameKind, variance: f64, trace_ms: f64, learn_ms: Option<f64>, period: u32) {
        match kind {
            FrameKind::Guided => self.report_guided(variance, trace_ms, learn_ms, period),
            FrameKind::Unguided => self.report(kind, variance, trace_ms),
        }
    }

    /// Takes in a traced image frame: its kind, its relative variance and its time.
    pub fn report(&mut self, kind: FrameKind, variance: f64, ms: f64) {
        let leader = self.leader();
        let warm = self.last == Some(kind);
        match kind {
            FrameKind::Guided => self.guided.add(variance, ms, warm, RACE_GUIDED_WINDOW),
            FrameKind::Unguided => self.unguided.add(variance, ms, warm, RACE_WINDOW),
        }
        self.run = if warm { self.run + 1 } else { 1 };
        self.last = Some(kind);
        if let Some(l) = self.leader() {
            self.lead = l;
        }
        if Some(kind) == leader {
            self.since_other_ms += ms;
            self.since_other_frames += 1;
        } else {
            self.since_other_ms = 0.0;
            self.since_other_frames = 0;
        }
    }

    /// The mean time of a warm frame of `kind` (ms; a guided frame's with its
    /// share of the learning passes), where frames of it were timed.
    pub fn frame_ms(&self, kind: FrameKind) -> Option<f64> {
        let record = if kind == FrameKind::Guided { &self.guided } else { &self.unguided };
        (record.timed > 0).then_some(record.ms)
    }

    /// The leading kind once both have been measured, else None: guided at
    /// first, and the other once it is more efficient by [`RACE_HYSTERESIS`].
    pub fn leader(&self) -> Option<FrameKind> {
        let (g, u) = (&self.guided, &self.unguided);
        if g.frames < RACE_START_FRAMES || u.frames < RACE_START_FRAMES {
            return None;
        }
        let (lead, trail, other) = match self.lead {
            FrameKind::Guided => (g, u, FrameKind::Unguided),
            FrameKind::Unguided => (u, g, FrameKind::Guided),
        };
        Some(if trail.inefficiency() < RACE_HYSTERESIS * lead.inefficiency() { other } else { self.lead })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs the race over frames whose variance and time each kind fixes.
    fn run(frames: u32, guided: (f64, f64), unguided: (f64, f64)) -> (FrameRace, Vec<FrameKind>) {
        let mut race = FrameRace::default();
        let mut kinds = Vec::new();
        for _ in 0..frames {
            let k = race.next();
            let (v, ms) = if k == FrameKind::Guided { guided } else { unguided };
            race.report(k, v, ms);
            kinds.push(k);
        }
        (race, kinds)
    }

    /// `run_left` counts exactly the frames of `next`'s kind that come in a row
    /// where each kind's frames keep their variance and time and the lead does
    /// not change hands: a round of that many traced in one submission is what
    /// frame-by-frame choices would trace.
    #[test]
    fn run_left_counts_the_frames_next_gives_in_a_row() {
        for (guided, unguided) in [((1.0, 2.0), (4.0, 1.0)), ((4.0, 1.0), (1.0, 2.0)), ((1.0, 1.0), (1.0, 1.0))] {
            let mut race = FrameRace::default();
            let mut f = 0;
            while f < 4000 {
                let (kind, left, leader) = (race.next(), race.run_left(), race.leader());
                for i in 0..left {
                    assert_eq!(race.next(), kind, "{guided:?} / {unguided:?}: frame {} of a run of {left}", i + 1);
                    let (v, ms) = if kind == FrameKind::Guided { guided } else { unguided };
                    race.report(kind, v, ms);
                    f += 1;
                }
                // Where the lead did not change hands within the run (the race's state
                // changes with it), the next frame is of the other kind.
                if leader.is_some() && race.leader() == leader {
                    assert_ne!(race.next(), kind, "{guided:?} / {unguided:?}: the run of {left} ended early");
                }
            }
        }
    }

    #[test]
    fn the_race_starts_by_alternating_bursts_unguided_first() {
        let (_, kinds) = run(4, (1.0, 1.0), (1.0, 1.0));
        use FrameKind::*;
        assert_eq!(kinds, [Unguided, Unguided, Guided, Guided]);
    }

    /// The head start's guided frames are not weighed; it ends after
    /// `RECORD_FIRST_FRAMES` of them, or, in a timed render, once they took
    /// `RACE_HEAD_START_SHARE` of its budget (learning passes counted).
    #[test]
    fn the_head_start_ends_after_its_frames_or_its_share_of_the_budget() {
        let head = shared::RECORD_FIRST_FRAMES;
        let mut untimed = FrameRace::default();
        for g in 0..head {
            assert_eq!(untimed.head_start_left(g), head - g);
            assert_eq!(frame_kind(Some(&untimed), g, g, 0), FrameKind::Guided, "untimed, frame {g}");
            assert!(!untimed.weighs(FrameKind::Guided, g, g, 0));
            untimed.report_traced((FrameKind::Guided, g, g, 0), 1.0, 1e6, Some(1e6), 1);
        }
        assert!(untimed.head_start_over(head) && untimed.guided.frames == 0);
        // A round ends with the head start: the race's first burst is its own.
        assert_eq!((untimed.head_start_left(head), untimed.round_left(head)), (0, RACE_BURST));
        assert_eq!(untimed.round_left(head - 1), 1);
        assert_eq!(frame_kind(Some(&untimed), head, head, 0), FrameKind::Unguided, "the race starts unguided");

        // A budget of 100 ms: at most 10 ms of head start, here two frames of 3 ms
        // and a pass of 0.5 ms each (a third would take it to 10.5 ms).
        // (The timed render's first two frames are unguided, of 1 ms: the budget fits 100.)
        let mut timed = FrameRace::default();
        timed.set_time_left(100.0);
        for t in 0..RACE_OPENING {
            assert_eq!(frame_kind(Some(&timed), t, 0, 0), FrameKind::Unguided, "frame {t}");
            timed.report_traced((FrameKind::Unguided, t, 0, 0), 1.0, 1.0, None, 1);
        }
        timed.set_time_left(95.0);
        let o = RACE_OPENING;
        for g in 0..2 {
            assert!(!timed.head_start_over(g), "after {g} frames");
            assert_eq!(timed.head_start_left(g), if g == 0 { head } else { 1 }, "after {g} frames");
            assert_eq!(frame_kind(Some(&timed), g + o, g, 0), FrameKind::Guided);
            timed.report_traced((FrameKind::Guided, g + o, g, 0), 1.0, 3.0, Some(0.5), 1);
        }
        assert!(timed.head_start_over(2), "7 ms of a 100 ms budget, and 3.5 more");
        assert_eq!(timed.head_start_left(2), 0);
        assert!(timed.weighs(FrameKind::Guided, 2 + o, 2, 0) && timed.guided.frames == 0);
        assert_eq!(frame_kind(Some(&timed), 2 + o, 2, 0), FrameKind::Unguided, "the race opens unguided");
        // Learning frames are guided, head start or not; the image's then race.
        assert_eq!(frame_kind(Some(&timed), 2, 2, 5), FrameKind::Guided);
        // The first frame is traced whatever its budget.
        let mut short = FrameRace::default();
        short.set_time_left(1.0);
        assert!(!short.head_start_over(0));
        short.report_traced((FrameKind::Guided, 0, 0, 0), 1.0, 3.0, None, 1);
        assert!(short.head_start_over(1));
    }

    /// A timed render's frames weigh the inverse of their kind's variance, as
    /// the frames already traced measured it: the head start's guided frames
    /// too, the render's first frame not (no mean before it). Untimed, and
    /// before both kinds are measured, every frame weighs 1.
    #[test]
    fn timed_frames_weigh_the_inverse_of_their_kinds_variance() {
        use FrameKind::*;
        let mut untimed = FrameRace::default();
        for t in 0..4 {
            untimed.report_traced((Unguided, t, 0, 0), 1.0, 1.0, None, 1);
            untimed.report_traced((Guided, t, 0, 0), 28.0, 1.0, None, 1);
        }
        assert_eq!(untimed.frame_weight(Guided), 1.0, "an --spp image weighs every frame alike");

        let mut race = FrameRace::default();
        race.set_time_left(1000.0);
        race.report_traced((Unguided, 0, 0, 0), 0.001, 1.0, None, 1);
        assert_eq!(race.frame_weight(Guided), 1.0, "the first frame measures nothing");
        // The second, against the first's mean: twice the variance it measures.
        race.report_traced((Unguided, 1, 0, 0), 2.0, 1.0, None, 1);
        assert_eq!(race.unguided.frames, 0, "the race itself does not weigh the opening");
        assert_eq!(race.frame_weight(Guided), 1.0, "no guided frame measured yet");
        // A head-start frame, which the race itself does not weigh, 28 times as noisy.
        race.report_traced((Guided, 2, 0, 0), 28.0, 1.0, None, 1);
        assert!(race.guided.frames == 0 && !race.head_start_over(1));
        assert_eq!((race.frame_weight(Guided), race.frame_weight(Unguided)), (1.0 / 28.0, 1.0));
        // Means over the kind's frames: (28 + 14) / 2.
        race.report_traced((Guided, 3, 1, 0), 14.0, 1.0, None, 1);
        assert_eq!(race.frame_weight(Guided), 1.0 / 21.0);
        // Guided frames less noisy weigh more, up to the range.
        let mut better = race;
        for g in 0..RACE_WINDOW {
            better.report_traced((Guided, 4 + g, 2 + g, 0), 0.25, 1.0, None, 1);
        }
        assert!((better.frame_weight(Guided) - 4.0).abs() < 0.05, "{}", better.frame_weight(Guided));
        for g in 0..RACE_WINDOW {
            better.report_traced((Guided, 4 + RACE_WINDOW + g, 2 + RACE_WINDOW + g, 0), 0.0, 1.0, None, 1);
        }
        assert_eq!(better.frame_weight(Guided), RACE_WEIGHT_RANGE as f32, "a guided kind without variance");
        let mut worse = race;
        for g in 0..RACE_WINDOW {
            worse.report_traced((Guided, 4 + g, 2 + g, 0), 1e6, 1.0, None, 1);
        }
        assert_eq!(worse.frame_weight(Guided), 1.0 / RACE_WEIGHT_RANGE as f32);
        // Learning frames are not the image's: guided ones are not measured.
        let mut learning = FrameRace::default();
        learning.set_time_left(1000.0);
        learning.report_traced((Guided, 0, 0, 4), 5.0, 1.0, Some(1.0), 1);
        learning.report_traced((Unguided, 3, 3, 4), 1.0, 1.0, None, 1);
        assert_eq!(learning.frame_weight(Guided), 1.0);
    }

    /// A timed render opens with two unguided frames; the race times the first
    /// and weighs neither (measured against no frame or one). Where
    /// its budget fits fewer than `RACE_MIN_FRAMES` of them every frame is
    /// unguided, else the head start follows. Without a time limit, or after
    /// learning frames whose last is unguided, the render opens as before.
    #[test]
    fn a_timed_render_opens_unguided_and_guides_only_where_enough_frames_fit() {
        use FrameKind::*;
        for (frame_ms, explores) in [(10.0, false), (100.0 / RACE_MIN_FRAMES, true)] {
            let mut race = FrameRace::default();
            race.set_time_left(100.0);
            assert!(race.explores() && race.opens_unguided(0, 0, 0));
            assert_eq!(frame_kind(Some(&race), 0, 0, 0), Unguided);
            race.report_traced((Unguided, 0, 0, 0), 1.0, frame_ms, None, 1);
            assert_eq!(race.unguided.frames, 0, "the first frame's variance is not weighed");
            assert_eq!(race.explores(), explores, "frames of {frame_ms} ms in 100");
            race.set_time_left(100.0 - frame_ms);
            assert_eq!(frame_kind(Some(&race), 1, 0, 0), Unguided, "the second frame opens the image too");
            race.report_traced((Unguided, 1, 0, 0), 1.0, frame_ms, None, 1);
            assert_eq!(race.unguided.frames, 0, "the opening is not the race's");
            race.set_time_left(100.0 - 2.0 * frame_ms);
            let want = if explores { Guided } else { Unguided };
            assert_eq!(frame_kind(Some(&race), 2, 0, 0), want, "frames of {frame_ms} ms");
            if !explores {
                assert_eq!(race.round_left(0), u32::MAX, "one kind to the end: rounds are not cut");
                race.report_traced((Unguided, 2, 0, 0), 1.0, frame_ms, None, 1);
                assert_eq!((race.unguided.frames, frame_kind(Some(&race), 3, 0, 0)), (1, Unguided));
            }
        }
        // Untimed: the head start first.
        let untimed = FrameRace::default();
        assert!(!untimed.opens_unguided(0, 0, 0));
        assert_eq!(frame_kind(Some(&untimed), 0, 0, 0), Guided);
        // One learning frame: the image's first frame is the unguided one. Four:
        // their last is unguided, and its time is the unguided kind's.
        let mut timed = FrameRace::default();
        timed.set_time_left(100.0);
        assert_eq!((frame_kind(Some(&timed), 0, 0, 1), frame_kind(Some(&timed), 1, 1, 1)), (Guided, Unguided));
        assert_eq!(frame_kind(Some(&timed), 3, 3, 4), Unguided);
        timed.report_traced((Unguided, 3, 3, 4), 1.0, 10.0, None, 1);
        assert_eq!(timed.unguided.frames, 1);
        assert!(!timed.explores());
        assert_eq!(frame_kind(Some(&timed), 4, 3, 4), Unguided);
    }

    /// `RACE_MIN_FRAMES` is where the race's own rules start to allow a guided
    /// frame after the head start: with every frame of either kind taking 1 ms
    /// (guided frames take at least an unguided one's time), a race with a
    /// budget of that many frames traces a guided burst, and one of two frames
    /// fewer (the head start's frames are whole) traces unguided frames alone after it.
    #[test]
    fn below_the_minimum_budget_no_guided_frame_follows_the_head_start() {
        let guided_after_head_start = |budget: f64| {
            let mut race = FrameRace::default();
            race.set_time_left(budget);
            // The opening's unguided frames: their time only (reported apart, so
            // that the race still explores).
            let (mut spent, mut g) = (RACE_OPENING as f64, 0);
            while !race.head_start_over(g) {
                race.set_time_left(budget - spent);
                race.report_traced((FrameKind::Guided, g + 1, g, 0), 1.0, 1.0, None, 1);
                (spent, g) = (spent + 1.0, g + 1);
            }
            while spent < budget {
                race.set_time_left(budget - spent);
                if race.next() == FrameKind::Guided {
                    return true;
                }
                race.report(FrameKind::Unguided, 1.0, 1.0);
                spent += 1.0;
            }
            false
        };
        assert!(guided_after_head_start(RACE_MIN_FRAMES.ceil()), "{RACE_MIN_FRAMES}");
        assert!(!guided_after_head_start(RACE_MIN_FRAMES.floor() - 1.0), "{RACE_MIN_FRAMES}");
    }

    /// In a timed render a burst of the trailing kind, or the first guided one,
    /// is traced only where it takes at most `RACE_EXPLORE_SHARE` of the time
    /// left; the leader's run then lasts until the time left changes.
    #[test]
    fn bursts_that_do_not_fit_the_time_left_are_not_traced() {
        use FrameKind::*;
        let head = shared::RECORD_FIRST_FRAMES;
        let mut race = FrameRace::default();
        race.set_time_left(1000.0);
        for g in 0..head {
            race.report_traced((Guided, g, g, 0), 1.0, 4.0, None, 1);
        }
        // Head start over; two unguided frames; a guided burst of 2 x 4 ms against 10 % of the time left.
        for _ in 0..2 {
            assert_eq!(race.next(), Unguided);
            race.report(Unguided, 1.0, 1.0);
        }
        race.set_time_left(79.0);
        assert_eq!(race.next(), Unguided, "8 ms of guided frames in 79 ms left");
        race.set_time_left(80.0);
        assert_eq!(race.next(), Guided, "8 ms of guided frames in 80 ms left");
        assert_eq!((race.frame_ms(Guided), race.frame_ms(Unguided)), (None, Some(1.0)));
        for _ in 0..2 {
            race.report(Guided, 1.0, 2.0);
        }
        assert_eq!(race.frame_ms(Guided), Some(2.0));
        assert_eq!(race.leader(), Some(Unguided));
        // The leader's frames until the guided burst is due: guided is 2 times
        // behind, so 32 times its burst's 2 x 2 ms of 1 ms frames.
        let mut frames = 0;
        while race.next() == Unguided {
            race.report(Unguided, 1.0, 1.0);
            frames += 1;
        }
        assert_eq!(frames, 128);
        race.set_time_left(39.0);
        assert_eq!((race.next(), race.run_left()), (Unguided, u32::MAX), "4 ms of guided frames in 39 ms left");
        race.set_time_left(40.0);
        assert_eq!(race.next(), Guided);
    }

    /// The more efficient kind gets most of the time; the other keeps a share
    /// that shrinks with the gap and with how much noisier its frames are, never none.
    #[test]
    fn the_more_efficient_kind_gets_most_of_the_time() {
        for (guided, unguided) in [((0.65, 2.0), (1.0, 1.0)), ((0.2, 2.0), (1.0, 1.0)), ((1.0, 1.0), (0.9, 1.2))] {
            let (race, kinds) = run(4000, guided, unguided);
            let e = |(v, ms): (f64, f64)| v * ms;
            let (lead, trail) = if e(guided) <= e(unguided) { (guided, unguided) } else { (unguided, guided) };
            let trailing = if e(guided) <= e(unguided) { FrameKind::Unguided } else { FrameKind::Guided };
            // Leader frames between two bursts of the trailing kind: enough time and enough frames.
            let burst = RACE_BURST as f64;
            let gap = (RACE_MIN_GAP * e(trail) / e(lead)).clamp(RACE_MIN_GAP, RACE_MAX_GAP);
            let by_time = (gap * burst * trail.1 / lead.1).ceil();
            let by_variance = (burst * trail.0 / lead.0 / RACE_TRAILING_VARIANCE).ceil();
            let k = by_time.max(by_variance);
            let want = burst / (k + burst);
            let got = kinds[100..].iter().filter(|&&x| x == trailing).count() as f64 / (kinds.len() - 100) as f64;
            assert!((got - want).abs() < 0.1 * want, "{guided:?} vs {unguided:?}: trailing frames {got}, want {want}");
            assert!(race.guided.frames > 0 && race.unguided.frames > 0);
        }
    }

    /// A kind that improves (the guided one as its table learns) takes the lead
    /// once it is ahead, measured by the frames it keeps getting.
    #[test]
    fn a_kind_that_improves_takes_the_lead() {
        let mut race = FrameRace::default();
        let mut guided_frames = 0u32;
        let mut last = Vec::new();
        for _ in 0..3000 {
            let k = race.next();
            let (v, ms) = match k {
                FrameKind::Guided => {
                    guided_frames += 1;
                    // Variance falls from twice the unguided one's to a tenth.
                    (0.1 + 1.9 * (-(guided_frames as f64) / 20.0).exp(), 1.5)
                }
                FrameKind::Unguided => (1.0, 1.0),
            };
            race.report(k, v, ms);
            last.push(k);
        }
        let tail = &last[last.len() - 200..];
        let guided = tail.iter().filter(|&&k| k == FrameKind::Guided).count();
        assert!(guided > 180, "guided frames in the last 200: {guided}");
    }
}
