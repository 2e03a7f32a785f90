//! The string itself: its stiffness near the set tension and its creep during the hold,
//! estimated from the pull the machine makes anyway — what no stringing machine shows.
//!
//! # Theory of operation
//!
//! **Stiffness.** While the carriage takes up the string at its cruising speed the tension
//! rises along the string's load line. [`StringProbe::pulling`] notes the Hall count and the
//! tension the first time the tension reaches half the pull's final target ([`LOWER_SHARE`])
//! and again at three quarters ([`UPPER_SHARE`]); the stiffness is the tension gained over the
//! carriage travel between them, `K = ΔT / (Δsteps · 52.917 µm)`, kgf per mm of carriage
//! travel. The tension is the machine's ≈ 64 ms running average (median of three, then a
//! first-order average: a switching spike never lands on a probe point), and the Hall count
//! goes through *the same* filter. A linear filter commutes with the load line `T = K·x + c`,
//! so the two averages stay on it whatever the carriage's speed does — accelerating, or the
//! average still settling after the string went taut (on a stiff string at full speed the
//! lower point comes ≈ 0.13 s after it, inside the average's settling: with the raw count
//! that lag difference read 7 % too stiff). The points sit below the
//! braking onset on every string (the braking adds at most `K·v²/(2a)` ≈ 3.4 kgf on the
//! stiffest string at full speed, 14 % of 25 kgf) and above the string's straightening toe,
//! so the line between them is the string's own. A string pulled at a finite speed shows a
//! few per cent less than its instantaneous stiffness `E·A/L` (its fastest relaxation arm
//! gives way during the pull): that is the stiffness the racket will feel at stringing
//! speed, and within the 10 % the estimate is held to.
//!
//! **Creep.** Holding at constant pull, the controller keeps the tension constant while the
//! string relaxes, so the carriage creeps forward: for a string of stiffness `K` the tension
//! it would have lost at constant length is `K·ẋ` (with relaxation arms `aᵢ` of time
//! constants `τᵢ`, `dT/dt = K·ẋ − Σ aᵢ/τᵢ = 0` in a hold, so `K·ẋ = Σ aᵢ/τᵢ` exactly). The
//! probe opens a window [`CREEP_SETTLE_MS`] after the hold began — the reference's closure
//! and the fastest relaxation are over by then — closes it [`CREEP_WINDOW_MS`] later, and
//! turns the travel in it into the creep rate: `100 · K · Δx / (T · Δt)`, per cent of the
//! held tension per minute. The window is fixed because a string's relaxation slows through
//! the hold (its arms decay one after another): a rate over "the whole hold" would read
//! several times higher for a short hold than for a long one, and two pulls could not be
//! compared. A hold released before the window closes logs no creep (a few Hall steps are
//! no measure), and any change of the hold (an adjustment, constant pull off or on)
//! restarts the window.
//!
//! Both are integer arithmetic on the Hall count and the tension, saturating, in a few
//! operations per tick at most; the results are logged per pull ([`super::PullRecord`]).

use core::num::NonZeroU16;

use crate::mechanism::NM_PER_STEP;
use crate::units::Kgf;

/// The lower probe point, share of the final target: 1/2.
pub const LOWER_SHARE: (i32, i32) = (1, 2);
/// The upper probe point, share of the final target: 3/4.
pub const UPPER_SHARE: (i32, i32) = (3, 4);
/// How long into the hold the creep window opens, ms.
pub const CREEP_SETTLE_MS: u32 = 1_000;
/// How long the creep window lasts, ms: the creep rate is always the travel over this long,
/// from [`CREEP_SETTLE_MS`] into the hold (or after its last change).
pub const CREEP_WINDOW_MS: u32 = 4_000;

/// A string's stiffness, thousandths of a kgf per mm of carriage travel (0.001–65.535;
/// never zero, so an unmeasured one costs the log no space: `Option<Stiffness>` is 2 bytes).
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug)]
pub struct Stiffness(NonZeroU16);

impl Stiffness {
    /// `milli` thousandths of a kgf per mm; `None` for zero.
    #[must_use]
    pub const fn from_milli(milli: u16) -> Option<Self> {
        match NonZeroU16::new(milli) {
            Some(value) => Some(Self(value)),
            None => None,
        }
    }

    /// Thousandths of a kgf per mm.
    #[must_use]
    pub const fn milli(self) -> u16 {
        self.0.get()
    }
}

/// A creep rate: hundredths of a per cent of the held tension per minute (0–655.34 %/min;
/// kept one up, so `Option<CreepRate>` is 2 bytes in the log).
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug)]
pub struct CreepRate(NonZeroU16);

