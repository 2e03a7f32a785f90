//! Four-point calibration of the load cell against a reference gauge: raw kgf → true kgf.
//!
//! # Theory of operation
//!
//! The paper's calibration (section 6.2): a reference force gauge is hooked in at the
//! machine's right side, the machine pulls to **10, 20, 30 and 40 kg** by its own (raw)
//! reading, and at each point the operator keys in what the gauge shows: the
//! [`CALIBRATION_POINTS`] pairs (raw reading, reference reading) of [`CalibrationPoints`].
//! The fifth pair is implicit: the load cell is tared before the calibration, so the
//! **zero** point reads raw 0 at a true 0 kgf by definition.
//!
//! **Two passes.** The machine pulls the four points twice, homing in between, and the
//! operator reads the gauge eight times ([`CALIBRATION_PASSES`]); each point is the mean of
//! its two readings ([`merge_passes`]), so the gauge's own reading error reaches the fit with
//! σ/√2 — the gauge's reading error is what the calibrated hold's sensing offset is made of,
//! so halving its variance is worth two passes (the figures are in `docs/RESULTS.md`). The two
//! readings of one point must agree:
//! their corrections (reference − raw) more than [`REPEAT_LIMIT`] apart is a mistyped or
//! misread entry, or a gauge or hook that slipped between the passes, and the calibration is
//! refused ([`CalibrationError::PassesDisagree`]). Homing between the passes makes the
//! second pass an independent one: slack taken up again, the hook re-seated, every point
//! approached from below as a pull approaches its target.
//!
//! The number of points is one constant, [`CALIBRATION_POINTS`]: the targets
//! ([`calibration_targets`], 10 kgf apart from 10 kgf), the fit, the stored record's layout
//! and the machine's calibration states all follow it (a test builds the fit and the record
//! layout for five points).
//!
//! The paper's own load-cell test (fig. 21) found the chain linear from 5 to 40 kg but
//! **poorly linear below 5 kg**. taut therefore corrects in two pieces:
//!
//! - **Working range, at and above the knee (5 kgf true):** a straight line
//!   `true = gain × raw + offset`, fitted by least squares through the loaded points.
//!   A line, rather than a polyline through every point, because the reference gauge has its
//!   own error (a good digital tension calibrator: σ ≈ 0.02 kgf) and the least-squares fit
//!   averages it over the points (for four): the fitted line's error is
//!   σ·√(1/4 + (x − x̄)²/Σ(xᵢ − x̄)²), i.e. 0.5 σ at 25 kgf and ≤ 0.9 σ anywhere in 8–40 kgf, where a polyline would pass every
//!   point's full error σ straight into the tensions near that point.
//! - **Below the knee:** the sensor's non-linearity there is not captured by any of the loaded
//!   points, so the fitted line is not trusted; instead the correction interpolates linearly
//!   from the zero point (raw 0 → 0 kgf, exact by definition) to the line's value at the
//!   knee (raw `knee` → 5 kgf). The correction is continuous and strictly increasing over the
//!   whole range. Below 5 kgf the machine only needs to know "the slack is gone" and "the
//!   string is loose", for which this is more than adequate; no pull is ever set below 5 kgf.
//!
//! Below the zero reading the low piece continues with its slope, so a reading slightly
//! below zero (noise on an unloaded cell) stays slightly negative instead of jumping.
//!
//! # Validation
//!
//! [`Calibration::new`] rejects a set of points that cannot come from a healthy chain and a
//! careful operator ([`CalibrationError`]): raw or reference readings not strictly
//! increasing from the zero point, a reference outside the plausible band, a fitted gain off
//! by more than 25 % or an offset beyond ±3 kgf (the four-point calibration corrects a chain, it cannot make a
//! broken one right), a point more than 0.5 kgf off the fitted line (a mistyped reading),
//! and a low-range sensitivity (zero point to knee) more than ×2 off the fitted one. The
//! per-sample [`Calibration::correct`] has no
//! error path.
//!
//! # Fixed point
//!
//! Tensions are Q15.16 ([`Kgf`]). The gain and the low-range slope are **Q1.30** (`i32`,
//! range ±2, resolution 9.3 × 10⁻¹⁰): a 2⁻¹⁶ gain (Q15.16's resolution) would already cost
//! 0.8 mkgf at 50 kgf. `correct` is one 32 × 32 → 64-bit product, a shift and an add, and
//! rounds once: `|correct(raw) − exact| ≤ 2⁻¹⁶ kgf` for the stored parameters. The fit itself
//! (at construction) is exact integer arithmetic on the raw bits up to the final rounding of
//! the gain and offset.

