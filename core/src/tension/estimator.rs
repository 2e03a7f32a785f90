//! The tension the controller acts on: spike rejection, a Hall-fused tension observer, and
//! the tension rate and carriage speed the approach is timed by.
//!
//! # Theory of operation
//!
//! The load cell is read once per tick through a 12-bit converter: one code is ≈ 0.013 kgf,
//! white noise is 1–3 codes, and MOSFET switching throws spikes of 0.2–1 kgf into a few
//! per cent of the samples (the paper's figure 22). The carriage position, on the other
//! hand, is known without noise or lag to one Hall step (52.9 µm) from the drive's step
//! counter. [`TensionEstimator::update`] combines the two, every tick:
//!
//! 1. **Median**: before the string's stiffness is known (the take-up, where the carriage
//!    runs and every sample is new tension) the median of the last five samples removes
//!    isolated spikes (two ticks of delay on a ramp). Once the stiffness `K̂` is known the
//!    median is taken over the last [`WINDOW`] = 15 samples, each first **moved along the
//!    string** to where the carriage was two ticks ago, `y_i + K̂·(x_{t−2} − x_i)` (`x_i`
//!    the Hall position when `y_i` was taken): what the carriage's travel explains is taken
//!    out before the samples are compared, so the window adds no delay to it and keeps the
//!    median of five's two ticks on a ramp. A **burst** of up to [`BURST_MAX`] = 5
//!    consecutive spikes — a gate driver ringing across several conversions, which passes a
//!    median of five from three spikes on — is then a minority of the window, even with
//!    [`SPIKES_BESIDE`] = 2 single switching spikes of the same sign beside it (a few per
//!    cent of the samples carry one), and never moves the median past the string's own
//!    samples. The sizing: the amplifier's
//!    bandwidth is at least 100 Hz (a time constant ≤ 1.6 ms), so a change of the string's
//!    tension reaches the converter within two samples and stays; what the string does
//!    with the carriage still is creep and relaxation, well under 0.01 kgf per ms; so a
//!    jump of tenths of a kgf that is not in the Hall travel and is gone again within
//!    5 ms is not the string. A change the travel does not explain (creep, a clamp
//!    slipping, the amplifier's drift) reaches the median after 7 samples instead of 2;
//!    the string-break rule reads the raw samples and is not delayed by it.
//! 2. **Spike clip** (switchable): what is left of a burst is limited by physics — the
//!    string cannot change its tension faster than the stiffest string (2 kgf/mm) times the
//!    carriage's travel this tick, plus 0.1 kgf for noise and relaxation — so the filtered
//!    sample `y_f` moves toward the median by at most that much per tick.
//!    **Burst bridge** (the take-up at speed, [`TensionEstimator::set_burst_bridge`]): before the
//!    stiffness is known the median is of five, and a burst of three or more spikes passes
//!    it: the median jumps by tenths of a kgf or more, further than the clip's limit, which
//!    the string cannot do. Slewing toward it at the limit would take the burst in at
//!    ≈ 0.2 kgf a tick, and its rate with it — and the take-up times the braking by `ẏ·v`
//!    and identifies the string's stiffness as `ẏ/v`: a burst a few ticks before the braking
//!    point doubled or tripled the rate, braked early and identified the string two or three
//!    times stiffer than it is. With the bridge on, a median beyond the clip's limit is
//!    bridged: `y_f` goes on at its own rate (`ẏ·dt`, within the limit — in the take-up the
//!    string's `K·v`) for up to [`BURST_MAX`] consecutive ticks, as long as a burst lasts; a
//!    change that lasts longer is the string's, and `y_f` slews toward it at the limit.
//! 3. **Observer** (switchable): once the string's stiffness `K̂` is known (the controller
//!    identifies it during the take-up, [`TensionEstimator::set_stiffness`]), the estimate
//!    moves with the carriage at once, `ŷ ← ŷ + K̂·Δx`, and is pulled toward the measurement
//!    with gain `α`: a complementary filter whose fast part is the Hall position (no lag, no
//!    noise) and whose slow part (time constant `dt/α`, 20 ms for `α` = 0.05) is the load
//!    cell. The measurement is `lag` ticks old (conversion, the previous tick, the median's
//!    two ticks on a ramp), so it is compared with what the estimate was then,
//!    `ŷ − K̂·Δx_lag` (`Δx_lag` the Hall travel of the last `lag` ticks):
//!    `ŷ ← ŷ + α·(y_f − (ŷ − K̂·Δx_lag))` — otherwise a ramp would drag the estimate back by
//!    the lag. Before `K̂` is known (or when the controller withdraws it, `K̂ = 0`) the
//!    observer is a plain low-pass of `y_f`; without the observer `ŷ = y_f`.
//! 4. **Rate and speed**: first-order low-passes with the same time constant of the
//!    filtered sample's difference (`ẏ`, kgf/s) and of the Hall travel (`v`, mm/s). Filtered
//!    alike, they carry the same lag, so `ẏ/v` is the string's stiffness and `ẏ·v` times a
//!    constant is the tension a braking carriage still adds (see the controller).
//!
//! # Fixed point
//!
//! Tensions, rates and speeds are Q15.16 bits; the observer state is Q31.32 (`i64`) so a
//! gain of 0.05 keeps moving it below Q15.16's resolution. Per tick: five comparisons'
//! worth of median, at most seven 32 × 32 → 64-bit products (and, bridging a burst, the rate
//! times the Q0.32 period), no division.
//!
//! The hold's other estimate, the carriage's motion seen in the motor current, is
//! [`crate::tension::slip`]'s.