impl CreepRate {
    /// `centi` hundredths of a per cent per minute, saturating at 655.34.
    #[must_use]
    pub const fn from_centi_percent_per_minute(centi: u16) -> Self {
        let stored = centi.saturating_add(1);
        match NonZeroU16::new(stored) {
            Some(value) => Self(value),
            None => Self(NonZeroU16::MIN),
        }
    }

    /// Hundredths of a per cent per minute.
    #[must_use]
    pub const fn centi_percent_per_minute(self) -> u16 {
        self.0.get().saturating_sub(1)
    }
}

/// The probe's state through one pull.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct StringProbe {
    /// The filtered Hall count (×2¹⁶) and tension at the lower probe point.
    lower: Option<(i64, Kgf)>,
    /// Whether the upper point has been passed (the stiffness is final).
    upper_passed: bool,
    /// The stiffness, once both points were passed.
    stiffness: Option<Stiffness>,
    /// The creep window: the Hall count and the hold's time when it opened.
    window: Option<(i32, u32)>,
    /// The Hall steps crept over the whole window, once it closed.
    crept: Option<i32>,
    /// The hold's time at which the creep window opens.
    opens_at: u32,
}

/// `value · share`, rounded toward zero.
fn share_of(value: Kgf, (numerator, denominator): (i32, i32)) -> Kgf {
    let bits = i64::from(value.to_bits()).saturating_mul(i64::from(numerator));
    let part = bits.checked_div(i64::from(denominator)).unwrap_or(0);
    Kgf::from_bits(i32::try_from(part).unwrap_or(0))
}

/// `K = ΔT / (Δsteps · NM_PER_STEP)` in thousandths of a kgf per mm, the Hall counts in
/// 2⁻¹⁶ steps; `None` without travel or without a rise, or beyond the type's range.
#[must_use]
pub fn stiffness_between(from: (i64, Kgf), to: (i64, Kgf)) -> Option<Stiffness> {
    let steps = to.0.checked_sub(from.0).filter(|&s| s > 0)?;
    let rise = i64::from(to.1.to_bits()).checked_sub(i64::from(from.1.to_bits()))?;
    if rise <= 0 {
        return None;
    }
    // kgf bits / 2¹⁶ per (steps / 2¹⁶ · nm / 10⁶ mm) × 1 000 = bits · 10⁹ / (nm · steps);
    // steps in 2⁻¹⁶ and tension in 2⁻¹⁶ kgf cancel.
    let numerator = rise.checked_mul(1_000_000_000)?;
    let denominator = steps.checked_mul(NM_PER_STEP)?;
    let milli = numerator.checked_add(denominator / 2)?.checked_div(denominator)?;
    u16::try_from(milli).ok().and_then(Stiffness::from_milli)
}

/// The creep rate of a string of stiffness `stiffness` held at `tension` whose carriage
/// crept `steps` Hall steps in `elapsed_ms`: `100 · K · Δx / (T · Δt)` per minute, in
/// hundredths of a per cent; `None` for an empty window or a tension below 1 kgf. A carriage that moved back (the string tightened) creeps at zero.
#[must_use]
pub fn creep_rate(
    stiffness: Stiffness,
    tension: Kgf,
    steps: i32,
    elapsed_ms: u32,
) -> Option<CreepRate> {
    if elapsed_ms == 0 || tension < Kgf::from_int(1) {
        return None;
    }
    let travel_nm = i64::from(steps.max(0)).checked_mul(NM_PER_STEP)?;
    // kgf/mm × 1 000 · nm = kgf × 10⁹ → micro-kgf lost over the window, then per minute.
    let lost_micro = i64::from(stiffness.milli()).checked_mul(travel_nm)?.checked_div(1_000)?;
    let per_minute = lost_micro.checked_mul(60_000)?.checked_div(i64::from(elapsed_ms))?;
    // Hundredths of a per cent of the tension (micro-kgf), rounded to the nearest.
    let tension_micro = i64::from(tension.to_milli()).checked_mul(1_000)?;
    let centi_percent = per_minute
        .checked_mul(10_000)?
        .checked_add(tension_micro / 2)?
        .checked_div(tension_micro)?;
    Some(CreepRate::from_centi_percent_per_minute(u16::try_from(centi_percent).unwrap_or(u16::MAX)))
}

impl Default for StringProbe {
    fn default() -> Self {
        Self::NEW
    }
}

impl StringProbe {
    /// A fresh probe for a new pull.
    pub const NEW: Self = Self {
        lower: None,
        upper_passed: false,
        stiffness: None,
        window: None,
        crept: None,
        opens_at: CREEP_SETTLE_MS,
    };