use crate::fixed::saturate_i32;
use crate::units::Kgf;

/// The number of loaded calibration points: 10, 20, 30 and 40 kgf (the paper's four).
pub const CALIBRATION_POINTS: usize = 4;

/// The passes over the points: 2 (see the module docs).
pub const CALIBRATION_PASSES: usize = 2;

/// The gauge readings a calibration takes: every point in every pass.
pub const CALIBRATION_READINGS: usize = CALIBRATION_POINTS * CALIBRATION_PASSES;

/// The largest difference between the two passes' corrections (reference − raw) at one
/// point: 0.25 kgf. The gauge's reading error (σ ≈ 0.02 kgf) and a stick-slip detent on the
/// calibration cord (≈ 0.02 kgf) make a few hundredths; a digit keyed wrongly makes 0.1 or
/// more, a hook or gauge that slipped between the passes more still.
pub const REPEAT_LIMIT: Kgf = Kgf(crate::units::Q16::lit("0.25"));

/// The first calibration target and the spacing of the others: 10 kgf.
pub const CALIBRATION_SPACING: Kgf = Kgf::from_int(10);

/// The tensions the calibration pulls to, by the raw reading: 10, 20, 30, 40 kgf.
pub const CALIBRATION_TARGETS: [Kgf; CALIBRATION_POINTS] = calibration_targets();

/// The targets of an `N`-point calibration: `CALIBRATION_SPACING × (1, 2, …, N)`.
#[must_use]
#[allow(
    clippy::indexing_slicing,
    reason = "a const fn cannot call `get_mut`; `index < N` is the loop's own bound, and a \
              `const` that indexed out of bounds would fail to compile rather than panic"
)]
pub const fn calibration_targets<const N: usize>() -> [Kgf; N] {
    let mut out = [Kgf::ZERO; N];
    let mut bits = 0_i32;
    let mut index = 0;
    while index < N {
        bits = bits.saturating_add(CALIBRATION_SPACING.to_bits());
        out[index] = Kgf::from_bits(bits);
        index = index.saturating_add(1);
    }
    out
}

/// The true tension above which the straight-line fit is used: 5 kgf (paper fig. 21).
pub const KNEE: Kgf = Kgf::from_int(5);

/// The fitted gain must lie in `[0.8, 1.25]` (Q1.30 bits).
pub const GAIN_RANGE_Q30: (i32, i32) = (858_993_459, 1_342_177_280);

/// The fitted offset must lie within ±3 kgf.
pub const OFFSET_LIMIT: Kgf = Kgf::from_int(3);

/// Largest distance of a calibration point from the fitted line: 0.5 kgf.
pub const RESIDUAL_LIMIT: Kgf = Kgf(crate::units::Q16::lit("0.5"));

/// Reference readings must lie in `[KNEE, 55 kgf]`: every calibration point is a loaded one.
pub const REFERENCE_MAX: Kgf = Kgf::from_int(55);

/// The low piece's slope must be within `[0.5, 2]` (Q1.30; `2` is stored as `i32::MAX`): a
/// chain whose sensitivity below 5 kgf differs from the fitted one by more than ×2 is broken.
const LOW_SLOPE_RANGE_Q30: (i32, i32) = (536_870_912, i32::MAX);

/// One in Q1.30.
const ONE_Q30: i32 = 1 << 30;