use crate::fixed::{filter_gain, mul_wide, narrow, saturate_i32};
use crate::mechanism::{MAX_STEPS_PER_TICK, STEP_MM_BITS};
use crate::settings::MmPerSecond;
use crate::tension::law::Coef;
use crate::units::{Kgf, KgfPerSecond, Q16, Seconds};

/// The stiffest string the spike clip allows for, 2 kgf/mm (the twin's stiffest is
/// 1.5 kgf/mm), Q15.16.
pub const CLIP_STIFFNESS: Q16 = Q16::const_from_int(2);

/// What a still carriage's tension may do in one tick besides moving with the string:
/// noise and relaxation, 0.1 kgf.
pub const CLIP_ALLOWANCE: Kgf = Kgf(Q16::lit("0.1"));

/// The longest burst of consecutive spikes the median rejects whole once the string's
/// stiffness is known: 5 samples (see the module docs).
pub const BURST_MAX: usize = 5;

/// Single switching spikes (a few per cent of the samples, either sign) the window allows
/// for besides a burst: 2.
pub const SPIKES_BESIDE: usize = 2;

/// The median's rank in its window: the number of samples that may be outliers on one side,
/// `BURST_MAX + SPIKES_BESIDE` = 7.
pub const MEDIAN_RANK: usize = BURST_MAX + SPIKES_BESIDE;

/// The median's window once the stiffness is known: `2·MEDIAN_RANK + 1` = 15 samples, so a
/// burst of up to [`BURST_MAX`] spikes with [`SPIKES_BESIDE`] single spikes of the same sign
/// beside it is always a minority.
pub const WINDOW: usize = 2 * MEDIAN_RANK + 1;

/// The largest stiffness the observer accepts, kgf/mm (Q15.16): 4 kgf/mm.
pub const STIFFNESS_MAX: Q16 = Q16::const_from_int(4);

/// How the estimate is formed (each part switchable, for the ablation report).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct EstimatorConfig {
    /// Limit each tick's change of the filtered sample by the carriage's travel.
    pub spike_clip: bool,
    /// The observer's correction gain `α` per tick (`None`: no observer, `ŷ = y_f`).
    pub observer_gain: Option<Q16>,
    /// Time constant of the rate and speed low-passes.
    pub rate_filter: Seconds,
    /// The age of a load-cell sample when it is used, ticks (at most [`LAG_TICKS_MAX`]).
    pub lag_ticks: u8,
}

/// The longest sensing lag the observer compensates, ticks.
pub const LAG_TICKS_MAX: usize = 4;

/// One tick's estimate.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct Estimate {
    /// The observer's tension `ŷ` (= the filtered sample without the observer): what the
    /// law regulates and the machine displays.
    pub tension: Kgf,
    /// The spike-filtered sample `y_f` (median, then clip; bridged over a burst in the
    /// take-up).
    pub sample: Kgf,
    /// The median moved toward by the clip alone, from the last `y_f` (= `sample` whenever no
    /// burst is bridged): what the carriage's load-cell reading does, for the take-up's gripper
    /// identification — a heavy gripper's inertial step is a real reading, not a burst.
    pub clipped: Kgf,
    /// The low-passed rate of `y_f`, kgf/s.
    pub rate: KgfPerSecond,
    /// The low-passed carriage speed from Hall steps, mm/s.
    pub speed: MmPerSecond,
    /// Hall steps since the previous tick (clamped to ±[`MAX_STEPS_PER_TICK`]).
    pub steps: i32,
}

