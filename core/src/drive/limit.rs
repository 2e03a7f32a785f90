//! The board the drive runs on, and current limiting by control: what the current sense reads,
//! what the bus divider reads, and the duty window that keeps the winding current within a
//! limit whatever the rotor does.
//!
//! # Theory of operation
//!
//! With six-step drive two windings conduct in series, and the switched leg is complementary
//! (`crate::drive::commutation`): during the off-time the low sides short the pair. Averaged
//! over a PWM period the pair sees `duty·V_bus` against the back-EMF `e` and its resistance
//! `R`, so the winding current settles at
//!
//! ```text
//! I = (duty·V_bus − e) / R          (e > 0 when the rotor turns the way the torque points)
//! ```
//!
//! Keeping `|I| ≤ I_lim` is therefore a window on the duty:
//!
//! ```text
//! (e − I_lim·R) / V_bus  ≤  duty  ≤  (e + I_lim·R) / V_bus
//! ```
//!
//! — the upper edge bounds the motoring current (a start from rest may ask for at most
//! `I_lim·R/V_bus`, ≈ 0.23 at 24 V), the lower edge the braking current (a duty far below
//! the back-EMF would short the spinning motor through the low sides). When the rotor turns
//! *against* the torque, `e < 0`: if `−e ≥ I_lim·R` even zero duty would brake with more than
//! the limit, the window is empty and the drive must not energise (it coasts: with every
//! switch off no current flows while `|e| < V_bus`). This replaces a fixed "quiet time"
//! before a reversal: the drive reverses as soon as the rotor's speed — its back-EMF —
//! allows it, at a duty that keeps the current within the limit.
//!
//! [`DriveConfig::window`] evaluates it from three measured quantities and three constants:
//!
//! - `V_bus` from the bus divider's converter code ([`BusSense`]), floored at
//!   [`BusSense::floor_mv`] (a low reading can only widen nothing: a lower assumed bus
//!   *narrows* the window's lower edge and *widens* its upper edge, so the floor is where the
//!   board's undervoltage lockout holds the bus; below it the gate drivers are off anyway).
//! - `e` from the Hall timing: one Hall step is 1/24 motor turn, so
//!   `e = K / t_step` with `K = Ke · (2π/24) · 10⁷ s⁻¹` (`t_step` in [`DriveTime`]'s 100 ns;
//!   [`CurrentLimit::emf_mv_time`]).
//!   The drive uses `t_step = max(last step interval, time since the last step)`:
//!   exact at constant speed and an *upper* bound of the speed while the rotor slows (a slowing
//!   rotor moved less than one step since its last edge), which is what coasting, braking and
//!   the moment before a reversal are. (While the rotor speeds up the estimate lags by one step
//!   interval; the limit's margin below the trip — 8 A against 12 A — covers it, and the
//!   per-period fold-back on the sampled current catches what is left.)
//!
//!   Right after a **turn-around** — a Hall step against the one before, as when the string
//!   back-drives a rotor that the drive holds — there is no interval, and one step per time
//!   since the step would be tens of volts at first: the window would stay empty for
//!   `K/(I_lim·R)` ≈ 2.8 ms after every backward step of a hold although the rotor has just
//!   turned round. The rotor's speed was zero at the turn, which lies after the step before
//!   it, so it is at most `a_max · (gap + time since the step)` — and the back-EMF at most
//!   [`DriveConfig::turn_emf_mv`] of that time; the drive uses the smaller of the two bounds.
//!   `a_max` is what can accelerate a rotor against the held torque: the motor's own torque
//!   at the limit (a braking current still flowing at the turn, `Kt·I_lim` = 0.481 N·m) plus
//!   the string's back-drive through a lossless screw at twice the machine's 50 kgf rating
//!   (981 N × 25.4 mm / (2π·20) = 0.198 N·m), over the smallest rotor + gearbox inertia of the
//!   family (0.8 × 10⁻⁵ kg·m²): 84 900 rad/s², `Ke·a_max` = 5.10 V/ms, 523 mV per 1 024
//!   time units ([`CurrentLimit::accel_emf_mv_per_1024`], rounded up). The time since the step before is
//!   lengthened by the Hall filter's confirmation lag ([`TURN_LAG`]); with no valid step
//!   sequence (power-up, an invalid code, a skipped sector) no turn-around is credited.
//! - `I_lim·R` with the *lowest* resistance the pair can have (cold windings, MOSFETs at their
//!   best), so the real current is at most the limit.
//!
//! Above the regeneration threshold (`BusSense::regen_mv`, as `DriveConfig`'s `regen_code`)
//! the lower edge rises to `e/V_bus`: no braking current, so the bus stops being pumped; at
//! the overvoltage threshold (`BusSense::max_mv`) the drive latches a fault and coasts.
//!
//! # Current sensing
//!
//! [`CurrentSense`] says what the current converter code stands for: the **winding** current
//! (per-phase low-side shunts, or a DC-link shunt sampled in the middle of the on-time) or the
//! **link average** (a DC-link shunt behind an RC filter: `≈ duty × I`). Its zero — 0 for a
//! unidirectional amplifier, mid-rail for a bidirectional one — is tared by the drive while
//! the bridge is off ([`TARE_SETTLE`]); the overcurrent threshold is the board's trip
//! ([`DriveConfig::trip`], 12 A on the paper's) of the reading on both kinds
//! ([`DriveConfig::overcurrent`]): the winding current itself, or a link average that never
//! exceeds it. The limit the window keeps to (8 A) is watched on both kinds too
//! ([`DriveConfig::over_limit`]): a winding reading against it directly, a link average
//! against the duty applied lately × the limit, so a shorted winding that the window cannot
//! hold down is caught on an RC-filtered board at any duty, not only once `duty × I` reaches
//! the trip.
//!
//! Every quantity is an integer in mV, mA, converter codes or duty raw units, with the
//! divisions done in `u32`; the conversions are precomputed by [`DriveConfig::new`], which
//! refuses a configuration whose arithmetic could overflow.

use crate::drive::DriveTime;
use crate::drive::dead_time::{DEAD_TIME_MAX, DEAD_TIME_MIN};
use crate::drive::duty::{DUTY_MAX, DUTY_ONE, Duty};
use crate::units::{AdcCode, Amps, Volts};

/// The converter's full-scale code count (12 bit).
const ADC_COUNTS: u32 = 4_096;

/// How long the bridge must have been all-off before the current sense is tared: 5 ms
/// (the winding current decays with `L/R` ≈ 1.4 ms; after 3.5 time constants it is < 3 %).
pub const TARE_SETTLE: DriveTime = DriveTime::from_micros(5_000);

/// What the current converter code stands for.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
#[cfg_attr(kani, derive(kani::Arbitrary))]
pub enum CurrentReading {
    /// The winding current: per-phase low-side shunts (the conducting low side's), or a
    /// DC-link shunt converted in the middle of the high side's on-time.
    Winding,
    /// The average of the DC-link current (an RC-filtered link shunt): ≈ duty × winding
    /// current. The board's filter must be at least two PWM periods long (τ ≥ 100 µs at
    /// 20 kHz), so a sample anywhere in the period reads at most 127 % of `duty × I`
    /// ([`DriveConfig::over_limit`]); a shorter filter is a winding reading's ripple, not an
    /// average.
    LinkAverage,
}

/// The motor-current sensing of a board.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct CurrentSense {
    /// What the code stands for.
    pub reading: CurrentReading,
    /// The code at zero current by design: 0 (unidirectional amplifier) or 2 048 (mid-rail).
    pub design_zero: AdcCode,
    /// Amperes per code, in nA (0.2 V/A at 5 V / 4 096: 6 103 516 nA).
    pub na_per_code: u32,
    /// How far the tared zero may sit from the design zero before the sense is faulty, codes.
    pub zero_tolerance: u16,
}

impl CurrentSense {
    #[cfg(any(test, feature = "paper-board"))]
    /// taut's own board: one DC-link shunt converted mid on-time (it reads the winding
    /// current) through a unidirectional 0.2 V/A amplifier.
    pub const PAPER: Self = Self {
        reading: CurrentReading::Winding,
        design_zero: AdcCode::new(0),
        na_per_code: 6_103_516,
        zero_tolerance: 82,
    };

