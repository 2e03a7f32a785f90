//! The drivetrain's wear trend: how long the motor test takes, against its commissioning.
//!
//! # Theory of operation
//!
//! A drivetrain wears toward more drag: a dry screw, a worn nut, a gearbox losing its grease,
//! a carriage slide gathering dust. The machine already has a measurement of that drag taken
//! under the same conditions every time: the self-test's motor test drives the unloaded
//! carriage from rest at a fixed duty ([`super::MOTOR_TEST_DUTY`]) until it has turned
//! [`super::MOTOR_TEST_STEPS`] Hall steps, and fails (E-07) when that takes longer than
//! [`super::MOTOR_TEST_TIMEOUT`]. With the rotor's inertia and the motor's torque at that duty
//! fixed, the time it takes grows with the drag it overcomes — a drivetrain on its way to
//! failing that test takes longer at every boot before it does. A figure taken in the pulls
//! themselves would mix the drag with what the stringer chose: the speed setting, the
//! string, the tension.
//!
//! The record keeps two figures ([`DrivetrainTrend`]): the motor test's time at
//! commissioning — the first motor test the record sees, taken again whenever a calibration
//! is accepted (a serviced machine is recommissioned by calibrating it) — and its trend, a
//! running average over the self-tests since (each new time weighs a quarter), which a
//! single slow boot on a cold morning or a low bus moves little. When the trend exceeds the
//! commissioning time by [`WEAR_MARGIN_PERCENT`] the machine shows the wear notice (n-05)
//! in Ready, once a self-test. On the twin the motor test is 25 % slower at about ten times
//! a new drivetrain's drag (a drag that grows a step every boot is noticed at about twelve:
//! the trend lags it by a few boots); the carriage stalls in a pull (E-09) at about eighteen
//! times and the motor test fails (E-07) at nearly thirty: the notice comes while the machine
//! still strings, with time to service it. A new machine's test varies by a few per cent from
//! boot to boot (the bus, the winding's temperature), far inside the margin. The service page shows the trend as a percentage of
//! the commissioning time.
//!
//! The arithmetic is a few integer operations once per self-test; nothing runs in the
//! 1 ms tick otherwise.

/// How much slower than at commissioning the motor test's trend may get before the wear
/// notice, per cent.
pub const WEAR_MARGIN_PERCENT: u32 = 25;

/// The motor test's times, ms (`0`: none yet), as the record keeps them.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct DrivetrainTrend {
    /// The motor test's time when the drivetrain was commissioned (the first self-test the
    /// record saw, or the one before the last accepted calibration).
    pub commissioned_ms: u16,
    /// The running average of the motor tests since, each new one weighing a quarter.
    pub trend_ms: u16,
}

impl DrivetrainTrend {
    /// Takes one motor test's time, `elapsed_ms`; whether the trend is now past the margin
    /// (the wear notice is due).
    pub fn observe(&mut self, elapsed_ms: u32) -> bool {
        let time = u16::try_from(elapsed_ms).unwrap_or(u16::MAX).max(1);
        if self.commissioned_ms == 0 {
            self.commissioned_ms = time;
        }
        self.trend_ms = if self.trend_ms == 0 {
            time
        } else {
            // (3·trend + time) / 4, rounded to the nearest: below 2¹⁸, no overflow.
            let sum = u32::from(self.trend_ms).saturating_mul(3).saturating_add(u32::from(time));
            u16::try_from(sum.saturating_add(2) >> 2).unwrap_or(u16::MAX)
        };
        self.worn()
    }

    /// Whether the trend is more than [`WEAR_MARGIN_PERCENT`] above the commissioning time.
    #[must_use]
    pub fn worn(&self) -> bool {
        let limit = u32::from(self.commissioned_ms)
            .saturating_mul(100_u32.saturating_add(WEAR_MARGIN_PERCENT));
        self.commissioned_ms > 0 && u32::from(self.trend_ms).saturating_mul(100) > limit
    }