/// Why a calibration was rejected.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum CalibrationError {
    /// The raw readings (the tare's 0, then the points) or the reference readings do not
    /// strictly increase.
    NotMonotonic,
    /// A reference reading lies outside `[KNEE, REFERENCE_MAX]`.
    ReferenceOutOfRange,
    /// The fitted gain lies outside [`GAIN_RANGE_Q30`].
    GainOutOfRange,
    /// The fitted offset lies beyond ±[`OFFSET_LIMIT`].
    OffsetOutOfRange,
    /// A point lies more than [`RESIDUAL_LIMIT`] from the fitted line (a mistyped reading).
    PointOffLine,
    /// The line's 5 kgf reading is at or below the tare's 0, or the zero-to-knee piece's
    /// sensitivity is more than ×2 away from the fitted one.
    ZeroImplausible,
    /// The two passes' corrections (reference − raw) at one point differ by more than
    /// [`REPEAT_LIMIT`].
    PassesDisagree,
}

/// One calibration point: what the machine read and what the reference gauge read.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct CalibrationPoint {
    /// The machine's uncorrected reading ([`crate::sense::load_cell::LoadCellScale::to_kgf`]),
    /// averaged while holding.
    pub raw: Kgf,
    /// The reference gauge's reading, keyed in by the operator.
    pub reference: Kgf,
}

/// The raw material of a calibration, as the persisted record keeps it: the loaded points in
/// increasing order (the zero point is the tare's, raw 0 at 0 kgf).
///
/// The record keeps the measured points, not derived coefficients: the correction is rebuilt
/// from them (and re-validated) at boot, so a change to how the correction is computed never
/// needs a format change.
pub type CalibrationPoints = [CalibrationPoint; CALIBRATION_POINTS];

/// Points that make the identity correction: raw = reference at each target.
pub const IDENTITY_POINTS: CalibrationPoints = identity_points();

/// The identity points of an `N`-point calibration.
#[allow(
    clippy::indexing_slicing,
    reason = "a const fn cannot call `get_mut`; `index < N` is the loop's own bound"
)]
const fn identity_points<const N: usize>() -> [CalibrationPoint; N] {
    let targets = calibration_targets::<N>();
    let mut out = [CalibrationPoint { raw: Kgf::ZERO, reference: Kgf::ZERO }; N];
    let mut index = 0;
    while index < N {
        out[index] = CalibrationPoint { raw: targets[index], reference: targets[index] };
        index = index.saturating_add(1);
    }
    out
}

/// One point of the second pass merged into the same point of the first: the mean of the
/// two raw readings and the mean of the two reference readings, or
/// [`CalibrationError::PassesDisagree`] when their corrections (reference − raw) differ by
/// more than [`REPEAT_LIMIT`]. The means are rounded toward −∞ by 2⁻¹⁷ kgf at most.
///
/// # Errors
/// [`CalibrationError::PassesDisagree`], as above.
pub fn merge_passes(
    first: CalibrationPoint,
    second: CalibrationPoint,
) -> Result<CalibrationPoint, CalibrationError> {
    let correction = |p: CalibrationPoint| {
        i64::from(p.reference.to_bits()).saturating_sub(i64::from(p.raw.to_bits()))
    };
    let disagreement = correction(first).saturating_sub(correction(second)).saturating_abs();
    if disagreement > i64::from(REPEAT_LIMIT.to_bits()) {
        return Err(CalibrationError::PassesDisagree);
    }
    let mean = |a: Kgf, b: Kgf| {
        Kgf::from_bits(saturate_i32(
            i64::from(a.to_bits()).saturating_add(i64::from(b.to_bits())) >> 1,
        ))
    };
    Ok(CalibrationPoint {
        raw: mean(first.raw, second.raw),
        reference: mean(first.reference, second.reference),
    })
}

/// A validated load-cell correction. See the module docs for the two pieces.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Calibration {
    points: CalibrationPoints,
    /// Working-range gain, Q1.30.
    gain_q30: i32,
    /// Working-range offset.
    offset: Kgf,
    /// The raw reading where the line gives [`KNEE`].
    knee_raw: Kgf,
    /// Low-range slope, Q1.30: `KNEE / (knee_raw − zero)`.
    low_slope_q30: i32,
}

impl Default for Calibration {
    fn default() -> Self {
        Self::IDENTITY
    }
}