/// The estimator's memory (public for proofs and fuzzing, which draw it whole;
/// [`TensionEstimator::is_valid`] states which values are reachable).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
#[cfg_attr(kani, derive(kani::Arbitrary))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct EstimatorState {
    /// The last [`WINDOW`] raw samples, kgf bits, oldest first.
    pub window: [i32; WINDOW],
    /// The drive's Hall step count when each of them was taken, oldest first.
    pub window_steps: [i32; WINDOW],
    /// The filtered sample `y_f`, kgf bits.
    pub filtered: i32,
    /// The observer's tension `ŷ`, kgf in Q31.32.
    pub fused: i64,
    /// The rate low-pass, kgf/s bits.
    pub rate: i32,
    /// The speed low-pass, mm/s bits.
    pub speed: i32,
    /// The step count at the previous tick.
    pub last_steps: i32,
    /// Whether the next update continues (`true`) or restarts from its sample (`false`).
    pub primed: bool,
    /// The observer's stiffness `K̂`, kgf/mm bits (0: not yet known, no Hall correction).
    pub stiffness: i32,
    /// Hall steps moved in each of the last [`LAG_TICKS_MAX`] ticks, newest last.
    pub recent: [i32; LAG_TICKS_MAX],
    /// Consecutive ticks the filtered sample has bridged a median beyond the clip's limit
    /// (see the module docs; at most [`BURST_MAX`] count).
    pub bridged: u8,
}

/// An unprimed, zero state.
const STATE_ZERO: EstimatorState = EstimatorState {
    window: [0; WINDOW],
    window_steps: [0; WINDOW],
    filtered: 0,
    fused: 0,
    rate: 0,
    speed: 0,
    last_steps: 0,
    primed: false,
    stiffness: 0,
    recent: [0; LAG_TICKS_MAX],
    bridged: 0,
};

/// The estimator: validated gains plus state. See the module docs.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct TensionEstimator {
    clip: bool,
    /// `α`, Q15.16 bits (`None` in the config → no observer).
    alpha: Option<Coef>,
    /// The configured `α`, restored by [`TensionEstimator::reset`].
    alpha_config: Option<Coef>,
    /// `dt/(τ + dt)` of the rate and speed low-passes, Q15.16 bits.
    beta: Coef,
    /// `1/dt`, Hz.
    inv_dt: i32,
    /// `dt`, s, Q0.32 (the burst bridge's `ẏ·dt`).
    dt_q32: i64,
    /// Bridge a median beyond the clip's limit (see the module docs).
    bridge: bool,
    /// The sensing lag, ticks (≤ [`LAG_TICKS_MAX`]).
    lag: u8,
    state: EstimatorState,
}

/// Why an estimator configuration was rejected.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum EstimatorError {
    /// The period is zero or above one second.
    Period,
    /// `α` is not in `(0, 1]`, the rate time constant is negative, or the lag is longer
    /// than [`LAG_TICKS_MAX`].
    Gain,
}

/// `median(e, max(min(a,b), min(c,d)), min(max(a,b), max(c,d)))`: the median of five.
#[must_use]
pub fn median5(a: i32, b: i32, c: i32, d: i32, e: i32) -> i32 {
    let f = a.min(b).max(c.min(d));
    let g = a.max(b).min(c.max(d));
    e.min(f).max(e.max(f).min(g))
}

/// The median of [`WINDOW`] values: the one with at most [`MEDIAN_RANK`] values below it
/// and more than [`MEDIAN_RANK`] at or below it (225 comparisons, a constant bound, no
/// indexing).
#[must_use]
pub fn median_window(v: &[i32; WINDOW]) -> i32 {
    let mut median = 0;
    for &x in v {
        let (mut below, mut at) = (0_usize, 0_usize);
        for &y in v {
            if y < x {
                below = below.saturating_add(1);
            } else if y == x {
                at = at.saturating_add(1);
            }
        }
        if below <= MEDIAN_RANK && below.saturating_add(at) > MEDIAN_RANK {
            median = x;
        }
    }
    median
}

/// `window` less its oldest value, with `newest` after its newest.
fn shifted(window: &[i32; WINDOW], newest: i32) -> [i32; WINDOW] {
    let mut next = [newest; WINDOW];
    for (to, from) in next.iter_mut().zip(window.iter().skip(1)) {
        *to = *from;
    }
    next
}

/// The burst-proof median (see the module docs): each sample of `window` moved along a
/// string of stiffness `stiffness` (kgf/mm bits) from the Hall count it was taken at,
/// `steps`, to the count two ticks ago, then the median of the [`WINDOW`].
#[must_use]
pub fn moved_median(window: &[i32; WINDOW], steps: &[i32; WINDOW], stiffness: i32) -> i32 {
    let [.., reference, _, _] = *steps;
    let mut moved = [0_i32; WINDOW];
    for ((out, &sample), &at) in moved.iter_mut().zip(window).zip(steps) {
        let travel = reference.wrapping_sub(at).saturating_mul(STEP_MM_BITS);
        *out = sample.saturating_add(narrow(mul_wide(stiffness, travel)));
    }
    median_window(&moved)
}

impl TensionEstimator {
    /// An estimator without spike clip or observer at 1 kHz (the controller's fallback).
    pub(crate) const FALLBACK: Self = Self {
        clip: false,
        alpha: None,
        alpha_config: None,
        beta: 1 << 12,
        inv_dt: 1_000,
        dt_q32: 4_294_967,
        bridge: false,
        lag: 0,
        state: STATE_ZERO,
    };