    /// One pulling tick at the filtered Hall count `steps` (×2¹⁶), with the tension through
    /// the same filter `tension`, on a pull whose final target is `target`.
    pub fn pulling(&mut self, steps: i64, tension: Kgf, target: Kgf) {
        if self.upper_passed {
            return;
        }
        match self.lower {
            None => {
                if tension >= share_of(target, LOWER_SHARE) {
                    self.lower = Some((steps, tension));
                }
            }
            Some(lower) => {
                if tension >= share_of(target, UPPER_SHARE) {
                    self.upper_passed = true;
                    self.stiffness = stiffness_between(lower, (steps, tension));
                }
            }
        }
    }

    /// One holding tick at Hall count `steps`, `held_ms` into the hold: opens the creep
    /// window once the hold has settled and closes it [`CREEP_WINDOW_MS`] later.
    pub fn holding(&mut self, steps: i32, held_ms: u32) {
        match self.window {
            None if held_ms >= self.opens_at => self.window = Some((steps, held_ms)),
            Some((from_steps, from_ms))
                if self.crept.is_none() && held_ms.saturating_sub(from_ms) >= CREEP_WINDOW_MS =>
            {
                self.crept = Some(steps.saturating_sub(from_steps));
            }
            _ => {}
        }
    }

    /// The hold changed (an adjustment, constant pull off or on) `held_ms` into the hold: the
    /// creep window restarts [`CREEP_SETTLE_MS`] from now.
    pub fn hold_changed(&mut self, held_ms: u32) {
        self.window = None;
        self.crept = None;
        self.opens_at = held_ms.saturating_add(CREEP_SETTLE_MS);
    }

    /// The stiffness, once measured.
    #[must_use]
    pub const fn stiffness(&self) -> Option<Stiffness> {
        self.stiffness
    }

