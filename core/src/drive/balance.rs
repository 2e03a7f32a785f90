//! Winding balance: an inter-turn short seen in the currents of the three conducting pairs.
//!
//! # Why
//!
//! A short between turns of one phase leaves that phase fewer turns: less resistance and less
//! back-EMF. The drive's current window is computed from the motor's nameplate (its lowest
//! resistance, its back-EMF constant), so it cannot hold such a winding to its limit, and on a
//! board whose current reading is an RC-filtered DC-link average no single sample need show
//! the excess (REQ-DRV-05's other rules catch the shorts that do show). What every board does
//! show is the *imbalance*: six-step drives one pair of phases per sector, and sectors `k`
//! and `k + 3` drive the same pair the other way round, so a revolution drives three pairs.
//! In a healthy motor turning at speed the three carry the same mean current; with one phase
//! shorted the two pairs through it carry several amperes more than the third (and the third
//! may brake).
//!
//! # Rule
//!
//! Per conducting pair, the reading from the tared zero is averaged with a short exponential
//! filter (1/8 per sample: the pair's latest sector visit). When the accepted sector comes
//! round to `S0` after a revolution that visited all six sectors within
//! [`REVOLUTION_MAX`] (10 ms: a fast revolution, in which no healthy acceleration changes the
//! current much) and whose pairs carry a mean of at least 1/8 of the window's limit (1 A), the
//! revolution is judged: a spread between the pairs above a quarter of the limit (2 A of
//! reading) *and* above half their mean is a strike, any other judged revolution takes one
//! back. [`IMBALANCE_STRIKES`] net strikes are an overcurrent the window cannot hold (E-10).
//! Measured on the twin's family (both sensing kinds, Hall mounting error ±5°, inertia,
//! friction, bus 20–30 V): while the rule was drafted, no healthy revolution of 390 machine
//! cycles was a strike (exact per-revolution means) while 29 of 60 injected 80–95 % shorts
//! made 10 or more; as built, 0 false faults in 1000 machine cycles and 52 of 60 shorts latched
//! (with the drive's other rules).
//!
//! Everything here is additions, shifts and comparisons: no division in the fast loop.

use super::DriveTime;
use super::hall::Sector;

/// The longest revolution judged: 10 ms.
pub const REVOLUTION_MAX: DriveTime = DriveTime::from_micros(10_000);

/// Net strikes that latch an overcurrent: 20 fast revolutions (20–200 ms at speed).
pub const IMBALANCE_STRIKES: u8 = 20;

/// The per-pair means and the revolution being watched.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct WindingBalance {
    /// Per pair (sector index mod 3), the filtered reading from the zero, 1/16 codes.
    means: [i32; 3],
    /// Sectors visited in this revolution (bit per sector index).
    seen: u8,
    /// Time since this revolution began (saturating).
    ticks: DriveTime,
    /// Net strikes.
    strikes: u8,
}

impl WindingBalance {
    /// Nothing seen yet.
    #[must_use]
    pub const fn new() -> Self {
        Self { means: [0; 3], seen: 0, ticks: DriveTime(0), strikes: 0 }
    }

    /// Net strikes so far.
    #[must_use]
    pub const fn strikes(&self) -> u8 {
        self.strikes
    }

    /// One fast-loop call. `before` is the sector accepted while the sampled current flowed
    /// (`conducted`: the bridge drove then), `now` the sector accepted in this call,
    /// `reading` the sample's distance from the tared zero (codes, signed), `limit` the
    /// window's limit in codes. Returns whether the net strikes reached
    /// [`IMBALANCE_STRIKES`].
    pub fn update(
        &mut self,
        before: Option<Sector>,
        now: Option<Sector>,
        conducted: bool,
        reading: i32,
        elapsed: DriveTime,
        limit: u16,
    ) -> bool {
        let Some(sector) = before else {
            self.seen = 0;
            self.ticks = DriveTime(0);
            return false;
        };
        self.ticks = DriveTime(self.ticks.0.saturating_add(elapsed.0));
        self.seen |= 1_u8 << sector.index();
        if conducted {
            let pair = sector_pair(sector);
            let mean = pair_mean(&self.means, pair);
            let moved = mean.saturating_add(reading.saturating_mul(16).saturating_sub(mean) >> 3);
            set_pair_mean(&mut self.means, pair, moved);
        }
        if now != Some(Sector::S0) || before == Some(Sector::S0) {
            return false;
        }
        // A revolution ends: judge it if it was whole and fast.
        if self.seen == 0b11_1111 && self.ticks <= REVOLUTION_MAX {
            self.judge(limit);
        }
        self.seen = 0;
        self.ticks = DriveTime(0);
        self.strikes >= IMBALANCE_STRIKES
    }