    /// An estimator for a tick of `period_us` µs.
    ///
    /// # Errors
    /// [`EstimatorError`] for a zero period or an out-of-range gain.
    // Always inlined: from a constant configuration (the firmware's) the whole construction
    // folds to its result at compile time, so the image carries no constructor
    // (`scripts/firmware-size` checks).
    #[inline(always)]
    pub fn new(config: &EstimatorConfig, period_us: u32) -> Result<Self, EstimatorError> {
        if period_us == 0 || period_us > 1_000_000 {
            return Err(EstimatorError::Period);
        }
        let alpha = match config.observer_gain {
            None => None,
            Some(alpha) if alpha > Q16::ZERO && alpha <= Q16::ONE => Some(alpha.to_bits()),
            Some(_) => return Err(EstimatorError::Gain),
        };
        if config.rate_filter.0 < Q16::ZERO || usize::from(config.lag_ticks) > LAG_TICKS_MAX {
            return Err(EstimatorError::Gain);
        }
        let beta = filter_gain(period_us, config.rate_filter).ok_or(EstimatorError::Gain)?;
        let inv_dt = i32::try_from(1_000_000_u32.checked_div(period_us).unwrap_or(1))
            .map_err(|_| EstimatorError::Period)?;
        Ok(Self {
            clip: config.spike_clip,
            alpha,
            alpha_config: alpha,
            beta,
            inv_dt,
            dt_q32: (i64::from(period_us) << 32).checked_div(1_000_000).unwrap_or(0),
            bridge: false,
            lag: config.lag_ticks,
            state: EstimatorState::default(),
        })
    }

    /// Forgets the history: the next update restarts from its sample, with no stiffness and
    /// the configured observer gain.
    pub fn reset(&mut self) {
        self.state.primed = false;
        self.state.stiffness = 0;
        self.alpha = self.alpha_config;
    }

    /// Switches the burst bridge (see the module docs) on or off: on while the carriage runs
    /// into the string at its take-up speed, where the filtered sample's rate is the
    /// string's; off (the default) for a still carriage, whose clip alone bounds a burst.
    pub fn set_burst_bridge(&mut self, on: bool) {
        self.bridge = on;
    }

    /// Sets the observer's stiffness `K̂` (kgf/mm), clamped to `[0, STIFFNESS_MAX]`.
    pub fn set_stiffness(&mut self, stiffness: Q16) {
        self.state.stiffness = stiffness.clamp(Q16::ZERO, STIFFNESS_MAX).to_bits();
    }

    /// The observer's gain `α` now (`None`: no observer).
    #[must_use]
    pub fn observer_gain(&self) -> Option<Q16> {
        self.alpha.map(Q16::from_bits)
    }

    /// Changes the observer's gain `α` (clamped to `(0, 1]`); no effect without the
    /// observer.
    pub fn set_observer_gain(&mut self, alpha: Q16) {
        if self.alpha.is_some() {
            self.alpha = Some(alpha.clamp(Q16::DELTA, Q16::ONE).to_bits());
        }
    }

    /// Moves the observer's tension to `tension` (the controller's lag-compensated value
    /// when the braking starts).
    pub fn set_tension(&mut self, tension: Kgf) {
        self.state.fused = i64::from(tension.to_bits()) << 16;
    }

    /// The memory (proofs, fuzzing).
    #[must_use]
    pub const fn state(&self) -> EstimatorState {
        self.state
    }

    /// Replaces the memory (proofs, fuzzing); the guarantees hold for states that satisfy
    /// [`TensionEstimator::is_valid`].
    pub fn set_state(&mut self, state: EstimatorState) {
        self.state = state;
    }

