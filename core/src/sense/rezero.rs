//! Re-zero at rest: the load cell tared again whenever the string is slack.
//!
//! # Theory of operation
//!
//! The self-test tares the load cell at power-up (REQ-ID-01); over a working day the bridge's
//! zero moves with temperature and the bar creeps, and every pull inherits the difference as
//! an offset. The load cell's zero can be read again whenever nothing pulls on the gripper —
//! in Ready, with the carriage at home. [`Rezero::observe`] runs once a tick there and takes a
//! new tare (REQ-ID-08) when the evidence says the gripper is unloaded:
//!
//! 1. **At rest** — the home switch closed and the end switch open, the Hall count unchanged,
//!    no key down, the reading off the converter's rails — continuously for
//!    [`REZERO_SETTLE_MS`] before anything is averaged: the release's ringing has died, the
//!    amplifier has settled, and a stringer who just touched the panel (and maybe the
//!    gripper) has let go. Any tick not at rest starts the count again.
//! 2. **Steady** — readings are summed in windows of [`REZERO_WINDOW`] ticks (100 ms: five
//!    periods of 50 Hz mains and six of 60 Hz, so the hum averages out as in the self-test),
//!    and the last [`REZERO_WINDOWS`] windows' means (half a second) must all agree within
//!    [`REZERO_AGREE`]: a hand on the gripper is never that still (its tremor averages out
//!    of a window, but its force wanders by tens of grams over half a second), while the
//!    noise of a window's mean is a tenth of a sample's.
//! 3. **Near the zero in use** — the windows' mean may differ from the present zero by
//!    at most [`REZERO_STEP_MAX`] plus what the zero can have drifted on its own since it
//!    was taken ([`ZERO_DRIFT_RATE`] times that time, [`RezeroBands::step_after`]): the
//!    zero's drift between two re-zeros seconds apart is a few grams, while a string held in
//!    the gripper or a hand pushing on it loads it by far more and is refused as loaded. The
//!    allowance grows with the time the machine was busy — a calibration right after
//!    power-up, while the amplifier still warms, takes a minute and a half, long enough for
//!    its zero to walk past the step; without it that zero would be refused as a load at
//!    every rest of the day.
//! 4. **Near the self-test's zero** — and from the zero the self-test tared (the reference)
//!    by at most [`REZERO_RANGE`]: a zero that has walked further is not corrected step by
//!    step behind the operator's back (creeping tare steps cannot accumulate a held load
//!    into the zero beyond this bound either).
//!
//! The bands of steps 2–4 and the drift watch are tension facts — how still a hand is, what
//! a held string weighs, what drift needs recalibrating — so they are stated in kgf at the
//! gripper ([`REZERO_AGREE`], [`REZERO_STEP_MAX`], [`REZERO_RANGE`], [`DRIFT_WATCH`]) and
//! converted to volts at the converter once, through the board's load-cell scale
//! ([`RezeroBands::for_scale`]), when the rule is built; the rule compares volts, as the
//! readings come. On the paper's chain (92 mV/kgf on a 5 V converter) the bands are 1.5, 5,
//! 50 and 25 mV; on a chain divided by 0.656 before a 3.3 V converter, 0.98, 3.3, 32.8 and
//! 16.4 mV — the same tensions, and about the same number of codes.
//!
//! Windows accepted under all four become the load cell's zero (the mean of their 500
//! readings, to a fraction of a code, like the self-test's), and the windows go on: at rest
//! the zero follows its drift every 100 ms. The calibration's correction is relative to
//! the tare (its zero point is the tare's raw 0), so a new tare restores exactly the
//! condition the calibration was made in.
//!
//! Cost: one addition and a few comparisons a tick; a pass over five sums and two divisions
//! every 100 ms at rest.

use crate::sense::load_cell::LoadCellScale;
use crate::units::{ADC_REFERENCE_RANGE_MV, AdcCode, AdcReference, Kgf, Q16, Volts};

/// Ticks the carriage must have rested at home, untouched, before readings are averaged.
pub const REZERO_SETTLE_MS: u16 = 2_000;
/// Readings in one averaging window (whole periods of 50 and 60 Hz mains).
pub const REZERO_WINDOW: u16 = 100;
/// Consecutive windows that must agree: half a second.
pub const REZERO_WINDOWS: usize = 5;
const _: () = assert!(REZERO_WINDOWS == 5, "the mean's count below is 5 windows");
/// How far the agreeing windows' means may spread: 0.0163 kgf (1.5 mV on the paper's chain,
/// ≈ 1.2 codes on any chain whose full scale is the paper's); a window's mean has ≈ 0.003 kgf
/// of noise at the family's noisiest 0.033 kgf rms a sample, while a hand on the gripper
/// wanders by tens of grams.
pub const REZERO_AGREE: Kgf = Kgf(Q16::lit("0.0163"));
/// How far a new zero may lie from the zero in use: 0.0544 kgf (5 mV on the paper's chain,
/// 4 codes) — more than the zero drifts between two re-zeros, less than a string held in the
/// gripper weighs.
pub const REZERO_STEP_MAX: Kgf = Kgf(Q16::lit("0.0544"));
/// How far a new zero may lie from the self-test's: 0.5435 kgf (50 mV on the paper's chain).
pub const REZERO_RANGE: Kgf = Kgf(Q16::lit("0.5435"));
/// The drift watch (REQ-UI-12): a zero that has moved more than 0.2717 kgf (25 mV on the
/// paper's chain, half the re-zero's range) from the self-test's asks for a recalibration.
/// The re-zero removes the offset itself, but a bridge whose zero moved that far has seen a
/// temperature change (or a knock) that moves its sensitivity too — a strain-gauge chain's
/// span coefficient is of the order of its zero's, ≈ 0.02 % per kelvin, so ≈ 25 K at the
/// family's largest zero coefficient, 0.25 kgf at 50 kgf, more than the hold's accuracy —
/// which only a calibration measures; and the operator hears of it before the zero reaches
/// the range the re-zero no longer follows.
pub const DRIFT_WATCH: Kgf = Kgf(Q16::lit("0.2717"));