    #[cfg(any(test, feature = "paper-board"))]
    /// Per-phase low-side shunts with bidirectional 0.1 V/A amplifiers (zero at mid-rail).
    pub const PER_PHASE_BIDIRECTIONAL: Self = Self {
        reading: CurrentReading::Winding,
        design_zero: AdcCode::new(2_048),
        na_per_code: 12_207_031,
        zero_tolerance: 41,
    };

    #[cfg(any(test, feature = "paper-board"))]
    /// An RC-filtered DC-link shunt with a bidirectional 0.1 V/A amplifier.
    pub const LINK_AVERAGE_BIDIRECTIONAL: Self =
        Self { reading: CurrentReading::LinkAverage, ..Self::PER_PHASE_BIDIRECTIONAL };

    /// The current a sample `code` stands for with the sense's zero at `zero`: signed
    /// (positive above the zero), to the milliampere, in this board's scale — what the
    /// controller's motor current is (a mid-rail amplifier reads 0 A at its tared zero, not
    /// the 12.5 A a fixed unidirectional scale would make of it).
    #[must_use]
    pub fn amps(&self, code: AdcCode, zero: AdcCode) -> Amps {
        let codes = i64::from(code.get()).saturating_sub(i64::from(zero.get()));
        let ma = codes.saturating_mul(i64::from(self.na_per_code)) / 1_000_000;
        Amps::from_milli(i32::try_from(ma).unwrap_or(0))
    }

    /// The codes a current of `ma` spans, rounded up (`const`: `DriveConfig::new` is
    /// evaluated at compile time for a board's constant).
    const fn codes_for(&self, ma: u32) -> Option<u16> {
        let Some(na) = (ma as u64).checked_mul(1_000_000) else { return None };
        let per = self.na_per_code as u64;
        let Some(less_one) = per.checked_sub(1) else { return None };
        let Some(sum) = na.checked_add(less_one) else { return None };
        let Some(codes) = sum.checked_div(per) else { return None };
        narrow(codes)
    }
}

/// The DC bus divider and the bus limits.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct BusSense {
    /// Bus millivolts at converter full scale (5 V × divider ratio 12 = 60 000 mV).
    pub full_scale_mv: u32,
    /// The lowest bus the window assumes, mV: the board's undervoltage lockout (18 V).
    pub floor_mv: u32,
    /// Above this bus voltage the drive stops braking regeneratively, mV.
    pub regen_mv: u32,
    /// At or above this bus voltage the drive coasts and latches a fault, mV.
    pub max_mv: u32,
}

impl BusSense {
    #[cfg(any(test, feature = "paper-board"))]
    /// The paper's 24 V machine (supply 20–30 V): 1:12 divider, lockout at 18 V, no
    /// regeneration above 38 V, fault at 40 V. The board's clamp (a TVS, 28–36 V across the
    /// twin's family) absorbs ordinary braking energy — a limit below it would forbid the
    /// braking the approach needs (measured: settle/t_min 1.42 instead of ≤ 1.3 with the
    /// limit at 32 V); the drive's limit is the backstop for a clamp that failed or is
    /// missing, below the 50 V rating of the bus capacitors.
    pub const PAPER: Self =
        Self { full_scale_mv: 60_000, floor_mv: 18_000, regen_mv: 38_000, max_mv: 40_000 };

    /// The bus voltage a code stands for, mV.
    #[must_use]
    pub fn millivolts(&self, code: AdcCode) -> u32 {
        u32::from(code.get()).saturating_mul(self.full_scale_mv) / ADC_COUNTS
    }

    /// The bus voltage a code stands for.
    #[must_use]
    pub fn volts(&self, code: AdcCode) -> Volts {
        Volts::from_milli(i32::try_from(self.millivolts(code)).unwrap_or(i32::MAX))
    }

    /// The lowest code that reads at least `mv` (`const`, as [`CurrentSense`]'s conversion).
    const fn code_for(&self, mv: u32) -> Option<u16> {
        let Some(scaled) = (mv as u64).checked_mul(ADC_COUNTS as u64) else { return None };
        let per = self.full_scale_mv as u64;
        let Some(less_one) = per.checked_sub(1) else { return None };
        let Some(sum) = scaled.checked_add(less_one) else { return None };
        let Some(code) = sum.checked_div(per) else { return None };
        match narrow(code) {
            Some(code) if code <= AdcCode::MAX.get() => Some(code),
            _ => None,
        }
    }
}

/// `value` as a `u16`, if it fits (`u16::try_from` in a `const fn`).
const fn narrow(value: u64) -> Option<u16> {
    if value <= u16::MAX as u64 {
        #[allow(
            clippy::cast_possible_truncation,
            reason = "at most u16::MAX, checked on the line before"
        )]
        Some(value as u16)
    } else {
        None
    }
}

/// The motor data the window needs.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct CurrentLimit {
    /// The winding current the drive keeps to, mA (8 A: two thirds of the 12 A trip).
    pub limit_ma: u32,
    /// The lowest resistance of the conducting pair (windings + two MOSFETs), mΩ: the
    /// nameplate's 0.846 Ω less 17 % for cold copper and tolerance.
    pub resistance_mohm: u32,
    /// Back-EMF × time per Hall step, mV·(0.1 µs): `Ke·(2π/24)·10⁷ s⁻¹` =
    /// 60.1 mV·s/rad × 0.2618 rad × 10⁷ = 1.5735 × 10⁸.
    pub emf_mv_time: u32,
    /// The per-period fold-back threshold on the sampled winding current, mA (9.5 A).
    pub fold_back_ma: u32,
    /// The back-EMF a rotor can gain per 1 024 [`DriveTime`] units (102.4 µs) at the largest
    /// acceleration it can have while it turns against the torque, mV: `Ke · a_max` with
    /// `a_max = (Kt · I_lim + T_string) / J_min` (see [`DriveConfig::turn_emf_mv`]; a power
    /// of two of time units, so the bound is a product and a shift).
    pub accel_emf_mv_per_1024: u32,
}

impl CurrentLimit {
    #[cfg(any(test, feature = "paper-board"))]
    /// The paper's motor (`crate::tension::motor::MotorModel::PAPER`) with taut's limits.
    pub const PAPER: Self = Self {
        limit_ma: 8_000,
        resistance_mohm: 700,
        emf_mv_time: 157_350_000,
        fold_back_ma: 9_500,
        accel_emf_mv_per_1024: 523,
    };
}

/// The heat capacity the winding's estimate assumes, J/K: the largest a motor of the family
/// can have (a 20 min thermal time constant over 2 K/W), so the estimate heats no faster than
/// any real winding does.
pub const HEAT_CAPACITY_J_PER_K: u64 = 600;

/// The cooling time constant the winding's estimate assumes, s: the shortest of the family
/// (10 min), so the estimate cools no slower than any real winding does.
pub const COOLING_TAU_S: u64 = 600;

/// The largest rise over the cold value the estimate credits, µK (100 K: a class-F winding's
/// 155 °C from a 40 °C shop is 115 K). It bounds the hot resistance:
/// `R_cold · (1 + α · 100 K)` = 1.393 × `R_cold` (975 mΩ for taut's 700 mΩ).
pub const RISE_MAX_UK: u32 = 100_000_000;

/// Copper's temperature coefficient, per 10¹¹ µK: 0.393 %/K.
const COPPER_ALPHA_PER_1E11_UK: u64 = 393;

/// The largest winding current the estimate credits, mA (above any board's sense range).
const HEAT_CURRENT_MAX_MA: u64 = 65_535;

/// Time units per second (100 ns each).
const UNITS_PER_SECOND: u64 = 10_000_000;

/// The span the estimate is advanced over at once: 1 ms of calls.
const HEAT_SPAN: u32 = 10_000;