/// `(a × b_q30) >> 30`, rounded to nearest: a Q15.16 value times a Q1.30 factor.
fn mul_q30(a: Kgf, factor_q30: i32) -> i64 {
    let product = i64::from(a.to_bits()).saturating_mul(i64::from(factor_q30));
    product.saturating_add(1 << 29) >> 30
}

/// `num / den` as Q1.30 by restoring long division, for `0 ≤ num < 2·den`, `den > 0`;
/// `None` otherwise. A constant 31-step loop, so no wide intermediate is needed.
fn ratio_q30(num: i64, den: i64) -> Option<i32> {
    if den <= 0 || num < 0 || num >= den.checked_mul(2)? {
        return None;
    }
    let mut quotient: i64 = 0;
    let mut remainder = num;
    // 31 quotient bits: one integer bit and 30 fraction bits (bound: 31 iterations).
    for _ in 0..31 {
        quotient = quotient.checked_mul(2)?;
        if remainder >= den {
            remainder = remainder.checked_sub(den)?;
            quotient = quotient.checked_add(1)?;
        }
        remainder = remainder.checked_mul(2)?;
    }
    // The loop computed floor(num·2³⁰ / den) with the first bit being the integer part.
    // Round on the next bit.
    if remainder >= den {
        quotient = quotient.checked_add(1)?;
    }
    i32::try_from(quotient).ok().or(Some(i32::MAX))
}

impl Calibration {
    /// The identity correction: `correct(raw) == raw` everywhere.
    pub const IDENTITY: Self = Self {
        points: IDENTITY_POINTS,
        gain_q30: ONE_Q30,
        offset: Kgf::ZERO,
        knee_raw: KNEE,
        low_slope_q30: ONE_Q30,
    };

    /// Fits and validates a correction from the points (see the module docs).
    ///
    /// # Errors
    /// [`CalibrationError`] when the points cannot come from a healthy chain.
    pub fn new(points: &CalibrationPoints) -> Result<Self, CalibrationError> {
        let Line { gain_q30, offset } = fit_line(points)?;
        // knee_raw = (KNEE − offset) / gain; gain ∈ [0.8, 1.25] and |offset| ≤ 3 keep it in
        // 1.6 ..= 10 kgf, far inside i32 bits after the division.
        let knee_num = i64::from(KNEE.saturating_sub(offset).to_bits()) << 30;
        let knee_bits = knee_num.checked_div(i64::from(gain_q30)).unwrap_or(0);
        let knee_raw = Kgf::from_bits(i32::try_from(knee_bits).unwrap_or(0));
        let span = i64::from(knee_raw.to_bits());
        if span <= 0 {
            return Err(CalibrationError::ZeroImplausible);
        }
        let low_slope_q30 = ratio_q30(i64::from(KNEE.to_bits()), span)
            .filter(|slope| *slope >= LOW_SLOPE_RANGE_Q30.0 && *slope <= LOW_SLOPE_RANGE_Q30.1)
            .ok_or(CalibrationError::ZeroImplausible)?;
        Ok(Self { points: *points, gain_q30, offset, knee_raw, low_slope_q30 })
    }

    /// The points this correction was fitted from (what the stored record keeps).
    #[must_use]
    pub const fn points(&self) -> &CalibrationPoints {
        &self.points
    }

    /// The working-range gain, Q1.30 (`1 << 30` = 1.0).
    #[must_use]
    pub const fn gain_q30(&self) -> i32 {
        self.gain_q30
    }

    /// The working-range offset.
    #[must_use]
    pub const fn offset(&self) -> Kgf {
        self.offset
    }

    /// The raw reading where the working range starts (the line reads [`KNEE`] there).
    #[must_use]
    pub const fn knee_raw(&self) -> Kgf {
        self.knee_raw
    }

    /// The straight line's value at `raw`.
    fn on_line(&self, raw: Kgf) -> Kgf {
        Line { gain_q30: self.gain_q30, offset: self.offset }.at(raw)
    }