/// How fast the load cell's zero can move on its own, per second: 0.0015 kgf (≈ 0.14 mV/s on
/// the paper's chain). The fastest is the amplifier's warm-up after power-up — an
/// instrumentation amplifier's output offset settling over minutes, up to ≈ 0.1 mV/s at the
/// converter — and the bridge's temperature drift over the day is far slower. A re-zero may
/// move the zero by [`REZERO_STEP_MAX`] plus this rate times the time since the zero in use
/// was taken: a zero that walked while the machine was not at rest (a calibration right
/// after power-up takes a minute and a half; a pull with a long hold, a minute) is followed
/// at the next rest instead of being refused as a load at every rest after, while a string
/// held in the gripper minutes after a re-zero is still refused.
pub const ZERO_DRIFT_RATE: Kgf = Kgf(Q16::lit("0.0015"));

/// The most periods of 1.024 s [`RezeroBands::step_after`] counts: 1 023 (17 minutes; the
/// range caps the step after ≈ 6 minutes at [`ZERO_DRIFT_RATE`]).
pub const DRIFT_PERIODS_MAX: u32 = 1_023;

/// The widest band a valid rule has ([`RezeroBands::is_valid`]): the widest converter's whole
/// range, 5.5 V.
const BAND_MAX: Volts = Volts(Q16::lit("5.5"));
const _: () = assert!(ADC_REFERENCE_RANGE_MV.1 == 5_500, "BAND_MAX is the widest reference");

/// The re-zero's bands in volts at one board's converter: [`REZERO_AGREE`],
/// [`REZERO_STEP_MAX`], [`REZERO_RANGE`] and [`DRIFT_WATCH`] through its load-cell scale
/// (each to the nearest Q15.16 bit, [`LoadCellScale::volts_of`]). Converted once, when the
/// rule is built; a re-tare keeps the gain, so the bands stay.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct RezeroBands {
    agree: Volts,
    step_max: Volts,
    range: Volts,
    drift_watch: Volts,
    drift_rate: Volts,
}

/// Any bands, for proofs: each drawn whole, as bits ([`RezeroBands::is_valid`] states which a
/// board can have) — every board's bands, and more.
#[cfg(kani)]
impl kani::Arbitrary for RezeroBands {
    fn any() -> Self {
        Self {
            agree: Volts::from_bits(kani::any()),
            step_max: Volts::from_bits(kani::any()),
            range: Volts::from_bits(kani::any()),
            drift_watch: Volts::from_bits(kani::any()),
            drift_rate: Volts::from_bits(kani::any()),
        }
    }
}

impl RezeroBands {
    /// The bands on the chain of `scale` (its gain `k`: a band of `F` kgf is `F / k` volts).
    #[must_use]
    pub fn for_scale(scale: &LoadCellScale) -> Self {
        Self {
            agree: scale.volts_of(REZERO_AGREE),
            step_max: scale.volts_of(REZERO_STEP_MAX),
            range: scale.volts_of(REZERO_RANGE),
            drift_watch: scale.volts_of(DRIFT_WATCH),
            drift_rate: scale.volts_of(ZERO_DRIFT_RATE),
        }
    }

    /// Whether these are bands a board can have: each from zero up to the widest converter's
    /// whole range ([`BAND_MAX`], 5.5 V). A valid scale's bands are far inside — at most
    /// 0.11 V, [`REZERO_RANGE`] over the least gain a scale accepts (4.9 kgf/V, on a 5.5 V
    /// converter) — and the bound keeps every band below the distance the rule compares it
    /// with when that saturates at the format's range, so no band accepts every zero.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        // Constant bound: five bands.
        [self.agree, self.step_max, self.range, self.drift_watch, self.drift_rate]
            .iter()
            .all(|&band| band >= Volts::ZERO && band <= BAND_MAX)
    }

    /// [`REZERO_AGREE`] in volts: how far the agreeing windows' means may spread.
    #[must_use]
    pub const fn agree(&self) -> Volts {
        self.agree
    }

    /// [`REZERO_STEP_MAX`] in volts: how far a new zero may lie from the zero in use.
    #[must_use]
    pub const fn step_max(&self) -> Volts {
        self.step_max
    }

    /// [`REZERO_RANGE`] in volts: how far a new zero may lie from the self-test's.
    #[must_use]
    pub const fn range(&self) -> Volts {
        self.range
    }

    /// [`DRIFT_WATCH`] in volts: the zero's drift that asks for a recalibration.
    #[must_use]
    pub const fn drift_watch(&self) -> Volts {
        self.drift_watch
    }

    /// [`ZERO_DRIFT_RATE`] in volts per second.
    #[must_use]
    pub const fn drift_rate(&self) -> Volts {
        self.drift_rate
    }

    /// How far a re-zero may move the zero `age_ms` after the zero in use was taken:
    /// [`REZERO_STEP_MAX`] plus [`ZERO_DRIFT_RATE`] for that time, never past
    /// [`REZERO_RANGE`]. The time is counted in whole periods of 1.024 s (a shift, no
    /// division: the allowance comes up to 2.4 % late, never early), at most
    /// [`DRIFT_PERIODS_MAX`] of them — far past where the range caps the step.
    #[must_use]
    pub fn step_after(&self, age_ms: u32) -> Volts {
        let periods = i32::try_from((age_ms >> 10).min(DRIFT_PERIODS_MAX)).unwrap_or(0);
        // A valid band (≤ 5.5 V, 19 bits) times 1 023 periods (10 bits) fits 32 bits: the
        // product never wraps (and a plain product is what a proof's solver handles best).
        let drift = self.drift_rate.to_bits().wrapping_mul(periods);
        let step = self.step_max.to_bits().saturating_add(drift);
        let capped = step.min(self.range.to_bits().max(self.step_max.to_bits()));
        Volts::from_bits(capped)
    }
}