/// The winding's temperature estimate and the resistance of the conducting pair it gives.
///
/// A winding that heats up conducts less current for the same duty (`R` rises 0.393 %/K): a
/// window computed with the cold resistance then caps a hot motor well below the limit, and a
/// hold that needs most of the limit loses its torque. The drive therefore follows the
/// winding's rise over its cold temperature with a first-order model of its copper loss,
///
/// ```text
/// C · dΔT/dt = I² · R_cold − C · ΔT / τ
/// ```
///
/// fed with the sampled winding current of every conducting period, and computes the window
/// with `R = R_cold · (1 + α · ΔT)`, never below [`CurrentLimit::resistance_mohm`] (cold) and
/// never above 1.393 times it ([`RISE_MAX_UK`]).
///
/// The estimate must never exceed the real rise: a window computed with more resistance than
/// the pair has would let more than the limit flow. Every choice errs toward the cold side:
/// the loss uses the lowest resistance and only the periods that conduct (a link-average
/// reading, `≈ D·I`, reads less than the winding current), the capacity is the family's
/// largest ([`HEAT_CAPACITY_J_PER_K`]) and the cooling constant its shortest
/// ([`COOLING_TAU_S`]) — with both, a first-order system fed less power with more capacity and
/// a shorter constant stays below the real one from any common start (comparison of the two
/// equations at the point where they would meet). Heating rounds down, cooling rounds up. At
/// power-up the estimate starts cold: a motor still warm from before the boot is credited
/// nothing.
///
/// Each call adds its sample's square (one 32-bit product); once a millisecond of calls has
/// passed the model advances over it at once, so the fast loop carries no more than that.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct WindingHeat {
    /// Σ codes² of the conducting samples in the span (saturating: the span then ends).
    squares: u32,
    /// Calls in the span.
    calls: u16,
    /// Time in the span, 100 ns.
    span: u32,
    /// The estimated rise over the cold value, µK (≤ [`RISE_MAX_UK`]).
    rise_uk: u32,
    /// The estimated resistance of the conducting pair, mΩ.
    resistance_mohm: u32,
    /// `I_lim · R` with that resistance, mV.
    ir_mv: u32,
}

impl WindingHeat {
    /// A cold winding on the board `config` describes.
    #[must_use]
    pub const fn cold(config: &DriveConfig) -> Self {
        Self {
            squares: 0,
            calls: 0,
            span: 0,
            rise_uk: 0,
            resistance_mohm: config.limit.resistance_mohm,
            ir_mv: config.ir_mv,
        }
    }

    /// A winding `rise_uk` above its cold value (at most [`RISE_MAX_UK`]) on `config`'s board.
    #[must_use]
    pub fn with_rise(config: &DriveConfig, rise_uk: u32) -> Self {
        let mut heat = Self::cold(config);
        heat.rise_uk = rise_uk.min(RISE_MAX_UK);
        heat.follow(config);
        heat
    }

    /// The estimated rise over the cold value, µK.
    #[must_use]
    pub const fn rise_uk(&self) -> u32 {
        self.rise_uk
    }

    /// The estimated resistance of the conducting pair, mΩ.
    #[must_use]
    pub const fn resistance_mohm(&self) -> u32 {
        self.resistance_mohm
    }

    /// `I_lim · R` with the estimated resistance, mV: what the window keeps to.
    #[must_use]
    pub const fn ir_mv(&self) -> u32 {
        self.ir_mv
    }

    /// Whether the state is one the model can reach on `config`'s board: the rise within its
    /// bound and the resistance and `I·R` those of the rise.
    #[must_use]
    pub fn is_valid(&self, config: &DriveConfig) -> bool {
        let mut followed = *self;
        followed.follow(config);
        self.rise_uk <= RISE_MAX_UK
            && self.span < HEAT_SPAN.saturating_mul(2)
            && followed.resistance_mohm == self.resistance_mohm
            && followed.ir_mv == self.ir_mv
    }

    /// One call of the fast loop: the sample `codes` from the current sense's zero, taken
    /// while the bridge conducted (`conducting`), `elapsed` after the previous call.
    pub fn step(&mut self, config: &DriveConfig, codes: u16, conducting: bool, elapsed: DriveTime) {
        if conducting {
            let codes = u32::from(codes);
            self.squares = self.squares.saturating_add(codes.saturating_mul(codes));
        }
        self.calls = self.calls.saturating_add(1);
        self.span = self.span.saturating_add(elapsed.0.min(HEAT_SPAN));
        if self.span >= HEAT_SPAN || self.calls == u16::MAX || self.squares == u32::MAX {
            self.advance(config);
        }
    }

    /// Advances the model over the span gathered and starts the next.
    fn advance(&mut self, config: &DriveConfig) {
        let span = u64::from(self.span);
        // The mean square over every call of the span (a call that did not conduct adds
        // nothing), in codes², then in mA² (per code: µA).
        let mean_square = u64::from(self.squares).checked_div(u64::from(self.calls)).unwrap_or(0);
        let ua_per_code = u64::from(config.sense.na_per_code) / 1_000;
        let ma_squared =
            (mean_square.saturating_mul(ua_per_code) / 1_000).saturating_mul(ua_per_code) / 1_000;
        let ma_squared = ma_squared.min(HEAT_CURRENT_MAX_MA * HEAT_CURRENT_MAX_MA);
        // Copper loss with the cold resistance, mW (mA² · mΩ = 10⁻⁹ W); over the span it
        // heats the capacity by loss · span / C (mW · ms / (J/K) = µK).
        let loss_mw =
            (ma_squared / 1_000).saturating_mul(u64::from(config.limit.resistance_mohm)) / 1_000;
        let heat_uk =
            loss_mw.saturating_mul(span) / (HEAT_CAPACITY_J_PER_K * (UNITS_PER_SECOND / 1_000));
        let rise = u64::from(self.rise_uk);
        let cool_uk = rise.saturating_mul(span).div_ceil(COOLING_TAU_S * UNITS_PER_SECOND);
        let rise = rise.saturating_add(heat_uk).saturating_sub(cool_uk);
        self.rise_uk = u32::try_from(rise.min(u64::from(RISE_MAX_UK))).unwrap_or(RISE_MAX_UK);
        self.squares = 0;
        self.calls = 0;
        self.span = 0;
        self.follow(config);
    }

    /// The resistance and `I·R` of the rise.
    fn follow(&mut self, config: &DriveConfig) {
        let cold = u64::from(config.limit.resistance_mohm);
        let warmer = cold
            .saturating_mul(COPPER_ALPHA_PER_1E11_UK)
            .saturating_mul(u64::from(self.rise_uk.min(RISE_MAX_UK)))
            / 100_000_000_000;
        let resistance = cold.saturating_add(warmer);
        self.resistance_mohm = u32::try_from(resistance).unwrap_or(u32::MAX);
        let ir = u64::from(config.limit.limit_ma).saturating_mul(resistance) / 1_000;
        self.ir_mv =
            u32::try_from(ir.min(u64::from(EMF_MAX_MV))).unwrap_or(EMF_MAX_MV).max(config.ir_mv);
    }
}

/// Why a drive configuration was refused.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum DriveConfigError {
    /// The current sense's gain is zero, or the trip current is beyond its full scale.
    CurrentSense,
    /// The bus divider's full scale is zero or absurd, or the bus limits are out of order
    /// (floor < regeneration < maximum ≤ full scale).
    Bus,
    /// The current limit is zero, at or above the trip, or `I·R` would overflow.
    Limit,
    /// The dead time is outside [`DEAD_TIME_MIN`]..=[`DEAD_TIME_MAX`].
    DeadTime,
}

/// A duty range the drive may apply: `low ≤ duty ≤ high`.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct DutyWindow {
    /// The least duty (bounds the braking current).
    pub low: Duty,
    /// The greatest duty (bounds the motoring current).
    pub high: Duty,
}

impl DutyWindow {
    /// `duty` moved into the window.
    #[must_use]
    pub fn clamp(self, duty: Duty) -> Duty {
        duty.max(self.low).min(self.high)
    }
}