    /// The true tension for an uncorrected reading `raw`: the line at and above the knee,
    /// the zero-to-knee interpolation below it. Continuous, non-decreasing, saturating.
    #[must_use]
    pub fn correct(&self, raw: Kgf) -> Kgf {
        if raw >= self.knee_raw {
            self.on_line(raw)
        } else {
            Kgf::from_bits(saturate_i32(mul_q30(raw, self.low_slope_q30)))
        }
    }

    /// The invariant every constructed calibration satisfies (for proofs and the stored
    /// record): gain in range, the knee above the zero reading, low slope in range.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.gain_q30 >= GAIN_RANGE_Q30.0
            && self.gain_q30 <= GAIN_RANGE_Q30.1
            && self.offset.abs() <= OFFSET_LIMIT
            && self.knee_raw > Kgf::ZERO
            && self.low_slope_q30 >= LOW_SLOPE_RANGE_Q30.0
    }
}

/// A fitted straight line `true = gain × raw + offset`.
struct Line {
    /// Q1.30.
    gain_q30: i32,
    offset: Kgf,
}

impl Line {
    /// The line's value at `raw`.
    fn at(&self, raw: Kgf) -> Kgf {
        let bits = mul_q30(raw, self.gain_q30).saturating_add(i64::from(self.offset.to_bits()));
        Kgf::from_bits(saturate_i32(bits))
    }
}