/// What one tick tells the re-zero rule.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct RestSample {
    /// The home limit switch is closed.
    pub home: bool,
    /// The end limit switch is closed.
    pub end: bool,
    /// The drive's Hall count.
    pub steps: i32,
    /// A key is down or a key event came this tick.
    pub key: bool,
    /// The load-cell code.
    pub code: AdcCode,
    /// The machine's clock, ms (wrapping).
    pub now_ms: u32,
}

/// The verdict on a pair of windows.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Retare {
    /// Accepted: the load cell's new zero.
    Zero(Volts),
    /// The two windows disagree: something moves the gripper.
    Unsteady,
    /// Farther than [`RezeroBands::step_after`] from the zero in use: the gripper is loaded.
    Loaded,
    /// Farther than [`REZERO_RANGE`] from the self-test's zero.
    OutOfRange,
}

/// The re-zero rule's state (see the module docs): 56 bytes.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Rezero {
    /// The self-test's zero.
    reference: Volts,
    /// The bands in volts on the board's chain.
    bands: RezeroBands,
    /// Consecutive ticks at rest, up to [`REZERO_SETTLE_MS`].
    rest_ms: u16,
    /// Readings in the present window.
    ticks: u16,
    /// The Hall count the rest started at.
    steps: i32,
    /// The present window's code sum.
    sum: u32,
    /// Windows completed in this rest, up to [`REZERO_WINDOWS`].
    windows: u8,
    /// Where the next window's sum goes in `sums`.
    next: u8,
    /// The last windows' code sums (a ring).
    sums: [u32; REZERO_WINDOWS],
    /// When the zero in use was taken (the self-test's tare or the last re-zero), on the
    /// machine's clock; `None` when not known (then only [`REZERO_STEP_MAX`] is allowed).
    zero_at: Option<u32>,
}

/// Any re-zero state, for proofs ([`Rezero::is_valid`] states which are reachable): every
/// field drawn whole (`Volts` wraps a `fixed` number, which has no `Arbitrary`: its bits are
/// drawn instead), the bands too — every board's bands, and more.
#[cfg(kani)]
impl kani::Arbitrary for Rezero {
    fn any() -> Self {
        Self {
            reference: Volts::from_bits(kani::any()),
            bands: kani::any(),
            rest_ms: kani::any(),
            ticks: kani::any(),
            steps: kani::any(),
            sum: kani::any(),
            windows: kani::any(),
            next: kani::any(),
            sums: kani::any(),
            zero_at: kani::any(),
        }
    }
}

/// The largest code sum of a window.
const WINDOW_SUM_MAX: u32 = 4_095 * REZERO_WINDOW as u32;

/// `|a − b|` of two voltages, saturating.
fn distance(a: Volts, b: Volts) -> Q16 {
    a.0.saturating_sub(b.0).saturating_abs()
}

impl Rezero {
    /// A rule whose reference is the self-test's zero `reference`, with the `bands` of the
    /// board's chain ([`RezeroBands::for_scale`]), no rest yet.
    #[must_use]
    pub const fn new(reference: Volts, bands: RezeroBands) -> Self {
        Self {
            reference,
            bands,
            rest_ms: 0,
            ticks: 0,
            steps: 0,
            sum: 0,
            windows: 0,
            next: 0,
            sums: [0; REZERO_WINDOWS],
            zero_at: None,
        }
    }

    /// This rule, its zero in use taken at `now_ms` on the machine's clock (the self-test's
    /// tare).
    #[must_use]
    pub const fn taken_at(self, now_ms: u32) -> Self {
        Self { zero_at: Some(now_ms), ..self }
    }

    /// The self-test's zero the rule keeps to.
    #[must_use]
    pub const fn reference(&self) -> Volts {
        self.reference
    }

    /// When the zero in use was taken, on the machine's clock, if known.
    #[must_use]
    pub const fn zero_at(&self) -> Option<u32> {
        self.zero_at
    }

    /// The bands the rule keeps to, in volts on the board's chain.
    #[must_use]
    pub const fn bands(&self) -> RezeroBands {
        self.bands
    }

    /// Whether the zero in use, `zero`, has drifted past [`DRIFT_WATCH`] from the
    /// self-test's.
    #[must_use]
    pub fn drifted(&self, zero: Volts) -> bool {
        distance(zero, self.reference) > self.bands.drift_watch.0
    }