    /// The creep rate over the window at tension `tension`; `None` until the window closed.
    #[must_use]
    pub fn creep(&self, tension: Kgf) -> Option<CreepRate> {
        creep_rate(self.stiffness?, tension, self.crept?, CREEP_WINDOW_MS)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tension ramp of `milli_per_step` milli-kgf per Hall step, from 0.
    fn ramp(probe: &mut StringProbe, milli_per_step: i32, target: Kgf, steps: i32) {
        for step in 0..steps {
            probe.pulling(i64::from(step) << 16, Kgf::from_milli(step * milli_per_step), target);
        }
    }

    /// `steps` Hall steps as the probe takes them (×2¹⁶).
    fn at(steps: i64) -> i64 {
        steps << 16
    }

    #[test]
    fn stiffness_is_the_rise_over_the_travel_between_the_probe_points() {
        // 66.15 milli-kgf a step = 1.250 kgf/mm (a 52.917 µm step).
        let mut probe = StringProbe::NEW;
        ramp(&mut probe, 66, Kgf::from_int(25), 1_000);
        let k = probe.stiffness().map(Stiffness::milli);
        assert_eq!(k, Some(1_247), "66 / 52.917 = 1.2472 kgf/mm");
        // A soft badminton string: 9.5 milli-kgf a step = 0.180 kgf/mm.
        let mut soft = StringProbe::NEW;
        ramp(&mut soft, 9, Kgf::from_tenths(115), 2_000);
        assert_eq!(soft.stiffness().map(Stiffness::milli), Some(170), "9 / 52.917");
        // Not yet at the upper point: nothing.
        let mut short = StringProbe::NEW;
        ramp(&mut short, 66, Kgf::from_int(25), 250);
        assert_eq!(short.stiffness(), None);
    }

    #[test]
    fn the_probe_points_are_half_and_three_quarters_of_the_target() {
        let mut probe = StringProbe::NEW;
        let target = Kgf::from_int(20);
        probe.pulling(at(0), Kgf::from_milli(9_999), target);
        probe.pulling(at(10), Kgf::from_int(10), target);
        probe.pulling(at(20), Kgf::from_milli(14_999), target);
        assert_eq!(probe.stiffness(), None);
        // From step 10 at 10 kgf to step 110 at 15 kgf: 5 kgf over 5.2917 mm.
        probe.pulling(at(110), Kgf::from_int(15), target);
        assert_eq!(probe.stiffness().map(Stiffness::milli), Some(945));
        // A fraction of a step counts: 100.5 steps.
        let mut half = StringProbe::NEW;
        half.pulling(at(10), Kgf::from_int(10), target);
        half.pulling(at(110) + (1 << 15), Kgf::from_int(15), target);
        assert_eq!(half.stiffness().map(Stiffness::milli), Some(940));
        // Later ticks do not move it.
        probe.pulling(at(200), Kgf::from_int(30), target);
        assert_eq!(probe.stiffness().map(Stiffness::milli), Some(945));
    }

    #[test]
    fn no_travel_or_no_rise_gives_no_stiffness() {
        let at = |steps: i64, kgf| (steps << 16, Kgf::from_int(kgf));
        assert_eq!(stiffness_between(at(10, 10), at(10, 15)), None, "no travel");
        assert_eq!(stiffness_between(at(10, 10), at(5, 15)), None, "backwards");
        assert_eq!(stiffness_between(at(10, 10), at(20, 10)), None, "no rise");
        assert_eq!(stiffness_between(at(0, 0), at(1, 50)), None, "944.9 kgf/mm: beyond the type");
        assert_eq!(stiffness_between(at(-(1 << 40), 0), at(1 << 40, 50)), None, "rounds to zero");
        assert_eq!(
            stiffness_between((i64::MIN, Kgf::ZERO), (i64::MAX, Kgf::MAX)),
            None,
            "overflow"
        );
    }

    #[test]
    fn creep_is_the_tension_the_travel_made_up_per_minute() {
        let k = Stiffness::from_milli(1_250);
        let Some(k) = k else { panic!("valid") };
        // 1.25 kgf/mm × 20 steps (1.058 mm) = 1.323 kgf over 20 s at 25 kgf: 15.88 %/min.
        let rate = creep_rate(k, Kgf::from_int(25), 20, 20_000);
        assert_eq!(rate.map(CreepRate::centi_percent_per_minute), Some(1_588));
        // An empty window, too low a tension: none; a carriage that moved back: zero.
        assert_eq!(creep_rate(k, Kgf::from_int(25), 20, 0), None);
        assert_eq!(creep_rate(k, Kgf::from_milli(999), 20, 20_000), None);
        assert_eq!(
            creep_rate(k, Kgf::from_int(25), -20, 20_000).map(CreepRate::centi_percent_per_minute),
            Some(0)
        );
        // Saturates instead of wrapping.
        assert_eq!(
            creep_rate(k, Kgf::from_int(1), 1_000_000, 3_000)
                .map(CreepRate::centi_percent_per_minute),
            Some(u16::MAX - 1)
        );
    }

    #[test]
    fn the_creep_window_opens_after_the_settle_closes_after_its_length_and_restarts_on_a_change() {
        let mut probe = StringProbe::NEW;
        ramp(&mut probe, 66, Kgf::from_int(25), 1_000);
        let tension = Kgf::from_int(25);
        for ms in 1..=999 {
            probe.holding(1_000, ms);
        }
        assert_eq!(probe.creep(tension), None, "not open before 1 s");
        probe.holding(1_000, 1_000);
        probe.holding(1_003, 4_999);
        assert_eq!(probe.creep(tension), None, "the window is still open");
        probe.holding(1_004, 5_000);
        let closed = probe.creep(tension).map(CreepRate::centi_percent_per_minute);
        assert_eq!(closed, Some(1_584), "1.247 kgf/mm × 4 steps in 4 s at 25 kgf");
        // The window is fixed: later travel, however long the hold, does not move it.
        probe.holding(1_200, 120_000);
        assert_eq!(probe.creep(tension).map(CreepRate::centi_percent_per_minute), closed);
        // An adjustment at 7 s: the window reopens at 8 s from the count then.
        probe.hold_changed(7_000);
        assert_eq!(probe.creep(tension), None);
        probe.holding(1_300, 7_999);
        probe.holding(1_300, 8_000);
        probe.holding(1_302, 12_000);
        let after = probe.creep(tension).map(CreepRate::centi_percent_per_minute);
        assert_eq!(after, Some(792), "2 steps in 4 s");
    }

    #[test]
    fn logged_values_round_trip() {
        assert_eq!(Stiffness::from_milli(0), None);
        assert_eq!(Stiffness::from_milli(1_234).map(Stiffness::milli), Some(1_234));
        for centi in [0, 1, 1_587, u16::MAX - 1] {
            assert_eq!(
                CreepRate::from_centi_percent_per_minute(centi).centi_percent_per_minute(),
                centi
            );
        }
        assert_eq!(
            CreepRate::from_centi_percent_per_minute(u16::MAX).centi_percent_per_minute(),
            u16::MAX - 1
        );
        assert_eq!(size_of::<Option<Stiffness>>(), 2);
        assert_eq!(size_of::<Option<CreepRate>>(), 2);
    }
}