/// The drive's board configuration, validated and precomputed.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct DriveConfig {
    sense: CurrentSense,
    bus: BusSense,
    limit: CurrentLimit,
    /// The winding current at which the drive trips, mA (as the board states it).
    trip_ma: u32,
    /// `I_lim·R`, mV.
    ir_mv: u32,
    /// Codes from zero that trip (winding current at the trip).
    trip_codes: u16,
    /// Codes from zero that fold the duty back.
    fold_back_codes: u16,
    /// Codes from zero at the current limit itself (evidence of a fault, see
    /// [`DriveConfig::over_limit`]).
    limit_codes: u16,
    /// Bus code at or above which regeneration stops.
    regen_code: u16,
    /// Bus code at or above which the drive faults.
    over_code: u16,
    /// The bridge's dead time (the board's gate drivers and MOSFETs).
    dead_time: DriveTime,
}

/// A link-average reading's allowance over `D × I_lim` before it counts as over the limit:
/// 130 % (the RC filter's ripple at its sampling instant, ≤ 127 % for `τ ≥ 2` PWM periods;
/// see [`DriveConfig::over_limit`]).
pub const LINK_RIPPLE_PERCENT: u64 = 130;

/// The least duty a link-average reading is scaled by: 1/8. Below it `D × I` is too small a
/// reading to tell a fault by (a short at such a duty drives no more than a healthy winding
/// at full duty would); the reading is compared with `I_lim × 1.3 / 8` (1.3 A) instead.
pub const LINK_DUTY_FLOOR: Duty = Duty::from_raw_clamped(8_192);

/// The largest back-EMF the window considers, mV (above any bus the board supports).
pub const EMF_MAX_MV: u32 = 60_000;

/// How much later the drive accepts a Hall step than the rotor crosses the edge, at most: the
/// filter's second confirming read one PWM period after the first (50 µs at 20 kHz), doubled
/// for a period stretched by a Hall-edge call. The turn-around bound
/// ([`DriveConfig::turn_emf_mv`]) adds it to the measured time since the step before the
/// turn, which can only be longer than measured.
pub const TURN_LAG: DriveTime = DriveTime::from_micros(100);

impl DriveConfig {
    #[cfg(any(test, feature = "paper-board"))]
    /// taut's own board and the paper's motor, tripping at 12 A: [`Self::new`] evaluated at
    /// compile time, so its derived codes are the constructor's and nowhere written by hand.
    pub const PAPER: Self = match Self::new(
        CurrentSense::PAPER,
        BusSense::PAPER,
        CurrentLimit::PAPER,
        12_000,
        DriveTime::from_micros(1),
    ) {
        Ok(config) => config,
        // A constant's evaluation: a refused board is a compile error, never a run-time path.
        #[allow(clippy::panic, reason = "const evaluation: fails the build, not the run")]
        Err(_) => panic!("the paper's board is refused by DriveConfig::new"),
    };

    /// A configuration for `sense`, `bus` and `limit` with the trip at `trip_ma` and the
    /// bridge's `dead_time` (the same value the board programs into its timer's dead-time
    /// generator). `const`: a board's configuration can be a constant, checked as the firmware
    /// is built.
    ///
    /// # Errors
    /// [`DriveConfigError`] names the part that is zero, out of order or out of range.
    pub const fn new(
        sense: CurrentSense,
        bus: BusSense,
        limit: CurrentLimit,
        trip_ma: u32,
        dead_time: DriveTime,
    ) -> Result<Self, DriveConfigError> {
        if dead_time.0 < DEAD_TIME_MIN.0 || dead_time.0 > DEAD_TIME_MAX.0 {
            return Err(DriveConfigError::DeadTime);
        }
        if sense.na_per_code == 0 || sense.design_zero.get() > AdcCode::MAX.get() {
            return Err(DriveConfigError::CurrentSense);
        }
        let Some(trip_codes) = sense.codes_for(trip_ma) else {
            return Err(DriveConfigError::CurrentSense);
        };
        let Some(fold_back_codes) = sense.codes_for(limit.fold_back_ma) else {
            return Err(DriveConfigError::CurrentSense);
        };
        let Some(limit_codes) = sense.codes_for(limit.limit_ma) else {
            return Err(DriveConfigError::CurrentSense);
        };
        if trip_codes == 0 || trip_codes > AdcCode::MAX.get() {
            return Err(DriveConfigError::CurrentSense);
        }
        let bus_ok = bus.full_scale_mv >= 1_000
            && bus.full_scale_mv <= 1_000_000
            && bus.floor_mv > 0
            && bus.floor_mv < bus.regen_mv
            && bus.regen_mv < bus.max_mv
            && bus.max_mv <= bus.full_scale_mv;
        if !bus_ok {
            return Err(DriveConfigError::Bus);
        }
        let Some(regen_code) = bus.code_for(bus.regen_mv) else {
            return Err(DriveConfigError::Bus);
        };
        let Some(over_code) = bus.code_for(bus.max_mv) else {
            return Err(DriveConfigError::Bus);
        };
        let ir_mv = match limit.limit_ma.checked_mul(limit.resistance_mohm) {
            Some(product) if product / 1_000 > 0 && product / 1_000 <= EMF_MAX_MV => {
                product / 1_000
            }
            _ => return Err(DriveConfigError::Limit),
        };
        if limit.limit_ma >= trip_ma
            || limit.fold_back_ma < limit.limit_ma
            || limit.fold_back_ma >= trip_ma
            || limit.emf_mv_time == 0
            || limit.accel_emf_mv_per_1024 == 0
        {
            return Err(DriveConfigError::Limit);
        }
        Ok(Self {
            sense,
            bus,
            limit,
            trip_ma,
            ir_mv,
            trip_codes,
            fold_back_codes,
            limit_codes,
            regen_code,
            over_code,
            dead_time,
        })
    }

    /// The bridge's dead time.
    #[must_use]
    pub const fn dead_time(&self) -> DriveTime {
        self.dead_time
    }

    /// The current sense.
    #[must_use]
    pub const fn sense(&self) -> CurrentSense {
        self.sense
    }

    /// The bus divider and limits.
    #[must_use]
    pub const fn bus(&self) -> BusSense {
        self.bus
    }

    /// The current limit.
    #[must_use]
    pub const fn limit(&self) -> CurrentLimit {
        self.limit
    }

    /// `I_lim·R`, mV.
    #[must_use]
    pub const fn ir_mv(&self) -> u32 {
        self.ir_mv
    }

    /// The winding current at which the drive trips, as the board stated it
    /// ([`Self::trip_codes`] is the reading's codes for it, rounded up).
    #[must_use]
    pub fn trip(&self) -> Amps {
        Amps::from_milli(i32::try_from(self.trip_ma).unwrap_or(i32::MAX))
    }

    /// Codes from the zero at which the drive trips.
    #[must_use]
    pub const fn trip_codes(&self) -> u16 {
        self.trip_codes
    }

    /// The window's current limit in codes of the board's reading (from its zero).
    #[must_use]
    pub const fn limit_codes(&self) -> u16 {
        self.limit_codes
    }

    /// Whether a bus code is at or above the configured maximum.
    #[must_use]
    pub const fn bus_over(&self, code: AdcCode) -> bool {
        code.get() >= self.over_code
    }

    /// The back-EMF, mV, of a rotor making one Hall step every `per_step` ([`DriveTime`]
    /// units; zero for a rotor at rest, `per_step = 0` meaning "no step seen"), at most
    /// [`EMF_MAX_MV`].
    #[must_use]
    pub fn emf_mv(&self, per_step: u32) -> u32 {
        self.limit.emf_mv_time.checked_div(per_step).unwrap_or(0).min(EMF_MAX_MV)
    }

    /// The largest back-EMF, mV, of a rotor that was at rest at some instant within the last
    /// `since` ([`DriveTime`] units) — a rotor whose last Hall step reversed the one before,
    /// `since` the time since that step before (at most [`EMF_MAX_MV`]):
    /// `Ke · a_max · (since + TURN_LAG)`, in `u32` (saturating: a saturated product is far
    /// above the cap).
    #[must_use]
    pub fn turn_emf_mv(&self, since: u32) -> u32 {
        let mv = since
            .saturating_add(TURN_LAG.0)
            .saturating_mul(self.limit.accel_emf_mv_per_1024)
            .checked_shr(10)
            .unwrap_or(u32::MAX);
        mv.min(EMF_MAX_MV)
    }