    /// Whether the zero in use, `zero`, has drifted past [`DRIFT_WATCH`] from the self-test's
    /// or from the zero the calibration was taken at (`calibrated_at`, kept in the record;
    /// `None` when not known): a zero that crept across power cycles since the calibration is
    /// watched as well as one that moved since the boot.
    #[must_use]
    pub fn drifted_since(&self, zero: Volts, calibrated_at: Option<Volts>) -> bool {
        self.drifted(zero)
            || calibrated_at
                .is_some_and(|calibrated| distance(zero, calibrated) > self.bands.drift_watch.0)
    }

    /// Whether a real run can be in this state: the counts within their lengths, the sums
    /// within what their readings can add to, the bands a board's
    /// ([`RezeroBands::is_valid`]).
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.rest_ms <= REZERO_SETTLE_MS
            && self.ticks < REZERO_WINDOW
            && self.sum <= 4_095u32.saturating_mul(u32::from(self.ticks))
            && usize::from(self.windows) <= REZERO_WINDOWS
            && usize::from(self.next) < REZERO_WINDOWS
            && self.sums.iter().all(|&sum| sum <= WINDOW_SUM_MAX)
            && (self.ticks == 0 || self.rest_ms == REZERO_SETTLE_MS)
            && (self.windows == 0 || self.rest_ms == REZERO_SETTLE_MS)
            && self.bands.is_valid()
    }

    /// Starts over: the rest is broken (or Ready was just entered).
    pub fn restart(&mut self) {
        *self = Self { zero_at: self.zero_at, ..Self::new(self.reference, self.bands) };
    }

    /// One tick (REQ-ID-08): `sample` what the machine sees, `zero` the load cell's zero in
    /// use, `reference` its converter's. A verdict every [`REZERO_WINDOW`] ticks once the rest has settled and one window
    /// is complete; `None` otherwise.
    pub fn observe(
        &mut self,
        sample: &RestSample,
        zero: Volts,
        reference: AdcReference,
    ) -> Option<Retare> {
        let code = sample.code.get();
        let at_rest = sample.home
            && !sample.end
            && !sample.key
            && code > 0
            && code < AdcCode::MAX.get()
            && (self.rest_ms == 0 || sample.steps == self.steps);
        if !at_rest {
            self.restart();
            return None;
        }
        if self.rest_ms < REZERO_SETTLE_MS {
            if self.rest_ms == 0 {
                self.steps = sample.steps;
            }
            self.rest_ms = self.rest_ms.saturating_add(1);
            return None;
        }
        self.sum = self.sum.saturating_add(u32::from(code));
        self.ticks = self.ticks.saturating_add(1);
        if self.ticks < REZERO_WINDOW {
            return None;
        }
        let window = self.sum;
        self.sum = 0;
        self.ticks = 0;
        if let Some(slot) = self.sums.get_mut(usize::from(self.next)) {
            *slot = window;
        }
        let next = self.next.saturating_add(1);
        self.next = if usize::from(next) >= REZERO_WINDOWS { 0 } else { next };
        if usize::from(self.windows) < REZERO_WINDOWS {
            self.windows = self.windows.saturating_add(1);
        }
        if usize::from(self.windows) < REZERO_WINDOWS {
            return None;
        }
        // Constant bound: REZERO_WINDOWS (5) sums.
        let (mut low, mut high, mut total) = (u32::MAX, 0u32, 0u32);
        for &sum in &self.sums {
            low = low.min(sum);
            high = high.max(sum);
            total = total.saturating_add(sum);
        }
        let spread = reference
            .mean_volts(high, REZERO_WINDOW)
            .0
            .saturating_sub(reference.mean_volts(low, REZERO_WINDOW).0);
        if spread > self.bands.agree.0 {
            return Some(Retare::Unsteady);
        }
        // 5 × 100 readings.
        let mean = reference.mean_volts(total, REZERO_WINDOW.saturating_mul(5));
        let age_ms = self.zero_at.map_or(0, |at| sample.now_ms.wrapping_sub(at));
        Some(if distance(mean, zero) > self.bands.step_after(age_ms).0 {
            Retare::Loaded
        } else if distance(mean, self.reference) > self.bands.range.0 {
            Retare::OutOfRange
        } else {
            self.zero_at = Some(sample.now_ms);
            Retare::Zero(mean)
        })
    }
}

#[cfg(test)]
mod tests {
    /// The paper's board's 5 V converter.
    const FIVE_VOLTS: AdcReference = match AdcReference::from_millivolts(5_000) {
        Some(reference) => reference,
        None => panic!("5 V is a converter reference"),
    };
    use super::*;

    const ZERO: Volts = Volts(Q16::lit("0.05"));

    /// The bands on the paper's chain (92 mV/kgf on a 5 V converter).
    fn paper_bands() -> RezeroBands {
        RezeroBands::for_scale(&crate::test_support::paper_board().load_cell())
    }

    /// The firmware's kind of chain: the paper's amplifier through a 0.656 divider into a
    /// 3.3 V converter (60.4 mV/kgf at the pin, zero 32.8 mV).
    fn divided_scale() -> LoadCellScale {
        use crate::board::{PAPER_KGF_PER_VOLT, PAPER_LOAD_CELL_ZERO};
        let divider = Q16::lit("0.656126");
        let Some(reference) = AdcReference::from_millivolts(3_300) else {
            panic!("3.3 V is a converter reference")
        };
        let zero = Volts(PAPER_LOAD_CELL_ZERO.0.saturating_mul(divider));
        crate::test_support::valid(LoadCellScale::new(
            reference,
            zero,
            PAPER_KGF_PER_VOLT.saturating_div(divider),
        ))
    }