    /// The trend as a percentage of the commissioning time (100: as new), if both are known.
    #[must_use]
    pub fn percent(&self) -> Option<u32> {
        if self.trend_ms == 0 {
            return None;
        }
        let scaled = u32::from(self.trend_ms).saturating_mul(100);
        let half = u32::from(self.commissioned_ms) >> 1;
        scaled.saturating_add(half).checked_div(u32::from(self.commissioned_ms))
    }

    /// Recommissions the drivetrain at its present trend (a calibration was accepted: the
    /// machine is as its owner wants it now).
    pub fn recommission(&mut self) {
        if self.trend_ms > 0 {
            self.commissioned_ms = self.trend_ms;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_motor_test_commissions_and_a_steady_one_never_warns() {
        let mut trend = DrivetrainTrend::default();
        for _ in 0..100 {
            assert!(!trend.observe(271));
        }
        assert_eq!(trend, DrivetrainTrend { commissioned_ms: 271, trend_ms: 271 });
        assert_eq!(trend.percent(), Some(100));
    }

    #[test]
    fn one_slow_boot_moves_the_trend_a_quarter_and_does_not_warn() {
        let mut trend = DrivetrainTrend { commissioned_ms: 300, trend_ms: 300 };
        // Twice as slow once (a cold morning, a low bus): a quarter of the way.
        assert!(!trend.observe(600));
        assert_eq!(trend.trend_ms, 375);
        assert_eq!(trend.percent(), Some(125));
        // Back to normal: it decays again.
        assert!(!trend.observe(300));
        assert_eq!(trend.trend_ms, 356);
    }

    #[test]
    fn a_steadily_slower_test_warns_once_past_the_margin() {
        let mut trend = DrivetrainTrend::default();
        assert!(!trend.observe(250));
        // The limit: 25 % above 250 ms is 312.5 ms. A drivetrain whose test is 32 % slower
        // now: the trend passes the margin after a few boots, not before it.
        let mut boots = 0;
        while !trend.observe(330) {
            boots += 1;
            assert!(trend.trend_ms <= 312, "{}", trend.trend_ms);
            assert!(boots < 20);
        }
        assert_eq!((boots, trend.trend_ms), (5, 316));
        assert_eq!(trend.percent(), Some(126));
        // Exactly at the margin is not past it.
        let at = DrivetrainTrend { commissioned_ms: 200, trend_ms: 250 };
        assert!(!at.worn());
        assert!(DrivetrainTrend { trend_ms: 251, ..at }.worn());
    }

    #[test]
    fn a_calibration_recommissions_at_the_trend() {
        let mut trend = DrivetrainTrend { commissioned_ms: 250, trend_ms: 400 };
        assert!(trend.worn());
        trend.recommission();
        assert_eq!(trend, DrivetrainTrend { commissioned_ms: 400, trend_ms: 400 });
        assert!(!trend.worn());
        // Nothing to recommission at before a motor test.
        let mut empty = DrivetrainTrend::default();
        empty.recommission();
        assert_eq!(empty, DrivetrainTrend::default());
        assert_eq!(empty.percent(), None);
        assert!(!empty.worn());
        // No trend to recommission at: the commissioning is kept.
        let mut untested = DrivetrainTrend { commissioned_ms: 250, trend_ms: 0 };
        untested.recommission();
        assert_eq!(untested.commissioned_ms, 250);
        // A trend with no commissioning (a record's bytes can say so) is never wear.
        let uncommissioned = DrivetrainTrend { commissioned_ms: 0, trend_ms: 300 };
        assert!(!uncommissioned.worn());
        assert_eq!(uncommissioned.percent(), None);
    }

    #[test]
    fn extreme_times_saturate() {
        let mut trend = DrivetrainTrend::default();
        assert!(!trend.observe(0));
        assert_eq!(trend.commissioned_ms, 1);
        assert!(trend.observe(u32::MAX));
        assert_eq!(trend.trend_ms, 16_385);
        let mut full = DrivetrainTrend { commissioned_ms: u16::MAX, trend_ms: u16::MAX };
        assert!(!full.observe(u32::MAX));
        assert_eq!(full.percent(), Some(100));
    }
}