    /// The duty window for a bus code and a back-EMF `emf_mv` that is positive when the rotor
    /// turns the way the torque points; `None` when no duty keeps the current within the
    /// limit (the rotor turns against the torque with `|e| ≥ I_lim·R`).
    #[must_use]
    pub fn window(&self, bus: AdcCode, emf_mv: i32) -> Option<DutyWindow> {
        self.window_with(bus, emf_mv, self.ir_mv)
    }

    /// [`Self::window`] with `I_lim·R` = `ir_mv` (a hot winding's, [`WindingHeat::ir_mv`]).
    #[must_use]
    pub fn window_with(&self, bus: AdcCode, emf_mv: i32, ir_mv: u32) -> Option<DutyWindow> {
        let bus_mv = self.bus.millivolts(bus).max(self.bus.floor_mv);
        let regen_allowed = bus.get() < self.regen_code;
        let ir = ir_mv.min(EMF_MAX_MV);
        let (low_mv, high_mv) = if emf_mv >= 0 {
            let e = emf_mv.unsigned_abs().min(EMF_MAX_MV);
            let low = if regen_allowed { e.saturating_sub(ir) } else { e };
            (low, e.saturating_add(ir))
        } else {
            let e = emf_mv.unsigned_abs().min(EMF_MAX_MV);
            if e >= ir {
                return None;
            }
            (0, ir.saturating_sub(e))
        };
        Some(DutyWindow {
            low: duty_of(low_mv, bus_mv, true),
            high: duty_of(high_mv, bus_mv, false),
        })
    }

    /// Whether the sampled current code is an overcurrent: a reading at or above the trip's
    /// codes from the zero `zero`. A winding reading is the winding current. A link-average
    /// reading lies between `duty × I` (a long RC) and `I` itself (a short RC sampled in the
    /// on-time), so it is compared with the trip as it is: it never trips falsely, and on such
    /// a board the duty window bounds the winding current while the hardware comparator on the
    /// unfiltered shunt is the backstop.
    #[must_use]
    pub fn overcurrent(&self, code: AdcCode, zero: AdcCode) -> bool {
        u32::from(code.get().abs_diff(zero.get())) >= u32::from(self.trip_codes)
    }

    /// Whether the sampled winding current is at or above the fold-back threshold (winding
    /// readings only: a link average says too little within one period).
    #[must_use]
    pub fn fold_back(&self, code: AdcCode, zero: AdcCode) -> bool {
        self.sense.reading == CurrentReading::Winding
            && code.get().abs_diff(zero.get()) >= self.fold_back_codes
    }

    /// Whether the sampled current is above the limit the window keeps a healthy motor within
    /// (evidence of a fault, counted toward [`crate::drive::FOLD_BACK_TRIP`]). The window is
    /// computed with the lowest resistance the pair can have, so a healthy motor reaches the
    /// limit only while the Hall speed estimate lags a hard acceleration; a winding whose
    /// resistance is below that (an inter-turn short) exceeds it in every period it conducts.
    ///
    /// - A **winding** reading is compared with the limit itself.
    /// - A **link-average** reading is `≈ D·I` (the bus carries the winding current only while
    ///   the high side is on): it is compared with `D_hold × I_lim × 1.3`, where `D_hold` is
    ///   the largest duty applied lately (`duty_hold`, which falls no faster than the slowest
    ///   RC filter forgets, see [`crate::drive::DUTY_HOLD_DECAY_PER_MS`]) and at least
    ///   [`LINK_DUTY_FLOOR`]. The 1.3 covers the filter's ripple at its sampling instant: an
    ///   RC of `τ ≥ 2` PWM periods fed `I` for `D` of each period reads at most
    ///   `(1 − e^(−D·T/τ)) / (1 − e^(−T/τ)) · I ≤ 1.27·D·I`. A healthy motor (at most the
    ///   limit × the lowest over the real resistance, ≈ 7.3 A) then stays below it at any
    ///   sampling instant; a winding carrying 13 A or more — a shorted phase past the trip —
    ///   exceeds it at every instant, which the plain trip comparison (a link average of
    ///   `D·I` against 12 A) misses at every duty below ≈ 0.9.
    #[must_use]
    pub fn over_limit(&self, code: AdcCode, zero: AdcCode, duty_hold: Duty) -> bool {
        let codes = u32::from(code.get().abs_diff(zero.get()));
        match self.sense.reading {
            CurrentReading::Winding => codes > u32::from(self.limit_codes),
            CurrentReading::LinkAverage => {
                let duty = u64::from(duty_hold.max(LINK_DUTY_FLOOR).raw());
                // codes / limit > duty / DUTY_ONE × 130 / 100, in integers.
                let reading = u64::from(codes).saturating_mul(u64::from(DUTY_ONE) * 100);
                let allowed = duty
                    .saturating_mul(u64::from(self.limit_codes))
                    .saturating_mul(LINK_RIPPLE_PERCENT);
                reading > allowed
            }
        }
    }

    /// Whether the sampled current code is a motoring current of at least an eighth of the
    /// window's limit (1 A) — REQ-DRV-12's evidence that the winding is driven, not braked.
    /// A winding reading is compared as it is; a link average reads `≈ D·I`, so it is
    /// compared with `D` × an eighth of the limit, `D` the duty applied (at least
    /// [`MOTORING_DUTY_FLOOR`], which keeps the threshold four times above the worst
    /// board's noise).
    #[must_use]
    pub fn motoring(&self, code: AdcCode, zero: AdcCode, applied: Duty) -> bool {
        let Some(codes) = code.get().checked_sub(zero.get()).map(u64::from) else {
            return false;
        };
        let eighth = u64::from(self.limit_codes / 8);
        match self.sense.reading {
            CurrentReading::Winding => codes >= eighth,
            CurrentReading::LinkAverage => {
                let duty = u64::from(applied.max(MOTORING_DUTY_FLOOR).raw());
                codes.saturating_mul(u64::from(DUTY_ONE)) >= duty.saturating_mul(eighth)
            }
        }
    }

    /// The duty at which the winding current is zero for a back-EMF `emf_mv` (same sign
    /// convention as [`Self::window`]), on the bus `bus`.
    #[must_use]
    pub fn zero_current_duty(&self, bus: AdcCode, emf_mv: i32) -> Duty {
        let bus_mv = self.bus.millivolts(bus).max(self.bus.floor_mv);
        let e = if emf_mv > 0 { emf_mv.unsigned_abs().min(EMF_MAX_MV) } else { 0 };
        duty_of(e, bus_mv, true)
    }

    /// Whether `zero` is within the tolerance of the design zero.
    #[must_use]
    pub const fn zero_plausible(&self, zero: AdcCode) -> bool {
        zero.get().abs_diff(self.sense.design_zero.get()) <= self.sense.zero_tolerance
    }
}

/// The least duty a link-average reading's motoring threshold is scaled by: a quarter
/// (0.25 A of reading, four times the noisiest board's 0.06 A rms).
pub const MOTORING_DUTY_FLOOR: Duty = Duty::from_raw_clamped(16_384);