    fn rest(code: u16) -> RestSample {
        RestSample {
            home: true,
            end: false,
            steps: 7,
            key: false,
            code: AdcCode::new(code),
            now_ms: 0,
        }
    }

    #[test]
    fn the_step_grows_with_the_zeros_age_up_to_the_range() {
        let bands = paper_bands();
        assert_eq!(bands.step_after(0), bands.step_max());
        // ZERO_DRIFT_RATE through the paper's gain: 0.0015 kgf/s ≈ 0.138 mV/s.
        assert_eq!(bands.drift_rate(), Volts::from_bits(9));
        // Whole periods of 1.024 s.
        assert_eq!(bands.step_after(1_023), bands.step_max());
        assert_eq!(bands.step_after(1_024), Volts::from_bits(bands.step_max().to_bits() + 9));
        assert_eq!(bands.step_after(90_000), Volts::from_bits(bands.step_max().to_bits() + 783));
        // The count stops at DRIFT_PERIODS_MAX: with a range wider than that, the step stops.
        let wide = RezeroBands { range: BAND_MAX, ..bands };
        let most = Volts::from_bits(bands.step_max().to_bits() + 9 * 1_023);
        assert_eq!(wide.step_after(1_023 * 1_024), most);
        assert_eq!(wide.step_after(u32::MAX), most);
        assert_eq!(bands.step_after(u32::MAX), bands.range());
        let mut last = bands.step_after(0);
        for age in (0..=400_000).step_by(997) {
            let step = bands.step_after(age);
            assert!(step >= last && step <= bands.range(), "{age}");
            last = step;
        }
    }

    #[test]
    fn a_zero_that_walked_while_the_machine_was_busy_is_followed_at_the_next_rest() {
        // The zero in use taken at 0 ms; the cell now reads 49 codes, 9.8 mV (≈ 0.107 kgf)
        // above it — the amplifier's warm-up over a calibration right after power-up.
        let at =
            |start: u32| move |t: u32| RestSample { now_ms: start.wrapping_add(t), ..rest(49) };
        // 90 s later: 5 mV + 90 s × 0.138 mV/s allowed — followed, and the new zero's time kept.
        let mut rule = Rezero::new(ZERO, paper_bands()).taken_at(0);
        let tally = feed(&mut rule, 2_500, ZERO, at(90_000));
        assert!(matches!(tally.last, Some(Retare::Zero(_))), "{tally:?}");
        assert_eq!(rule.zero_at(), Some(92_499));
        // A broken rest keeps the zero's time.
        rule.observe(&RestSample { home: false, ..rest(49) }, ZERO, FIVE_VOLTS);
        assert_eq!(rule.zero_at(), Some(92_499));
        // 1 s after the tare the same reading is a load (a string held in the gripper).
        let mut rule = Rezero::new(ZERO, paper_bands()).taken_at(0);
        assert_eq!(feed(&mut rule, 2_500, ZERO, at(1_000)).last, Some(Retare::Loaded));
        // When the zero's time is not known, only the step.
        let mut rule = Rezero::new(ZERO, paper_bands());
        assert_eq!(feed(&mut rule, 2_500, ZERO, at(90_000)).last, Some(Retare::Loaded));
        // The clock wraps: 90 s across the wrap is 90 s.
        let mut rule = Rezero::new(ZERO, paper_bands()).taken_at(u32::MAX - 9_999);
        let tally = feed(&mut rule, 2_500, ZERO, at(80_000));
        assert!(matches!(tally.last, Some(Retare::Zero(_))), "{tally:?}");
    }

    /// How many verdicts of each kind a run gave, and the last one.
    #[derive(Debug, Default, PartialEq)]
    struct Tally {
        zero: u32,
        unsteady: u32,
        loaded: u32,
        out_of_range: u32,
        last: Option<Retare>,
    }

    impl Tally {
        fn total(&self) -> u32 {
            self.zero + self.unsteady + self.loaded + self.out_of_range
        }
    }

    /// Feeds `sample(tick)` for `ticks` ticks on the paper's 5 V converter; the verdicts.
    fn feed(
        rule: &mut Rezero,
        ticks: u32,
        zero: Volts,
        sample: impl FnMut(u32) -> RestSample,
    ) -> Tally {
        feed_on(rule, ticks, zero, FIVE_VOLTS, sample)
    }

    /// Feeds `sample(tick)` for `ticks` ticks on a converter of `reference`; the verdicts.
    fn feed_on(
        rule: &mut Rezero,
        ticks: u32,
        zero: Volts,
        reference: AdcReference,
        mut sample: impl FnMut(u32) -> RestSample,
    ) -> Tally {
        let mut tally = Tally::default();
        for t in 0..ticks {
            if let Some(verdict) = rule.observe(&sample(t), zero, reference) {
                match verdict {
                    Retare::Zero(_) => tally.zero += 1,
                    Retare::Unsteady => tally.unsteady += 1,
                    Retare::Loaded => tally.loaded += 1,
                    Retare::OutOfRange => tally.out_of_range += 1,
                }
                tally.last = Some(verdict);
            }
        }
        tally
    }