    /// One judged revolution: a strike, a strike taken back, or (too little current) neither.
    fn judge(&mut self, limit: u16) {
        let [a, b, c] = self.means;
        let sum = a.saturating_add(b).saturating_add(c).saturating_abs();
        // Mean ≥ limit/8: sum (1/16 codes) ≥ 3 × 16 × limit / 8 = 6 × limit.
        if sum < i32::from(limit).saturating_mul(6) {
            return;
        }
        let spread = a.max(b).max(c).saturating_sub(a.min(b).min(c));
        // Spread > limit/4 (in 1/16 codes: 4 × limit) and > mean/2 = sum/6.
        let strike = spread > i32::from(limit).saturating_mul(4) && spread.saturating_mul(6) > sum;
        self.strikes =
            if strike { self.strikes.saturating_add(1) } else { self.strikes.saturating_sub(1) };
    }
}

/// The pair a sector drives: sectors `k` and `k + 3` drive the same two phases.
const fn sector_pair(sector: Sector) -> usize {
    match sector {
        Sector::S0 | Sector::S3 => 0,
        Sector::S1 | Sector::S4 => 1,
        Sector::S2 | Sector::S5 => 2,
    }
}

fn pair_mean(means: &[i32; 3], pair: usize) -> i32 {
    means.get(pair).copied().unwrap_or(0)
}