/// `mv / bus_mv` as a duty, rounded up (`round_up`, for a lower edge) or down (an upper
/// edge), at most [`DUTY_MAX`]. `mv ≤ 2 × EMF_MAX_MV`, so `mv × 4 096` fits a `u32`; the
/// quotient is scaled to the duty's 2⁻¹⁶ by × 16 (a resolution of 2.4 × 10⁻⁴).
fn duty_of(mv: u32, bus_mv: u32, round_up: bool) -> Duty {
    let scaled = mv.saturating_mul(4_096);
    let quotient = if round_up {
        scaled.saturating_add(bus_mv.saturating_sub(1)).checked_div(bus_mv)
    } else {
        scaled.checked_div(bus_mv)
    }
    .unwrap_or(u32::MAX);
    let raw = quotient.saturating_mul(16).min(u32::from(DUTY_MAX.raw()));
    Duty::from_raw_clamped(u16::try_from(raw).unwrap_or(DUTY_MAX.raw()))
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::drive::TIME_UNITS_PER_SECOND;

    /// taut's board's dead time.
    const DEAD_TIME: DriveTime = DriveTime::from_micros(1);

    /// `I·R` over `R`: the current a pair of `r_mohm` carries at the window's upper edge from
    /// rest (`e` = 0), mA.
    fn edge_current_ma(ir_mv: u32, r_mohm: u32) -> u32 {
        ir_mv * 1_000 / r_mohm
    }

    /// REQ-DRV-13: a winding 40 K hot has 15.7 % more resistance. With the cold value the
    /// window caps it at 6.9 A from rest; with the estimate it keeps the full 8 A — and a pair
    /// at the estimate's resistance never carries more.
    #[test]
    fn a_hot_winding_keeps_the_windows_torque() {
        let config = DriveConfig::PAPER;
        let hot = WindingHeat::with_rise(&config, 40_000_000);
        assert_eq!(hot.resistance_mohm(), 810);
        let real = hot.resistance_mohm();
        let cold_edge = edge_current_ma(config.ir_mv(), real);
        let hot_edge = edge_current_ma(hot.ir_mv(), real);
        assert_eq!(cold_edge, 6_913, "the cold window loses a seventh of the torque");
        assert_eq!(hot_edge, 8_000, "the hot window keeps it");
        // The window's upper edge from rest on 24 V follows.
        let bus = AdcCode::new(1_638);
        let (Some(cold), Some(warm)) =
            (config.window(bus, 0), config.window_with(bus, 0, hot.ir_mv()))
        else {
            panic!("a window from rest");
        };
        assert!(warm.high.raw() > cold.high.raw() + cold.high.raw() / 8, "{warm:?} {cold:?}");
        // Heated by the limit's current, the drive's own estimate rises and the edge with it.
        let drive = crate::drive::Drive::new();
        let mut heat = WindingHeat::cold(&config);
        for _ in 0..20 * 60_000 {
            heat.step(&config, config.limit_codes(), true, DriveTime::from_micros(50));
        }
        // 8 A in 0.7 Ω for a minute: 44.8 W × 1 K/W × (1 − e^(−60 s / 600 s)) = 4.26 K; the
        // rounding (heat down, cooling up) leaves it a little below.
        assert!((4_150_000..4_270_000).contains(&heat.rise_uk()), "{}", heat.rise_uk());
        assert!(heat.ir_mv() > config.ir_mv());
        assert_eq!(drive.ir_mv(), config.ir_mv(), "a drive starts cold");
    }

    /// The estimate's invariant: a reachable state is valid; a rise past the bound, a span
    /// left unadvanced, or a resistance or `I·R` that is not the rise's are not.
    #[test]
    fn the_heat_estimates_invariant_names_each_field() {
        let config = DriveConfig::PAPER;
        assert!(WindingHeat::cold(&config).is_valid(&config));
        let hot = WindingHeat::with_rise(&config, RISE_MAX_UK);
        assert!(hot.is_valid(&config));
        let mut past = hot;
        past.rise_uk = RISE_MAX_UK + 1;
        assert!(!past.is_valid(&config), "a rise past the bound");
        let mut long = hot;
        long.span = HEAT_SPAN * 2 - 1;
        assert!(long.is_valid(&config));
        long.span = HEAT_SPAN * 2;
        assert!(!long.is_valid(&config), "a span never advanced");
        let mut resistance = hot;
        resistance.resistance_mohm = 700;
        assert!(!resistance.is_valid(&config), "a resistance not the rise's");
        let mut ir = hot;
        ir.ir_mv = config.ir_mv();
        assert!(!ir.is_valid(&config), "an I·R not the rise's");
    }

    /// REQ-DRV-13: the cold value is never undercut: a winding that cools for hours returns to
    /// the cold resistance and stays there, and idle calls never lower it.
    #[test]
    fn the_cold_value_is_never_undercut() {
        let config = DriveConfig::PAPER;
        let mut heat = WindingHeat::with_rise(&config, RISE_MAX_UK);
        assert_eq!(heat.resistance_mohm(), 975, "the hot limit: 1.393 × 700 mΩ");
        let mut last = heat.rise_uk();
        for _ in 0..3 * 3_600_000 {
            heat.step(&config, 0, false, DriveTime::from_micros(1_000));
            assert!(heat.rise_uk() <= last, "an idle winding only cools");
            last = heat.rise_uk();
            assert!(heat.resistance_mohm() >= 700 && heat.ir_mv() >= config.ir_mv());
        }
        assert_eq!(heat.rise_uk(), 0, "cooled to the cold value");
        assert_eq!((heat.resistance_mohm(), heat.ir_mv()), (700, config.ir_mv()));
        // A current that flows only while the bridge is off is not heat.
        heat.step(&config, 4_095, false, DriveTime::from_micros(1_000));
        assert_eq!(heat.rise_uk(), 0);
    }

    /// The heat model's sums cannot overflow: a span closes early when its call count or its
    /// sum of squares would saturate, however short the calls.
    #[test]
    fn a_span_closes_before_its_sums_saturate() {
        let config = DriveConfig::PAPER;
        // Calls of no duration: the count closes the span, not the time.
        let mut heat = WindingHeat::with_rise(&config, 0);
        for _ in 0..u16::MAX - 1 {
            heat.step(&config, 100, true, DriveTime(0));
        }
        assert_eq!((heat.calls, heat.span), (u16::MAX - 1, 0), "still gathering");
        heat.step(&config, 100, true, DriveTime(0));
        assert_eq!((heat.calls, heat.squares, heat.span), (0, 0, 0), "closed at the count");
        // A sum of squares at its ceiling closes the span in the call that reached it.
        let mut heat = WindingHeat::with_rise(&config, 0);
        heat.step(&config, u16::MAX, true, DriveTime(1));
        assert_eq!((heat.calls, heat.squares, heat.span), (1, 4_294_836_225, 1), "gathering");
        heat.step(&config, u16::MAX, true, DriveTime(1));
        assert_eq!((heat.calls, heat.squares, heat.span), (0, 0, 0), "closed at the sum");
        // An ordinary call gathers.
        heat.step(&config, 100, true, DriveTime(1));
        assert_eq!((heat.calls, heat.squares, heat.span), (1, 10_000, 1));
    }

    #[test]
    fn the_paper_constants_are_what_new_computes() {
        let built = DriveConfig::new(
            CurrentSense::PAPER,
            BusSense::PAPER,
            CurrentLimit::PAPER,
            12_000,
            DEAD_TIME,
        );
        assert_eq!(built, Ok(DriveConfig::PAPER));
        // What the constructor derives for the paper's board: 8 A × 0.70 Ω; 12 A, 9.5 A and
        // 8 A over 6.1 mA per code, rounded up; 38 V and 40 V of a 60 V full scale, rounded up.
        let paper = DriveConfig::PAPER;
        assert_eq!((paper.trip_ma, paper.ir_mv), (12_000, 5_600));
        assert_eq!(
            (paper.trip_codes, paper.fold_back_codes, paper.limit_codes),
            (1_967, 1_557, 1_311)
        );
        assert_eq!((paper.regen_code, paper.over_code), (2_595, 2_731));
        assert_eq!(paper.dead_time, DriveTime::from_micros(1));
    }

    #[test]
    fn the_sense_converts_a_code_to_signed_milliamperes_from_its_zero() {
        // 0.2 V/A unidirectional: 1 639 codes above code 0 are 10.003 A.
        assert_eq!(
            CurrentSense::PAPER.amps(AdcCode::new(1_639), AdcCode::MIN),
            Amps::from_milli(10_003)
        );
        assert_eq!(CurrentSense::PAPER.amps(AdcCode::new(41), AdcCode::new(41)), Amps::ZERO);
        // 0.1 V/A at mid-rail: 82 codes below the tared zero are −1.000 A (toward zero).
        let bidirectional = CurrentSense::PER_PHASE_BIDIRECTIONAL;
        assert_eq!(
            bidirectional.amps(AdcCode::new(1_986), AdcCode::new(2_068)),
            Amps::from_milli(-1_000)
        );
        assert_eq!(
            bidirectional.amps(AdcCode::new(2_150), AdcCode::new(2_068)),
            Amps::from_milli(1_000)
        );
        // The whole range converts without overflow: 4 095 codes of 12.2 mA.
        assert_eq!(bidirectional.amps(AdcCode::MAX, AdcCode::MIN), Amps::from_milli(49_987));
    }

    #[test]
    fn a_three_volt_three_referred_bus_divider_is_accepted() {
        // The firmware's X-NUCLEO-IHM08M1: gain 0.0522 on a 3.3 V converter, 63.2 V full scale.
        let bus = BusSense { full_scale_mv: 63_218, ..BusSense::PAPER };
        let config =
            DriveConfig::new(CurrentSense::PAPER, bus, CurrentLimit::PAPER, 12_000, DEAD_TIME);
        let Ok(config) = config else { panic!("{config:?}") };
        // Code 1 555 of that divider is 24.0 V, to the mV below (the paper's 1:12 would call it
        // 22.8 V).
        assert_eq!(config.bus().volts(AdcCode::new(1_555)), Volts::from_milli(23_999));
        assert!(config.bus_over(AdcCode::new(2_592)) && !config.bus_over(AdcCode::new(2_591)));
    }

    #[test]
    fn the_accessors_report_the_configuration() {
        let config = DriveConfig::PAPER;
        // 8 A × 0.70 Ω; 12 A / 6.1 mA per code, rounded up.
        assert_eq!(config.ir_mv(), 5_600);
        assert_eq!(config.trip_codes(), 1_967);
        assert_eq!(config.trip(), Amps::from_int(12));
        assert_eq!(config.sense(), CurrentSense::PAPER);
        assert_eq!(config.bus(), BusSense::PAPER);
        assert_eq!(config.limit(), CurrentLimit::PAPER);
        // The bus in volts: 1 638 codes of a 60 V full scale = 23.994 V.
        assert_eq!(BusSense::PAPER.volts(AdcCode::new(1_638)).to_milli(), 23_994);
        assert_eq!(BusSense::PAPER.volts(AdcCode::new(0)), Volts::ZERO);
    }

    fn link_average_board() -> DriveConfig {
        let Ok(config) = DriveConfig::new(
            CurrentSense::LINK_AVERAGE_BIDIRECTIONAL,
            BusSense::PAPER,
            CurrentLimit::PAPER,
            12_000,
            DEAD_TIME,
        ) else {
            panic!("the link-average board is a valid configuration");
        };
        config
    }

    #[test]
    fn a_link_average_sense_never_folds_back_and_judges_the_limit_by_the_duty() {
        assert_eq!(CurrentSense::LINK_AVERAGE_BIDIRECTIONAL.reading, CurrentReading::LinkAverage);
        let config = link_average_board();
        let zero = AdcCode::new(2_048);
        let high = AdcCode::new(2_048 + 900); // 11 A of reading: under the trip
        assert!(!config.fold_back(high, zero));
        assert!(!config.overcurrent(high, zero));
        // 11 A of link average is over the limit at any duty: at full duty it is 11 A of
        // winding current (> 8 A × 1.3 = 10.4 A), at less it is more.
        assert!(config.over_limit(high, zero, DUTY_MAX));
        assert!(config.over_limit(high, zero, Duty::ZERO));
        // A winding sense reading the same current does both.
        let Ok(winding) = DriveConfig::new(
            CurrentSense::PER_PHASE_BIDIRECTIONAL,
            BusSense::PAPER,
            CurrentLimit::PAPER,
            12_000,
            DEAD_TIME,
        ) else {
            panic!("the per-phase board is a valid configuration");
        };
        assert!(winding.fold_back(high, zero) && winding.over_limit(high, zero, DUTY_MAX));
    }

    #[test]
    fn a_link_average_is_over_the_limit_beyond_duty_times_limit_times_thirteen_tenths() {
        let config = link_average_board();
        let zero = AdcCode::new(2_048);
        // 8 A at 12.2 mA per code: 656 codes (rounded up); × 1.3 = 852.8 codes at full duty.
        assert_eq!(config.limit_codes, 656);
        let half = Duty::from_raw_clamped(32_768);
        // At half duty: 426.4 codes allowed — a winding current of 10.4 A.
        assert!(!config.over_limit(AdcCode::new(2_048 + 426), zero, half));
        assert!(config.over_limit(AdcCode::new(2_048 + 427), zero, half));
        // Braking current reads below the zero and counts the same.
        assert!(!config.over_limit(AdcCode::new(2_048 - 426), zero, half));
        assert!(config.over_limit(AdcCode::new(2_048 - 427), zero, half));
        // Below the floor (1/8) the floor is the duty: 106.6 codes (1.3 A).
        for duty in [Duty::ZERO, Duty::from_raw_clamped(4_000), LINK_DUTY_FLOOR] {
            assert!(!config.over_limit(AdcCode::new(2_048 + 106), zero, duty));
            assert!(config.over_limit(AdcCode::new(2_048 + 107), zero, duty));
        }
        // Exactly at the allowance is not over it: 533 codes at duty 40 960 (0.625) is
        // 0.625 × 656 × 1.3 = 533.0 codes to the bit.
        let exact = Duty::from_raw_clamped(40_960);
        assert!(!config.over_limit(AdcCode::new(2_048 + 533), zero, exact));
        assert!(config.over_limit(AdcCode::new(2_048 + 534), zero, exact));
        // Just above the floor the duty itself counts.
        let above = Duty::from_raw_clamped(16_384);
        assert!(!config.over_limit(AdcCode::new(2_048 + 213), zero, above));
        assert!(config.over_limit(AdcCode::new(2_048 + 214), zero, above));
    }

    #[test]
    fn over_the_limit_is_strictly_beyond_its_codes() {
        let config = DriveConfig::PAPER;
        // 8 A at 6.1 mA per code: 1 311 codes (rounded up), whatever the duty.
        let zero = AdcCode::new(0);
        for duty in [Duty::ZERO, DUTY_MAX] {
            assert!(!config.over_limit(AdcCode::new(1_311), zero, duty));
            assert!(config.over_limit(AdcCode::new(1_312), zero, duty));
        }
    }

    #[test]
    fn regeneration_stops_at_the_regeneration_code() {
        let config = DriveConfig::PAPER;
        let regen = AdcCode::new(2_595);
        let below = AdcCode::new(2_594);
        let e = 20_000;
        let (Some(at), Some(under)) = (config.window(regen, e), config.window(below, e)) else {
            panic!("a rotor turning with the torque always has a window");
        };
        // At the threshold the lower edge is the back-EMF itself (no braking current) …
        let bus_mv = config.bus().millivolts(regen);
        assert!(current_ma(at.low, bus_mv, e) >= 0, "{at:?}");
        // … one code below, it brakes with up to the limit.
        let bus_mv = config.bus().millivolts(below);
        assert!(current_ma(under.low, bus_mv, e) < -7_000, "{under:?}");
    }

    #[test]
    fn the_back_emf_constant_is_ke_times_a_step_angle_times_the_time_unit() {
        // Ke = 60.1 mV·s/rad, 2π/24 rad per step, 10⁷ time units per second.
        let k = 60.1 * (2.0 * core::f64::consts::PI / 24.0) * f64::from(TIME_UNITS_PER_SECOND);
        let relative = (f64::from(CurrentLimit::PAPER.emf_mv_time) - k).abs() / k;
        assert!(relative < 0.001, "{k}");
        // 3 700 rpm = 1 480 steps/s: one step per 675.7 µs reads ≈ 23.3 V.
        let e = DriveConfig::PAPER.emf_mv(6_757);
        assert!((23_000..23_500).contains(&e), "{e}");
        assert_eq!(DriveConfig::PAPER.emf_mv(0), 0);
    }

    /// The current a duty gives, mA: `(duty·V − e)/R` with the limit's resistance.
    fn current_ma(duty: Duty, bus_mv: u32, emf_mv: i32) -> i64 {
        let applied = i64::from(duty.raw()) * i64::from(bus_mv) / 65_536;
        (applied - i64::from(emf_mv)) * 1_000 / i64::from(CurrentLimit::PAPER.resistance_mohm)
    }

    #[test]
    fn every_window_keeps_the_current_within_the_limit() {
        let config = DriveConfig::PAPER;
        let limit = i64::from(CurrentLimit::PAPER.limit_ma);
        let mut windows = 0;
        for bus_code in (0..=4_095u16).step_by(13) {
            let bus = AdcCode::new(bus_code);
            let bus_mv = config.bus().millivolts(bus).max(config.bus().floor_mv);
            for emf in (-30_000..=30_000).step_by(97) {
                match config.window(bus, emf) {
                    Some(window) => {
                        windows += 1;
                        assert!(window.low <= window.high, "{bus_code} {emf}");
                        // The upper edge motors with at most the limit (rounding: 0.1 %).
                        let high = current_ma(window.high, bus_mv, emf);
                        assert!(high <= limit + 10, "{bus_code} {emf} {high}");
                        // The lower edge brakes with at most the limit, unless the edge
                        // is the cap (a rotor faster than the bus can follow).
                        if window.low < DUTY_MAX {
                            let low = current_ma(window.low, bus_mv, emf);
                            assert!(low >= -limit - 10, "{bus_code} {emf} {low}");
                        }
                    }
                    None => assert!(emf < 0 && emf.unsigned_abs() >= config.ir_mv()),
                }
            }
        }
        assert!(windows > 100_000);
    }

    #[test]
    fn from_rest_on_24_volts_the_duty_is_at_most_a_quarter() {
        let bus = AdcCode::new(1_638); // 23.99 V
        let window = DriveConfig::PAPER
            .window(bus, 0)
            .unwrap_or(DutyWindow { low: DUTY_MAX, high: DUTY_MAX });
        assert_eq!(window.low, Duty::ZERO);
        // 5.6 V / 24 V = 0.233
        assert!((15_200..15_400).contains(&window.high.raw()), "{:?}", window.high);
    }

    #[test]
    fn above_the_regeneration_threshold_the_drive_does_not_brake() {
        let config = DriveConfig::PAPER;
        let high_bus = AdcCode::new(2_600); // 38.1 V
        let window = config
            .window(high_bus, 20_000)
            .unwrap_or(DutyWindow { low: Duty::ZERO, high: Duty::ZERO });
        assert_eq!(window.low, config.zero_current_duty(high_bus, 20_000));
        assert!(!config.bus_over(high_bus));
        assert!(config.bus_over(AdcCode::new(2_731)));
        assert!(!config.bus_over(AdcCode::new(2_730)));
    }

    #[test]
    fn a_rotor_turning_against_the_torque_faster_than_the_limit_allows_gets_no_window() {
        let config = DriveConfig::PAPER;
        let bus = AdcCode::new(1_638);
        assert_eq!(config.window(bus, -5_600), None);
        assert!(config.window(bus, -5_599).is_some());
    }

    #[test]
    fn the_trip_is_twelve_amps_of_reading_on_every_kind_of_sense() {
        for sense in [
            CurrentSense::PAPER,
            CurrentSense::PER_PHASE_BIDIRECTIONAL,
            CurrentSense::LINK_AVERAGE_BIDIRECTIONAL,
        ] {
            let config =
                DriveConfig::new(sense, BusSense::PAPER, CurrentLimit::PAPER, 12_000, DEAD_TIME);
            let Ok(config) = config else { panic!("{sense:?}") };
            let zero = sense.design_zero;
            let amps = |code: u16| {
                f64::from(code.abs_diff(zero.get())) * f64::from(sense.na_per_code) * 1e-9
            };
            // The trip is 12 A of the reading, to within the threshold's rounding (a link
            // average reads at most the winding current, so it never trips falsely).
            let code_amps = f64::from(sense.na_per_code) * 1e-9;
            for raw in zero.get()..=4_095 {
                let trips = config.overcurrent(AdcCode::new(raw), zero);
                let winding = amps(raw);
                if trips {
                    assert!(winding >= 12.0 - 2.0 * code_amps, "{sense:?} {raw}");
                } else {
                    assert!(winding < 12.0 + 2.0 * code_amps, "{sense:?} {raw}");
                }
            }
            // A bidirectional zero reads no current at all.
            assert!(!config.overcurrent(zero, zero));
        }
    }

    /// The turn-around bound: `Ke·a_max` (523 mV per 102.4 µs, 5.107 V/ms) over the time since
    /// the step before plus the Hall filter's 100 µs lag, capped at the largest back-EMF
    /// considered.
    #[test]
    fn the_turn_around_bound_is_the_acceleration_over_the_time_since_the_step_before() {
        let config = DriveConfig::PAPER;
        assert_eq!(config.turn_emf_mv(0), 510);
        assert_eq!(config.turn_emf_mv(9_000), 5_107);
        assert_eq!(config.turn_emf_mv(9_002), 5_108);
        assert_eq!(config.turn_emf_mv(116_475), 59_999);
        assert_eq!(config.turn_emf_mv(116_477), EMF_MAX_MV);
        assert_eq!(config.turn_emf_mv(u32::MAX), EMF_MAX_MV);
        // The paper's data (Ke 60.1 mV·s/rad; 8 A; 981 N through 25.4 mm / 20; 0.8 × 10⁻⁵
        // kg·m²), in f64, per 1 024 units: the constant is its value rounded up.
        let torque = 0.0601 * 8.0 + 981.0 * 0.0254 / (2.0 * core::f64::consts::PI * 20.0);
        let emf_per_1024 = 0.0601 * torque / 0.8e-5 * 1_024.0 / 10_000.0;
        let constant = f64::from(CurrentLimit::PAPER.accel_emf_mv_per_1024);
        assert!(emf_per_1024 <= constant && emf_per_1024 > constant - 1.0, "{emf_per_1024}");
    }

    #[test]
    fn refuses_configurations_that_do_not_make_sense() {
        let s = CurrentSense::PAPER;
        let b = BusSense::PAPER;
        let l = CurrentLimit::PAPER;
        assert_eq!(
            DriveConfig::new(CurrentSense { na_per_code: 0, ..s }, b, l, 12_000, DEAD_TIME),
            Err(DriveConfigError::CurrentSense)
        );
        assert_eq!(
            DriveConfig::new(s, b, l, 30_000, DEAD_TIME),
            Err(DriveConfigError::CurrentSense)
        );
        assert_eq!(
            DriveConfig::new(s, BusSense { regen_mv: 45_000, ..b }, l, 12_000, DEAD_TIME),
            Err(DriveConfigError::Bus)
        );
        // A maximum the converter cannot read is refused: at full scale (code 4 096) and just
        // below it (59.999 V, code 4 096 rounded up); 59.985 V is the last code, 4 095.
        for max_mv in [60_000, 59_999] {
            assert_eq!(
                DriveConfig::new(s, BusSense { max_mv, ..b }, l, 12_000, DEAD_TIME),
                Err(DriveConfigError::Bus),
                "{max_mv} mV"
            );
        }
        let top = DriveConfig::new(s, BusSense { max_mv: 59_985, ..b }, l, 12_000, DEAD_TIME);
        assert_eq!(top.map(|c| c.over_code), Ok(4_095));
        assert_eq!(
            DriveConfig::new(s, b, CurrentLimit { limit_ma: 12_000, ..l }, 12_000, DEAD_TIME),
            Err(DriveConfigError::Limit)
        );
        assert_eq!(
            DriveConfig::new(s, b, CurrentLimit { emf_mv_time: 0, ..l }, 12_000, DEAD_TIME),
            Err(DriveConfigError::Limit)
        );
        assert_eq!(
            DriveConfig::new(
                s,
                b,
                CurrentLimit { accel_emf_mv_per_1024: 0, ..l },
                12_000,
                DEAD_TIME
            ),
            Err(DriveConfigError::Limit)
        );
        // The dead time: a zero one (no both-off time at all) and one beyond 5 µs are refused,
        // the bounds themselves accepted and kept.
        for (dead_time, accepted) in [
            (DriveTime(0), false),
            (DEAD_TIME_MIN, true),
            (DEAD_TIME_MAX, true),
            (DriveTime(DEAD_TIME_MAX.0 + 1), false),
        ] {
            let config = DriveConfig::new(s, b, l, 12_000, dead_time);
            assert_eq!(
                config.map(|c| c.dead_time()),
                if accepted { Ok(dead_time) } else { Err(DriveConfigError::DeadTime) }
            );
        }
    }
}