    #[test]
    fn a_steady_unloaded_gripper_is_tared_after_the_settling_and_five_windows() {
        let mut rule = Rezero::new(ZERO, paper_bands());
        // Readings alternating 41 and 42 codes: their mean, 41.5 codes, is the zero.
        let settle = u32::from(REZERO_SETTLE_MS);
        let window = u32::from(REZERO_WINDOW);
        let verdicts =
            feed(&mut rule, settle + 5 * window - 1, ZERO, |t| rest(41 + (t % 2) as u16));
        assert_eq!(verdicts.total(), 0, "{verdicts:?}");
        let last = rule.observe(&rest(42), ZERO, FIVE_VOLTS);
        assert_eq!(last, Some(Retare::Zero(FIVE_VOLTS.mean_volts(41 * 250 + 42 * 250, 500))));
        // Every window after that gives a verdict.
        let more = feed(&mut rule, 3 * window, ZERO, |t| rest(41 + (t % 2) as u16));
        assert_eq!(more.zero, 3, "{more:?}");
        assert!(rule.is_valid());
    }

    /// Each clause of the invariant, violated alone, makes the state invalid; states a run
    /// reaches, at each clause's limit, are valid.
    #[test]
    fn the_invariant_refuses_each_unreachable_state_alone() {
        let settled = Rezero {
            rest_ms: REZERO_SETTLE_MS,
            ticks: 99,
            sum: 4_095 * 99,
            windows: 5,
            next: 4,
            sums: [WINDOW_SUM_MAX; REZERO_WINDOWS],
            ..Rezero::new(ZERO, paper_bands())
        };
        assert!(settled.is_valid());
        assert!(Rezero::new(ZERO, paper_bands()).is_valid());
        let settling = Rezero { rest_ms: REZERO_SETTLE_MS - 1, ..Rezero::new(ZERO, paper_bands()) };
        assert!(settling.is_valid());
        let broken = [
            Rezero { rest_ms: REZERO_SETTLE_MS + 1, ..settled },
            Rezero { ticks: REZERO_WINDOW, ..settled },
            Rezero { sum: 4_095 * 99 + 1, ..settled },
            Rezero { windows: 6, ..settled },
            Rezero { next: 5, ..settled },
            Rezero { sums: [0, 0, WINDOW_SUM_MAX + 1, 0, 0], ..settled },
            Rezero { ticks: 1, sum: 0, windows: 0, ..settling },
            Rezero { windows: 1, ..settling },
            Rezero {
                bands: RezeroBands { agree: Volts::from_bits(-1), ..paper_bands() },
                ..settled
            },
        ];
        for (index, state) in broken.iter().enumerate() {
            assert!(!state.is_valid(), "clause {index}: {state:?}");
        }
        assert_eq!(WINDOW_SUM_MAX, 409_500);
    }

    #[test]
    fn the_drift_watch_is_past_twenty_five_millivolts_either_way() {
        let rule = Rezero::new(ZERO, paper_bands());
        let at = |mv: i32| Volts(ZERO.0.saturating_add(Volts::from_milli(mv).0));
        assert!(!rule.drifted(ZERO));
        assert!(!rule.drifted(at(25)) && !rule.drifted(at(-25)));
        assert!(rule.drifted(at(26)) && rule.drifted(at(-26)));
    }

    /// REQ-UI-12: the drift since calibration — a self-test that tared 20 mV from the zero the
    /// calibration was taken at (a drift across power cycles) sees the watch after 6 mV more,
    /// either way; without a known calibration zero only the self-test's counts.
    #[test]
    fn the_drift_watch_also_counts_from_the_calibrations_zero() {
        let rule = Rezero::new(ZERO, paper_bands());
        let at = |mv: i32| Volts(ZERO.0.saturating_add(Volts::from_milli(mv).0));
        let calibrated = Some(at(-20));
        assert!(!rule.drifted_since(ZERO, calibrated) && !rule.drifted_since(at(4), calibrated));
        assert!(rule.drifted_since(at(6), calibrated), "26 mV since the calibration");
        assert!(!rule.drifted_since(at(-4), calibrated), "within 25 mV of both");
        assert!(rule.drifted_since(at(-26), calibrated), "26 mV since the self-test");
        assert!(!rule.drifted_since(at(6), None) && rule.drifted_since(at(26), None));
        assert!(
            !rule.drifted_since(at(6), Some(at(6))) && rule.drifted_since(at(-26), Some(at(0)))
        );
    }

    #[test]
    fn a_string_held_in_the_gripper_is_refused_as_loaded() {
        let mut rule = Rezero::new(ZERO, paper_bands());
        // 0.1 kgf of string: ≈ 7.5 codes above the zero; steady.
        let verdicts = feed(&mut rule, 4_000, ZERO, |_| rest(49));
        assert!(verdicts.loaded > 10 && verdicts.loaded == verdicts.total(), "{verdicts:?}");
    }

    #[test]
    fn a_hand_pushing_the_gripper_is_refused_as_unsteady() {
        let mut rule = Rezero::new(ZERO, paper_bands());
        // A push wandering by 2 codes over 0.4 s, within the step.
        let verdicts = feed(&mut rule, 4_000, ZERO, |t| rest(41 + 2 * ((t / 200) % 2) as u16));
        assert!(verdicts.unsteady > 10 && verdicts.unsteady == verdicts.total(), "{verdicts:?}");
    }