    /// The invariant: the stiffness within `[0, STIFFNESS_MAX]`, the bridged ticks within
    /// [`BURST_MAX`].
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.state.stiffness >= 0
            && self.state.stiffness <= STIFFNESS_MAX.to_bits()
            && usize::from(self.state.bridged) <= BURST_MAX
    }

    /// The tension in Q15.16, rounded from the observer's Q31.32.
    fn fused_kgf(&self) -> Kgf {
        Kgf::from_bits(saturate_i32(self.state.fused.saturating_add(1 << 15) >> 16))
    }

    /// One tick: the calibrated tension sample and the drive's Hall step count in, the
    /// estimate out (see the module docs).
    pub fn update(&mut self, sample: Kgf, steps: i32) -> Estimate {
        let raw = sample.to_bits();
        let s = &mut self.state;
        if !s.primed {
            *s = EstimatorState {
                window: [raw; WINDOW],
                window_steps: [steps; WINDOW],
                filtered: raw,
                fused: i64::from(raw) << 16,
                rate: 0,
                speed: 0,
                last_steps: steps,
                primed: true,
                stiffness: s.stiffness,
                recent: [0; LAG_TICKS_MAX],
                bridged: 0,
            };
        }
        let moved = steps
            .wrapping_sub(s.last_steps)
            .clamp(MAX_STEPS_PER_TICK.saturating_neg(), MAX_STEPS_PER_TICK);
        s.last_steps = steps;
        let [_, r1, r2, r3] = s.recent;
        s.recent = [r1, r2, r3, moved];
        s.window = shifted(&s.window, raw);
        s.window_steps = shifted(&s.window_steps, steps);
        let median = if s.stiffness > 0 {
            moved_median(&s.window, &s.window_steps, s.stiffness)
        } else {
            let [.., w1, w2, w3, w4, w5] = s.window;
            median5(w1, w2, w3, w4, w5)
        };

        // Spike clip: |Δy_f| ≤ 2 kgf/mm · |Δx| + 0.1 kgf; with the bridge on, a median beyond
        // that is a burst, bridged at the filtered rate for up to BURST_MAX ticks.
        let previous = s.filtered;
        let travel = moved.saturating_abs().saturating_mul(STEP_MM_BITS);
        let mut clipped = median;
        s.filtered = if self.clip {
            let limit = narrow(mul_wide(CLIP_STIFFNESS.to_bits(), travel))
                .saturating_add(CLIP_ALLOWANCE.to_bits());
            let jump = median.saturating_sub(previous);
            clipped = previous.saturating_add(jump.clamp(limit.saturating_neg(), limit));
            let beyond = jump < limit.saturating_neg() || jump > limit;
            let burst_max = u8::try_from(BURST_MAX).unwrap_or(u8::MAX);
            let bridging = self.bridge && beyond && s.bridged < burst_max;
            // The count restarts only once the median is back within the limit: a change
            // that outlasts the bridge is slewed toward to the end.
            s.bridged =
                if self.bridge && beyond { s.bridged.saturating_add(1).min(burst_max) } else { 0 };
            let change = if bridging {
                // ẏ·dt: the rate (kgf/s bits) times the period (Q0.32 s).
                narrow(i64::from(s.rate).saturating_mul(self.dt_q32) >> 16)
            } else {
                jump
            };
            previous.saturating_add(change.clamp(limit.saturating_neg(), limit))
        } else {
            median
        };

        // Observer: ŷ ← ŷ + K̂·Δx, then ŷ ← ŷ + α·(y_f − (ŷ − K̂·Δx_lag)).
        s.fused = match self.alpha {
            Some(alpha) => {
                let dx = moved.saturating_mul(STEP_MM_BITS);
                let predicted = s.fused.saturating_add(mul_wide(s.stiffness, dx));
                // The travel of the last `lag` ticks (constant bound: LAG_TICKS_MAX).
                let mut lag_steps = 0_i32;
                for (age, steps) in s.recent.iter().rev().enumerate() {
                    if age < usize::from(self.lag) {
                        lag_steps = lag_steps.saturating_add(*steps);
                    }
                }
                let lag_travel = lag_steps.saturating_mul(STEP_MM_BITS);
                let then = predicted.saturating_sub(mul_wide(s.stiffness, lag_travel));
                let gap = (i64::from(s.filtered) << 16).saturating_sub(then);
                // gap (Q31.32) × α (Q15.16): split to stay in 64 bits.
                let correction = (gap >> 16).saturating_mul(i64::from(alpha));
                predicted.saturating_add(correction)
            }
            None => i64::from(s.filtered) << 16,
        };

        // Rate and speed low-passes.
        let raw_rate = saturate_i32(
            i64::from(s.filtered)
                .saturating_sub(i64::from(previous))
                .saturating_mul(i64::from(self.inv_dt)),
        );
        let raw_speed = saturate_i32(
            i64::from(moved.saturating_mul(STEP_MM_BITS)).saturating_mul(i64::from(self.inv_dt)),
        );
        let step_rate = narrow(
            i64::from(raw_rate)
                .saturating_sub(i64::from(s.rate))
                .saturating_mul(i64::from(self.beta)),
        );
        let step_speed = narrow(
            i64::from(raw_speed)
                .saturating_sub(i64::from(s.speed))
                .saturating_mul(i64::from(self.beta)),
        );
        s.rate = s.rate.saturating_add(step_rate);
        s.speed = s.speed.saturating_add(step_speed);
        let (filtered, rate, speed) = (s.filtered, s.rate, s.speed);
        Estimate {
            tension: self.fused_kgf(),
            sample: Kgf::from_bits(filtered),
            clipped: Kgf::from_bits(clipped),
            rate: KgfPerSecond::from_bits(rate),
            speed: MmPerSecond(Q16::from_bits(speed)),
            steps: moved,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::valid;

    fn estimator(clip: bool, observer: bool) -> TensionEstimator {
        valid(TensionEstimator::new(
            &EstimatorConfig {
                spike_clip: clip,
                observer_gain: observer.then_some(Q16::lit("0.05")),
                rate_filter: Seconds::from_milli(16),
                lag_ticks: 3,
            },
            1_000,
        ))
    }

    #[test]
    fn median5_is_the_median_of_every_pattern() {
        // Every ordering pattern of five values drawn from 0..5 (3 125 cases).
        let mut cases = 0;
        for n in 0..3_125_i32 {
            let v = [n % 5, n / 5 % 5, n / 25 % 5, n / 125 % 5, n / 625 % 5];
            let mut sorted = v;
            sorted.sort_unstable();
            assert_eq!(median5(v[0], v[1], v[2], v[3], v[4]), sorted[2], "{v:?}");
            cases += 1;
        }
        assert_eq!(cases, 3_125);
    }

    #[test]
    fn median_window_is_the_median_of_every_pattern() {
        // Sampled orderings of fifteen values with ties (0..4) and without: the middle of the
        // sorted eleven.
        let mut seed = 0x2545_f491_u32;
        for case in 0..20_000 {
            let mut v = [0_i32; WINDOW];
            for x in &mut v {
                seed ^= seed << 13;
                seed ^= seed >> 17;
                seed ^= seed << 5;
                let span = if case % 2 == 0 { 4 } else { 1_000 };
                *x = i32::try_from(seed % span).unwrap() - 2;
            }
            let mut sorted = v;
            sorted.sort_unstable();
            assert_eq!(median_window(&v), sorted[MEDIAN_RANK], "{v:?}");
        }
        assert_eq!(median_window(&[i32::MIN; WINDOW]), i32::MIN);
        assert_eq!(median_window(&[7; WINDOW]), 7);
    }

    /// An estimator with the stiffness `k` kgf/mm known, primed at `base` and step 0.
    fn known_stiffness(k: Q16, base: Kgf) -> TensionEstimator {
        let mut est = estimator(true, true);
        est.set_stiffness(k);
        est.update(base, 0);
        est
    }

    #[test]
    fn a_burst_of_up_to_five_never_moves_the_filtered_sample_once_the_stiffness_is_known() {
        let base = Kgf::from_int(25);
        for len in 1..=BURST_MAX {
            for sign in [1, -1] {
                let mut est = known_stiffness(Q16::ONE, base);
                for _ in 0..20 {
                    est.update(base, 0);
                }
                let spike = Kgf::from_int(6 * sign);
                for tick in 0..30 {
                    let sample = if tick < len { base.saturating_add(spike) } else { base };
                    let out = est.update(sample, 0);
                    assert_eq!(out.sample, base, "burst of {len} ({sign}), tick {tick}");
                    assert_eq!(out.tension, base, "burst of {len} ({sign}), tick {tick}");
                }
            }
        }
        // With two single spikes beside it, still nothing.
        let mut est = known_stiffness(Q16::ONE, base);
        for tick in 0..40 {
            let spiked = matches!(tick, 3 | 5..=9 | 11);
            let sample = if spiked { base.saturating_add(Kgf::from_int(6)) } else { base };
            assert_eq!(est.update(sample, 0).sample, base, "tick {tick}");
        }
        // Eight in a row are a majority of the window: a step of the string, followed.
        let mut est = known_stiffness(Q16::ONE, base);
        let mut last = Estimate::default();
        for _ in 0..MEDIAN_RANK {
            last = est.update(base.saturating_add(Kgf::from_int(6)), 0);
        }
        assert_eq!(last.sample, base, "seven are not");
        last = est.update(base.saturating_add(Kgf::from_int(6)), 0);
        assert!(last.sample > base, "{last:?}");
        // Before the stiffness is known the median is of five: three spikes pass (clipped).
        let mut est = estimator(true, false);
        est.update(base, 0);
        let mut worst = Kgf::ZERO;
        for tick in 0..10 {
            let sample = if tick < 3 { base.saturating_add(Kgf::from_int(6)) } else { base };
            worst = worst.max(est.update(sample, 0).sample.saturating_sub(base));
        }
        assert!(worst > Kgf::ZERO, "{worst:?}");
    }

    #[test]
    fn the_moved_window_adds_no_delay_to_what_the_carriage_travel_explains() {
        // A 1 kgf/mm string pulled by one Hall step per tick, each sample one tick late: the
        // filtered sample trails the truth by three ticks of travel, as with the median of
        // five (conversion, then the median's two), not by the window's six.
        let step_kgf = STEP_MM_BITS;
        let truth = |tick: i32| Kgf::from_bits(10 * 65_536 + tick.max(0) * step_kgf);
        let mut est = known_stiffness(Q16::ONE, truth(0));
        let mut out = Estimate::default();
        for tick in 1..100 {
            out = est.update(truth(tick - 1), tick);
        }
        let behind = truth(99).saturating_sub(out.sample).to_bits();
        assert!((behind - 3 * step_kgf).abs() <= 2, "{behind} bits behind");
        // A burst on the ramp moves it no more than a tick's travel.
        let mut spiked = Estimate::default();
        for tick in 100..140 {
            let sample = if (110..115).contains(&tick) {
                truth(tick - 1).saturating_add(Kgf::from_int(3))
            } else {
                truth(tick - 1)
            };
            spiked = est.update(sample, tick);
            let off = spiked.sample.saturating_sub(truth(tick - 4)).to_bits().abs();
            assert!(off <= step_kgf, "tick {tick}: {off} bits");
        }
        assert!((truth(139).saturating_sub(spiked.sample).to_bits() - 3 * step_kgf).abs() <= 2);
    }

    #[test]
    fn a_still_carriage_clips_what_the_median_lets_through() {
        let mut est = estimator(true, false);
        let base = Kgf::from_int(20);
        est.update(base, 0);
        // Three spikes of +1 kgf in five samples get through the median …
        let spiky = [0, 1, 1, 0, 1, 0, 0, 0];
        let mut worst = Kgf::ZERO;
        for &spike in &spiky {
            let sample = base.saturating_add(Kgf::from_int(spike));
            let out = est.update(sample, 0);
            worst = worst.max(out.sample.saturating_sub(base));
        }
        // … but a still carriage's filtered sample moves at most 0.1 kgf per tick.
        assert!(worst <= CLIP_ALLOWANCE.saturating_add(CLIP_ALLOWANCE), "{worst:?}");
        let mut unclipped = estimator(false, false);
        unclipped.update(base, 0);
        let mut worst_unclipped = Kgf::ZERO;
        for &spike in &spiky {
            let out = unclipped.update(base.saturating_add(Kgf::from_int(spike)), 0);
            worst_unclipped = worst_unclipped.max(out.sample.saturating_sub(base));
        }
        assert_eq!(worst_unclipped, Kgf::from_int(1));
    }

    #[test]
    fn rate_and_speed_share_their_lag_so_their_ratio_is_the_stiffness() {
        // A 0.7 kgf/mm string pulled at one Hall step per tick (52.9 mm/s): 37 kgf/s.
        let mut est = estimator(true, false);
        let mut out = Estimate::default();
        for tick in 0..200_i32 {
            let mm_q16 = i64::from(tick) * i64::from(STEP_MM_BITS);
            let tension = Kgf::from_bits(valid(i32::try_from(mm_q16 * 7 / 10)));
            out = est.update(tension, tick);
        }
        let speed = out.speed.0.to_num::<i32>();
        let rate = out.rate.0.to_num::<i32>();
        assert!((speed - 53).abs() <= 1, "{speed}");
        assert!((rate - 37).abs() <= 1, "{rate}");
    }

    /// A 0.3 kgf/mm string pulled at one Hall step per tick (16 kgf/s, the take-up), with a
    /// burst of `len` spikes of `spike` kgf from tick 150: the filtered sample and its rate
    /// at their worst against the ramp's, over the 30 ticks from the burst on, with the
    /// burst bridge `on` or off.
    fn burst_on_a_ramp(on: bool, len: i32, spike: i16) -> (i32, i32) {
        let mut est = estimator(true, false);
        est.set_burst_bridge(on);
        let ramp = |tick: i32| {
            let mm_q16 = i64::from(tick) * i64::from(STEP_MM_BITS);
            Kgf::from_bits(valid(i32::try_from(mm_q16 * 3 / 10)))
        };
        let (mut worst_sample, mut worst_rate) = (0, 0);
        for tick in 0..180_i32 {
            let burst = (150..150 + len).contains(&tick);
            let extra = if burst { Kgf::from_int(spike) } else { Kgf::ZERO };
            let out = est.update(ramp(tick).saturating_add(extra), tick);
            if tick >= 150 {
                // The filtered sample is the median's: two ticks old on the ramp.
                let error = out.sample.saturating_sub(ramp(tick - 2)).to_bits().abs();
                worst_sample = worst_sample.max(error);
                let rate = (out.rate.to_bits() - Kgf::from_int(16).to_bits()).abs();
                worst_rate = worst_rate.max(rate);
            }
        }
        (worst_sample, worst_rate)
    }

    #[test]
    fn a_change_of_exactly_the_clips_limit_is_followed_and_a_larger_one_bridged() {
        // A still carriage: the limit is the allowance alone; up and down.
        for sign in [1, -1] {
            for (over, bridged) in [(0, false), (1, true)] {
                let mut est = estimator(true, false);
                est.set_burst_bridge(true);
                let base = Kgf::from_int(10);
                est.update(base, 0);
                let change = sign * (CLIP_ALLOWANCE.to_bits() + over);
                let step = Kgf::from_bits(base.to_bits() + change);
                let mut out = Estimate::default();
                // The median of five takes the step on the third sample.
                for _ in 0..3 {
                    out = est.update(step, 0);
                }
                let moved = sign * out.sample.saturating_sub(base).to_bits();
                let clipped = sign * out.clipped.saturating_sub(base).to_bits();
                if bridged {
                    assert!(moved < CLIP_ALLOWANCE.to_bits(), "bridged {sign}: {moved}");
                    // The clip alone still moves toward the reading (the gripper's
                    // identification reads it).
                    assert_eq!(clipped, CLIP_ALLOWANCE.to_bits(), "{sign}");
                } else {
                    assert_eq!(moved, CLIP_ALLOWANCE.to_bits(), "followed {sign}");
                    assert_eq!(out.clipped, out.sample);
                }
            }
        }
    }

    #[test]
    fn the_invariant_bounds_the_stiffness_and_the_bridged_ticks() {
        let mut est = estimator(true, true);
        let valid_state =
            EstimatorState { bridged: 5, stiffness: STIFFNESS_MAX.to_bits(), ..est.state() };
        est.set_state(valid_state);
        assert!(est.is_valid());
        est.set_state(EstimatorState { bridged: 6, ..valid_state });
        assert!(!est.is_valid(), "six bridged ticks");
        est.set_state(EstimatorState { stiffness: -1, ..valid_state });
        assert!(!est.is_valid(), "a negative stiffness");
        est.set_state(EstimatorState { stiffness: STIFFNESS_MAX.to_bits() + 1, ..valid_state });
        assert!(!est.is_valid(), "past the largest stiffness");
    }

    #[test]
    fn the_take_up_bridges_a_burst_that_passes_the_median_of_five() {
        let hundredth = Kgf(Q16::lit("0.01")).to_bits();
        for len in 3..=i32::try_from(BURST_MAX).unwrap() {
            for spike in [-4, 4] {
                // Off: the burst reaches the filtered sample and its rate.
                let (sample, rate) = burst_on_a_ramp(false, len, spike);
                assert!(sample > 20 * hundredth, "off, {len} × {spike}: {sample}");
                assert!(rate > Kgf::from_int(10).to_bits(), "off, {len} × {spike}: {rate}");
                // On: the ramp goes on at its own rate.
                let (sample, rate) = burst_on_a_ramp(true, len, spike);
                assert!(sample <= 5 * hundredth, "on, {len} × {spike}: {sample}");
                assert!(rate <= Kgf::from_int(2).to_bits(), "on, {len} × {spike}: {rate}");
            }
        }
        // A change that outlasts any burst is the string's: followed.
        let mut est = estimator(true, false);
        est.set_burst_bridge(true);
        let base = Kgf::from_int(10);
        est.update(base, 0);
        let step = base.saturating_add(Kgf::from_int(1));
        let mut last = Estimate::default();
        for _ in 0..30 {
            last = est.update(step, 0);
        }
        assert_eq!(last.sample, step);
    }

    #[test]
    fn the_observer_is_not_dragged_back_by_the_sensing_lag_on_a_ramp() {
        // A 1 kgf/mm string pulled at one step per tick, the load-cell sample one tick late
        // and the median two more on a ramp — three in all: the estimate follows the true
        // tension, not the late sample.
        let mut est = estimator(true, true);
        est.update(Kgf::from_int(10), 0);
        est.set_stiffness(Q16::ONE);
        let step_kgf = i64::from(STEP_MM_BITS); // 1 kgf/mm × one step, in kgf bits
        let mut out = Estimate::default();
        for tick in 1..300_i64 {
            let late = (tick - 1).max(0) * step_kgf;
            let sample = Kgf::from_bits(valid(i32::try_from((10 << 16) + late)));
            out = est.update(sample, valid(i32::try_from(tick)));
        }
        let truth = (10_i64 << 16) + 299 * step_kgf;
        let off = i64::from(out.tension.to_bits()) - truth;
        assert!(off.abs() <= 70, "{off} bits"); // within 1 mkgf
    }

    #[test]
    fn the_observer_follows_the_hall_travel_at_once() {
        let mut est = estimator(true, true);
        est.update(Kgf::from_int(10), 0);
        est.set_stiffness(Q16::ONE);
        // Ten steps in one tick at 1 kgf/mm: +0.529 kgf at once, before the load cell moves
        // (and the load cell is not expected to show it for another three ticks).
        let out = est.update(Kgf::from_int(10), 10);
        let gained = out.tension.saturating_sub(Kgf::from_int(10)).to_milli();
        assert!((gained - 529).abs() <= 1, "{gained}");
        // With the load cell catching up three ticks later, the estimate stays there.
        let mut last = out;
        for _ in 0..100 {
            last = est.update(Kgf::from_milli(10_529), 10);
        }
        assert!((last.tension.to_milli() - 10_529).abs() <= 1, "{:?}", last.tension);
    }
}