fn set_pair_mean(means: &mut [i32; 3], pair: usize, value: i32) {
    if let Some(mean) = means.get_mut(pair) {
        *mean = value;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One 50 µs PWM period.
    const PERIOD: DriveTime = DriveTime::from_micros(50);

    /// The window's limit on taut's own board: 8 A = 1 311 codes.
    const LIMIT: u16 = 1_311;

    /// One revolution of `periods_per_sector` calls per sector, pair `p` reading `ma[p]`
    /// milliamperes (1 311 codes per 8 A); returns whether it latched.
    fn revolution(balance: &mut WindingBalance, periods_per_sector: u32, ma: [i32; 3]) -> bool {
        let mut latched = false;
        let sectors = Sector::ALL;
        for (k, sector) in sectors.iter().enumerate() {
            let next = sectors.get(k + 1).copied().unwrap_or(Sector::S0);
            let codes = ma[k % 3] * i32::from(LIMIT) / 8_000;
            for call in 0..periods_per_sector {
                let now = if call + 1 == periods_per_sector { next } else { *sector };
                latched |= balance.update(Some(*sector), Some(now), true, codes, PERIOD, LIMIT);
            }
        }
        latched
    }

    #[test]
    fn a_balanced_motor_never_strikes() {
        let mut balance = WindingBalance::new();
        for _ in 0..200 {
            assert!(!revolution(&mut balance, 10, [5_000, 5_500, 4_600]));
        }
        assert_eq!(balance.strikes(), 0);
    }

    #[test]
    fn a_shorted_phase_latches_after_twenty_fast_revolutions() {
        let mut balance = WindingBalance::new();
        // Pairs 0 and 1 through the shorted phase: 9 A; pair 2: 2 A.
        let mut latched_at = None;
        for n in 1..=40 {
            if revolution(&mut balance, 10, [9_000, 9_000, 2_000]) {
                latched_at = Some(n);
                break;
            }
        }
        // The first revolution starts from zero means but judges (S0 is reached after S5).
        assert_eq!(latched_at, Some(u32::from(IMBALANCE_STRIKES)));
    }

    #[test]
    fn spread_must_exceed_a_quarter_of_the_limit_and_half_the_mean() {
        // 1.9 A of spread on a 2 A mean: more than half the mean, less than 2 A.
        let mut small = WindingBalance::new();
        for _ in 0..40 {
            assert!(!revolution(&mut small, 10, [2_900, 2_900, 1_000]));
        }
        // 3 A of spread on a 10 A mean: more than 2 A, less than half the mean.
        let mut relative = WindingBalance::new();
        for _ in 0..40 {
            assert!(!revolution(&mut relative, 10, [11_000, 11_000, 8_000]));
        }
        // Both: strikes.
        let mut both = WindingBalance::new();
        for _ in 0..5 {
            revolution(&mut both, 10, [6_000, 6_000, 1_000]);
        }
        assert_eq!(both.strikes(), 5);
    }

    #[test]
    fn slow_revolutions_and_small_currents_are_not_judged() {
        // 201 periods per revolution of 6 sectors × 34 = 204 periods > 10 ms: not judged.
        let mut slow = WindingBalance::new();
        for _ in 0..40 {
            assert!(!revolution(&mut slow, 34, [9_000, 9_000, 2_000]));
        }
        assert_eq!(slow.strikes(), 0);
        // 33 periods per sector (198 periods ≤ 200): judged.
        let mut fast = WindingBalance::new();
        revolution(&mut fast, 33, [9_000, 9_000, 2_000]);
        assert_eq!(fast.strikes(), 1);
        // A mean below 1 A is not judged, however unbalanced.
        let mut weak = WindingBalance::new();
        for _ in 0..40 {
            revolution(&mut weak, 10, [1_200, 1_200, 0]);
        }
        assert_eq!(weak.strikes(), 0);
    }

    /// A balance with these pair means (1/16 codes), judged once.
    fn judged(means: [i32; 3]) -> u8 {
        let mut balance = WindingBalance { means, ..WindingBalance::new() };
        balance.judge(LIMIT);
        balance.strikes()
    }

    #[test]
    fn each_threshold_of_a_strike_is_strict_at_its_boundary() {
        // In 1/16 codes the limit is 1 311 × 16; the mean threshold is a sum of 6 × limit,
        // the spread threshold 4 × limit, the relative one 6 × spread > sum.
        let limit = i32::from(LIMIT);
        // The mean at exactly 1 A is judged (a strike: one pair carries it all).
        assert_eq!(judged([6 * limit, 0, 0]), 1);
        assert_eq!(judged([6 * limit - 1, 0, 0]), 0);
        // A spread of exactly 2 A is not a strike; one more 1/16 code is.
        let m = 874;
        assert_eq!(judged([4 * limit + m, m, m]), 0);
        assert_eq!(judged([4 * limit + m + 1, m, m]), 1);
        // A spread of exactly half the mean (6 × spread = sum) is not a strike.
        assert_eq!(judged([15_000, 12_000, 9_000]), 0);
        assert_eq!(judged([15_000, 11_999, 9_000]), 1);
        // A negative mean (a bidirectional board while braking) is judged by its size.
        assert_eq!(judged([-6 * limit, 0, 0]), 1);
    }

    #[test]
    fn a_revolution_of_exactly_ten_milliseconds_is_judged() {
        let mut balance = WindingBalance {
            means: [9_000 * 16, 9_000 * 16, 0],
            seen: 0b11_1111,
            ticks: DriveTime(REVOLUTION_MAX.0 - PERIOD.0),
            strikes: 0,
        };
        balance.update(Some(Sector::S5), Some(Sector::S0), false, 0, PERIOD, LIMIT);
        assert_eq!(balance.strikes(), 1);
        let mut longer = WindingBalance {
            means: [9_000 * 16, 9_000 * 16, 0],
            seen: 0b11_1111,
            ticks: DriveTime(REVOLUTION_MAX.0 - PERIOD.0 + 1),
            strikes: 0,
        };
        longer.update(Some(Sector::S5), Some(Sector::S0), false, 0, PERIOD, LIMIT);
        assert_eq!(longer.strikes(), 0);
    }

    #[test]
    fn a_balanced_revolution_takes_a_strike_back() {
        let mut balance = WindingBalance::new();
        for _ in 0..10 {
            revolution(&mut balance, 10, [9_000, 9_000, 2_000]);
        }
        assert_eq!(balance.strikes(), 10);
        for _ in 0..3 {
            revolution(&mut balance, 10, [5_000, 5_000, 5_000]);
        }
        assert_eq!(balance.strikes(), 7);
    }

    #[test]
    fn an_unknown_rotor_position_restarts_the_revolution() {
        let mut balance = WindingBalance::new();
        revolution(&mut balance, 10, [9_000, 9_000, 2_000]);
        assert_eq!(balance.strikes(), 1);
        // Half a revolution, the sensors lost, then S0 again: not a whole revolution.
        for sector in [Sector::S0, Sector::S1, Sector::S2] {
            balance.update(Some(sector), Some(sector), true, 1_000, PERIOD, LIMIT);
        }
        balance.update(None, None, false, 0, PERIOD, LIMIT);
        for sector in [Sector::S3, Sector::S4, Sector::S5] {
            balance.update(Some(sector), Some(sector), true, 1_000, PERIOD, LIMIT);
        }
        balance.update(Some(Sector::S5), Some(Sector::S0), true, 1_000, PERIOD, LIMIT);
        assert_eq!(balance.strikes(), 1);
    }
}