    #[test]
    fn a_zero_walked_past_the_range_is_refused_and_one_within_it_accepted() {
        // The zero in use has followed the drift to 0.099 V; the reference is 0.05 V.
        let far = Volts(Q16::lit("0.1"));
        let mut rule = Rezero::new(ZERO, paper_bands());
        let verdicts = feed(&mut rule, 4_000, far, |_| rest(82)); // 0.1001 V
        assert!(verdicts.out_of_range > 10 && verdicts.out_of_range == verdicts.total());
        let near = Volts(Q16::lit("0.095"));
        let mut rule = Rezero::new(ZERO, paper_bands());
        let verdicts = feed(&mut rule, 4_000, near, |_| rest(78)); // 0.0952 V
        assert!(verdicts.zero > 10 && verdicts.zero == verdicts.total(), "{verdicts:?}");
    }

    #[test]
    fn a_key_a_moving_carriage_or_leaving_home_starts_the_rest_again() {
        let settle = u32::from(REZERO_SETTLE_MS);
        let breaks: [fn(RestSample) -> RestSample; 6] = [
            |s| RestSample { key: true, ..s },
            |s| RestSample { steps: s.steps + 1, ..s },
            |s| RestSample { home: false, ..s },
            |s| RestSample { end: true, ..s },
            |s| RestSample { code: AdcCode::new(0), ..s },
            |s| RestSample { code: AdcCode::MAX, ..s },
        ];
        for broken in breaks {
            let mut rule = Rezero::new(ZERO, paper_bands());
            // One broken tick before the second window completes: no verdict until a whole
            // new settling and two windows have passed (then one every window).
            let broken_at = settle + 150;
            let ticks = broken_at + 1 + settle + 600;
            let verdicts = feed(&mut rule, ticks, ZERO, |t| {
                if t == broken_at { broken(rest(41)) } else { rest(41) }
            });
            assert_eq!(verdicts.zero, 2, "{verdicts:?}");
            assert_eq!(verdicts.total(), 2, "{verdicts:?}");
            let mut rule = Rezero::new(ZERO, paper_bands());
            let verdicts = feed(&mut rule, ticks - 2, ZERO, |t| {
                if t == broken_at { broken(rest(41)) } else { rest(41) }
            });
            assert_eq!(verdicts.total(), 1, "{verdicts:?}");
            let mut rule = Rezero::new(ZERO, paper_bands());
            let verdicts = feed(&mut rule, broken_at + settle, ZERO, |t| {
                if t == broken_at { broken(rest(41)) } else { rest(41) }
            });
            assert_eq!(verdicts.total(), 0, "{verdicts:?}");
        }
    }

    /// On the paper's chain the bands in kgf are today's bands in volts to the Q15.16 bit:
    /// 1.5, 5, 50 and 25 mV.
    #[test]
    fn the_papers_bands_are_its_millivolts() {
        let bands = paper_bands();
        assert_eq!(bands.agree(), Volts(Q16::lit("0.0015")));
        assert_eq!(bands.step_max(), Volts(Q16::lit("0.005")));
        assert_eq!(bands.range(), Volts(Q16::lit("0.05")));
        assert_eq!(bands.drift_watch(), Volts(Q16::lit("0.025")));
        assert_eq!(Rezero::new(ZERO, bands).bands(), bands);
    }

    /// A second board, its chain divided by 0.656 before a 3.3 V converter, gets bands in
    /// volts that read as the same kgf through its own gain (to half a Q15.16 bit of volts),
    /// so its re-zero refuses the same held string and watches the same drift.
    #[test]
    fn a_divided_chain_gets_bands_that_mean_the_same_kgf() {
        let paper = crate::test_support::paper_board().load_cell();
        let divided = divided_scale();
        for scale in [paper, divided] {
            let bands = RezeroBands::for_scale(&scale);
            let gain = i64::from(scale.kgf_per_volt().to_bits());
            let pairs = [
                (bands.agree(), REZERO_AGREE),
                (bands.step_max(), REZERO_STEP_MAX),
                (bands.range(), REZERO_RANGE),
                (bands.drift_watch(), DRIFT_WATCH),
            ];
            for (band, kgf) in pairs {
                // band × k against the band's kgf, both ×2¹⁶ × 2¹⁶: within half a bit × k.
                let read = i64::from(band.to_bits()) * gain;
                let stated = i64::from(kgf.to_bits()) << 16;
                assert!(2 * (read - stated).abs() <= gain, "{band:?} for {kgf:?} on {scale:?}");
            }
        }
        let (ours, theirs) = (paper_bands(), RezeroBands::for_scale(&divided));
        // The divided board's bands are the paper's × 0.656: 0.98, 3.28, 32.8 and 16.4 mV.
        assert_eq!(theirs.agree().to_bits(), 64);
        assert_eq!(theirs.step_max().to_bits(), 215);
        assert_eq!(theirs.range().to_bits(), 2_150);
        assert_eq!(theirs.drift_watch().to_bits(), 1_075);
        assert!(ours.range() > theirs.range());
        // The drift watch, in codes of each board: 20 codes of zero drift is 0.265 kgf on the
        // paper's chain and 0.267 kgf on the divided one, 21 codes 0.279 and 0.280 kgf.
        for scale in [paper, divided] {
            let bands = RezeroBands::for_scale(&scale);
            let start = AdcCode::new(41);
            let rule = Rezero::new(scale.volts(start), bands);
            let drifted = |codes: u16| rule.drifted(scale.volts(AdcCode::new(41 + codes)));
            assert!(!drifted(20) && drifted(21), "{scale:?}");
        }
    }