/// The least-squares line through `N` loaded points, validated: strictly increasing raw and
/// reference readings (from the tare's 0), references in `[KNEE, REFERENCE_MAX]`, gain and
/// offset in range, every point within [`RESIDUAL_LIMIT`] of the line. Generic in the point
/// count so that another count is one constant ([`CALIBRATION_POINTS`]).
fn fit_line<const N: usize>(points: &[CalibrationPoint; N]) -> Result<Line, CalibrationError> {
    let mut previous_raw = Kgf::ZERO;
    let mut previous_reference = Kgf::ZERO;
    for point in points {
        if point.raw <= previous_raw || point.reference <= previous_reference {
            return Err(CalibrationError::NotMonotonic);
        }
        if point.reference < KNEE || point.reference > REFERENCE_MAX {
            return Err(CalibrationError::ReferenceOutOfRange);
        }
        previous_raw = point.raw;
        previous_reference = point.reference;
    }

    // Least squares on the raw bits: gain = (nΣxy − ΣxΣy) / (nΣx² − (Σx)²).
    // |x|, |y| < 2³¹ bits but are bounded in practice by the plausibility checks below;
    // every sum saturates, and a saturated sum fails those checks.
    let (mut sx, mut sy, mut sxx, mut sxy) = (0_i64, 0_i64, 0_i64, 0_i64);
    for point in points {
        let x = i64::from(point.raw.to_bits());
        let y = i64::from(point.reference.to_bits());
        sx = sx.saturating_add(x);
        sy = sy.saturating_add(y);
        sxx = sxx.saturating_add(x.saturating_mul(x));
        sxy = sxy.saturating_add(x.saturating_mul(y));
    }
    let n = i64::try_from(N).map_err(|_| CalibrationError::GainOutOfRange)?;
    let den = n.saturating_mul(sxx).saturating_sub(sx.saturating_mul(sx));
    let num = n.saturating_mul(sxy).saturating_sub(sx.saturating_mul(sy));
    let gain_q30 = ratio_q30(num, den).ok_or(CalibrationError::GainOutOfRange)?;
    if gain_q30 < GAIN_RANGE_Q30.0 || gain_q30 > GAIN_RANGE_Q30.1 {
        return Err(CalibrationError::GainOutOfRange);
    }
    // offset = (Σy − gain·Σx) / n in Q15.16 bits, rounded to nearest (ties up).
    let gain_sx = i64::from(gain_q30).saturating_mul(sx).saturating_add(1 << 29) >> 30;
    let offset_bits = sy
        .saturating_sub(gain_sx)
        .saturating_add(n >> 1)
        .checked_div_euclid(n)
        .ok_or(CalibrationError::OffsetOutOfRange)?;
    let offset_bits = i32::try_from(offset_bits).map_err(|_| CalibrationError::OffsetOutOfRange)?;
    let line = Line { gain_q30, offset: Kgf::from_bits(offset_bits) };
    if line.offset.abs() > OFFSET_LIMIT {
        return Err(CalibrationError::OffsetOutOfRange);
    }
    for point in points {
        if line.at(point.raw).saturating_sub(point.reference).abs() > RESIDUAL_LIMIT {
            return Err(CalibrationError::PointOffLine);
        }
    }
    Ok(line)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::valid;

    /// Thousandths of a kgf (`Kgf::from_milli` only takes ±32 767).
    fn milli(value: i32) -> Kgf {
        Kgf::from_bits(((i64::from(value) << 16) / 1000) as i32)
    }

    #[test]
    fn identity_is_identity() {
        assert_eq!(Calibration::new(&IDENTITY_POINTS), Ok(Calibration::IDENTITY));
        for m in (-2_000..=55_000).step_by(37) {
            let raw = milli(m);
            assert_eq!(Calibration::IDENTITY.correct(raw), raw);
        }
    }

    /// `true = 1.05·raw + 0.4`, sampled at the targets of an `N`-point calibration.
    fn exact_line<const N: usize>() -> [CalibrationPoint; N] {
        calibration_targets::<N>().map(|target| CalibrationPoint {
            raw: Kgf::from_bits(
                ((i64::from(target.to_bits()) - i64::from(milli(400).to_bits())) * 100 / 105)
                    as i32,
            ),
            reference: target,
        })
    }

    #[test]
    fn recovers_an_exact_line() {
        let raw_of = |t: i32| (t - 400) * 100 / 105;
        let cal = valid(Calibration::new(&exact_line::<CALIBRATION_POINTS>()));
        for t in (6_000..=50_000).step_by(100) {
            let got = ((i64::from(cal.correct(milli(raw_of(t))).to_bits()) * 1000) >> 16) as i32;
            assert!((got - t).abs() <= 2, "{t}: {got}");
        }
        assert!(cal.is_valid());
    }

    /// Another point count is one constant: the targets and the fit are generic in it, and a
    /// five-point calibration (10–50 kgf) fits the same line as the four-point one (the
    /// stored record's layout for five points is checked in `store`).
    #[test]
    fn a_five_point_calibration_is_one_constant_away() {
        assert_eq!(calibration_targets::<CALIBRATION_POINTS>(), CALIBRATION_TARGETS);
        let five = calibration_targets::<5>();
        assert_eq!(five.map(Kgf::to_tenths_rounded), [100, 200, 300, 400, 500]);
        let four = valid(fit_line(&exact_line::<4>()));
        let five = valid(fit_line(&exact_line::<5>()));
        for line in [&four, &five] {
            assert!((line.gain_q30 - 1_127_428_915).abs() < 2_000, "{}", line.gain_q30);
            assert!((line.offset.to_bits() - milli(400).to_bits()).abs() <= 2);
        }
        let mut wrong = exact_line::<5>();
        wrong[2].reference = milli(31_000);
        assert!(matches!(fit_line(&wrong), Err(CalibrationError::PointOffLine)));
    }

    /// Points at every calibration target, whatever their number: `of(index, target)` gives
    /// the raw reading and the reference in thousandths of a kgf.
    fn points_at(of: impl Fn(i32, i32) -> (i32, i32)) -> CalibrationPoints {
        let mut index = 0;
        CALIBRATION_TARGETS.map(|target| {
            let (raw, reference) = of(index, ((i64::from(target.to_bits()) * 1000) >> 16) as i32);
            index += 1;
            CalibrationPoint { raw: milli(raw), reference: milli(reference) }
        })
    }

    #[test]
    fn rejects_bad_points() {
        let fit = |of: fn(i32, i32) -> (i32, i32)| Calibration::new(&points_at(of));
        assert!(fit(|_, t| (t, t)).is_ok());
        // Two points swapped.
        let swapped = fit(|i, t| match i {
            1 => (t + 10_000, t + 10_000),
            2 => (t - 10_000, t - 10_000),
            _ => (t, t),
        });
        assert_eq!(swapped, Err(CalibrationError::NotMonotonic));
        // The first point at or below the tare's 0.
        assert_eq!(
            fit(|i, t| (if i == 0 { 0 } else { t }, t)),
            Err(CalibrationError::NotMonotonic)
        );
        // A mistyped reference.
        let mistyped = fit(|i, t| (t, if i == 1 { t + 1_000 } else { t }));
        assert_eq!(mistyped, Err(CalibrationError::PointOffLine));
        let steep = fit(|_, t| (t / 2 + 10_000, (t / 2 + 10_000) * 13 / 10));
        assert_eq!(steep, Err(CalibrationError::GainOutOfRange));
        assert_eq!(fit(|_, t| (t, t + 4_000)), Err(CalibrationError::OffsetOutOfRange));
        let low = fit(|i, t| (t, if i == 0 { 4_000 } else { t }));
        assert_eq!(low, Err(CalibrationError::ReferenceOutOfRange));
        // true = 1.2·raw + 2.9: the line reads 5 kgf at raw 1.75, so the tare-to-knee piece
        // would be 2.86 times as sensitive as the line.
        let lifted = fit(|_, t| ((t - 2_900) * 10 / 12, t));
        assert_eq!(lifted, Err(CalibrationError::ZeroImplausible));
    }

    #[test]
    fn correction_is_continuous_and_increasing() {
        // A chain reading 1.5 % low with small scatter.
        let cal = valid(Calibration::new(&points_at(|i, t| {
            let scatter = match i % 5 {
                0 => 10,
                1 => -10,
                2 => 20,
                3 => 0,
                _ => -20,
            };
            (t * 985 / 1_000, t + scatter)
        })));
        let mut previous = cal.correct(milli(-5_000));
        for m in -4_999..=55_000 {
            let now = cal.correct(milli(m));
            assert!(now >= previous, "{m}");
            assert!(now.saturating_sub(previous) < milli(3), "jump at {m}");
            previous = now;
        }
        assert_eq!(cal.correct(Kgf::ZERO), Kgf::ZERO);
    }

    /// REQ-CAL-06: a second pass's reading is averaged into the first's, and refused when
    /// the two corrections differ by more than [`REPEAT_LIMIT`] either way.
    #[test]
    fn the_passes_are_averaged_and_must_agree() {
        let point = |raw: i32, reference: i32| CalibrationPoint {
            raw: Kgf::from_hundredths(raw),
            reference: Kgf::from_hundredths(reference),
        };
        // 20.00 read as 20.04, then 20.10 read as 20.10: the mean of each.
        let (first, second) = (point(2_000, 2_004), point(2_010, 2_010));
        let mean = |a: Kgf, b: Kgf| Kgf::from_bits((a.to_bits() + b.to_bits()) >> 1);
        assert_eq!(
            merge_passes(first, second),
            Ok(CalibrationPoint {
                raw: mean(first.raw, second.raw),
                reference: mean(first.reference, second.reference)
            })
        );
        assert!((mean(first.raw, second.raw).to_milli() - 20_050).abs() <= 1);
        // Corrections +0.04 and −0.21: 0.25 apart, accepted; a hundredth more, refused.
        assert!(merge_passes(point(2_000, 2_004), point(2_021, 2_000)).is_ok());
        assert_eq!(
            merge_passes(point(2_000, 2_004), point(2_022, 2_000)),
            Err(CalibrationError::PassesDisagree)
        );
        assert_eq!(
            merge_passes(point(2_022, 2_000), point(2_000, 2_004)),
            Err(CalibrationError::PassesDisagree)
        );
        // A digit mistyped in the second pass (30.14 keyed as 31.14) is caught.
        assert_eq!(
            merge_passes(point(3_010, 3_014), point(3_012, 3_114)),
            Err(CalibrationError::PassesDisagree)
        );
        // Extreme bits neither panic nor wrap.
        let extreme =
            CalibrationPoint { raw: Kgf::from_bits(i32::MAX), reference: Kgf::from_bits(i32::MAX) };
        assert_eq!(merge_passes(extreme, extreme), Ok(extreme));
        let low =
            CalibrationPoint { raw: Kgf::from_bits(i32::MIN), reference: Kgf::from_bits(i32::MIN) };
        assert_eq!(merge_passes(low, low), Ok(low));
    }
}