    /// The same held string and the same still gripper on both boards: 0.1 kgf of string is
    /// refused as loaded, a zero 0.04 kgf from the one in use is taken.
    #[test]
    fn both_boards_refuse_the_same_held_string_and_take_the_same_small_step() {
        let paper = crate::test_support::paper_board().load_cell();
        for scale in [paper, divided_scale()] {
            let bands = RezeroBands::for_scale(&scale);
            let zero = scale.zero();
            let held = scale.to_code(Kgf(Q16::lit("0.1")));
            let near = scale.to_code(Kgf(Q16::lit("0.04")));
            for (code, loaded) in [(held, true), (near, false)] {
                let mut rule = Rezero::new(zero, bands);
                let verdicts = feed_on(&mut rule, 4_000, zero, scale.reference(), |_| RestSample {
                    code,
                    ..rest(0)
                });
                let expected = if loaded { verdicts.loaded } else { verdicts.zero };
                assert!(
                    expected > 10 && expected == verdicts.total(),
                    "{scale:?}, loaded {loaded}: {verdicts:?}"
                );
            }
        }
    }

    /// Every bound is inclusive to the bit: windows whose means spread by exactly the
    /// agreement band, a mean exactly the step from the zero in use and exactly the range from
    /// the self-test's are taken; one bit more of any is refused with its reason. The drift
    /// watch likewise: exactly its band from the self-test's or the calibration's zero is
    /// within it, a bit more is past it.
    #[test]
    fn every_band_is_inclusive_to_the_bit() {
        // One window of code 41 then four of 42: the windows' means spread 3 280 → 3 360 bits
        // (80 bits, one code), their mean is (4 100 + 4 × 4 200) / 500 codes = 3 344 bits.
        let mean = Volts::from_bits(3_344);
        let verdict = |bands: RezeroBands, reference: Volts, zero: Volts| {
            let mut rule = Rezero::new(reference, bands);
            let settle = u32::from(REZERO_SETTLE_MS);
            let window = u32::from(REZERO_WINDOW);
            let tally = feed(&mut rule, settle + 5 * window, zero, |t| {
                rest(if t < settle + window { 41 } else { 42 })
            });
            assert_eq!(tally.total(), 1, "{tally:?}");
            tally.last
        };
        let bits = Volts::from_bits;
        let below = |by: i32| bits(mean.to_bits() - by);
        let exact = RezeroBands {
            agree: bits(80),
            step_max: bits(100),
            range: bits(1_000),
            drift_watch: bits(500),
            drift_rate: bits(9),
        };
        let (reference, zero) = (below(1_000), below(100));
        assert_eq!(verdict(exact, reference, zero), Some(Retare::Zero(mean)));
        let tight = RezeroBands { agree: bits(79), ..exact };
        assert_eq!(verdict(tight, reference, zero), Some(Retare::Unsteady));
        assert_eq!(verdict(exact, reference, below(101)), Some(Retare::Loaded));
        assert_eq!(verdict(exact, below(1_001), zero), Some(Retare::OutOfRange));
        // The same bounds the other side of the mean.
        let above = |by: i32| bits(mean.to_bits() + by);
        assert_eq!(verdict(exact, above(1_000), above(100)), Some(Retare::Zero(mean)));
        assert_eq!(verdict(exact, above(1_000), above(101)), Some(Retare::Loaded));
        assert_eq!(verdict(exact, above(1_001), above(100)), Some(Retare::OutOfRange));

        let rule = Rezero::new(mean, exact);
        for side in [1, -1] {
            let at = |by: i32| bits(mean.to_bits() + side * by);
            assert!(!rule.drifted(at(500)) && rule.drifted(at(501)), "side {side}");
            let calibrated = Some(at(-400));
            assert!(!rule.drifted_since(at(100), calibrated), "side {side}");
            assert!(rule.drifted_since(at(101), calibrated), "side {side}");
        }
    }

    /// A board's bands are valid from zero to the widest converter's range, each band alone;
    /// every scale the load cell accepts gives valid bands, at both ends of its gains on the
    /// narrowest and widest converters.
    #[test]
    fn bands_are_valid_from_zero_to_the_widest_converter() {
        let paper = paper_bands();
        assert!(paper.is_valid());
        let just_over = Volts::from_bits(BAND_MAX.to_bits() + 1);
        let below_zero = Volts::from_bits(-1);
        let each = |band: Volts| -> [RezeroBands; 5] {
            [
                RezeroBands { agree: band, ..paper },
                RezeroBands { step_max: band, ..paper },
                RezeroBands { range: band, ..paper },
                RezeroBands { drift_watch: band, ..paper },
                RezeroBands { drift_rate: band, ..paper },
            ]
        };
        for bands in each(Volts::ZERO).into_iter().chain(each(BAND_MAX)) {
            assert!(bands.is_valid(), "{bands:?}");
        }
        for bands in each(below_zero).into_iter().chain(each(just_over)) {
            assert!(!bands.is_valid(), "{bands:?}");
        }
        for millivolts in [1_000, 3_300, 5_000, 5_500] {
            let Some(reference) = AdcReference::from_millivolts(millivolts) else {
                panic!("{millivolts} mV is a converter reference")
            };
            let (low, high) = LoadCellScale::gain_range(reference);
            for gain in [low, high] {
                let scale =
                    crate::test_support::valid(LoadCellScale::new(reference, Volts::ZERO, gain));
                let bands = RezeroBands::for_scale(&scale);
                assert!(bands.is_valid(), "{millivolts} mV, {gain}: {bands:?}");
                assert!(bands.range() <= Volts(Q16::lit("0.111")), "{bands:?}");
                assert!(bands.agree() > Volts::ZERO, "{bands:?}");
            }
        }
    }
}
