//! The calibration states' bookkeeping: which point a reading is, what the pull to it is,
//! its label, and what confirming it records and proposes next (REQ-CAL-06, REQ-CAL-10).
//!
//! # Theory of operation
//!
//! Commissioning pulls to each of the four points twice (`CALIBRATION_READINGS` = 8
//! readings in two passes). The entry averages the raw reading over the whole time the
//! operator keys the reference gauge's value in, and confirming pairs that mean with the
//! keyed value: the first pass keeps each point, checks the pass at its end and sends the
//! carriage home for the second; the second merges into the first; after the last reading
//! the merged points are fitted and stored, or refused with a notice and the previous
//! calibration kept.

use super::{AfterRelease, CALIBRATION_SPEED, Chart, Context, ENTRY_MAX, State};
use crate::machine::fault::Notice;
use crate::machine::panel::{self, Beep};
use crate::sense::calibration::{
    CALIBRATION_PASSES, CALIBRATION_POINTS, CALIBRATION_READINGS, CALIBRATION_TARGETS, Calibration,
    CalibrationError, CalibrationPoint, merge_passes,
};
use crate::settings::{KnotBoost, PreStretch, PullSettings, Speed};
use crate::units::Kgf;

/// The index into the points (0–3) of calibration reading `reading` (0–7: two passes).
#[must_use]
pub fn point_of_reading(reading: u8) -> usize {
    usize::from(reading).checked_rem(CALIBRATION_POINTS).unwrap_or(0)
}

/// The controller settings for calibration reading `reading` (0–7: the points 0–3 in two
/// passes): its point's target by the raw reading, [`CALIBRATION_SPEED`], no pre-stretch.
#[must_use]
pub fn calibration_settings(reading: u8) -> PullSettings {
    let target =
        CALIBRATION_TARGETS.get(point_of_reading(reading)).copied().unwrap_or(Kgf::from_int(10));
    let speed = Speed::new(CALIBRATION_SPEED).unwrap_or(Speed::MIN);
    PullSettings::new(target, speed, PreStretch::NONE, KnotBoost::NONE).unwrap_or_default()
}

/// The label of calibration reading `reading` (0 to [`CALIBRATION_READINGS`] − 1), one digit
/// for the point and, after the first pass, one for the pass: `CAL1`…`CAL4` in the first pass,
/// `C2-1`…`C2-4` in the second. The service page labels each point's raw reading with its
/// first-pass label, so the two follow [`CALIBRATION_POINTS`] together.
#[must_use]
pub const fn calibration_label(reading: usize) -> [u8; 4] {
    let (pass, point) =
        match (reading.checked_div(CALIBRATION_POINTS), reading.checked_rem(CALIBRATION_POINTS)) {
            (Some(pass), Some(point)) => (pass, point),
            _ => (0, 0),
        };
    let point_digit = panel::last_digit(point.saturating_add(1));
    if pass == 0 {
        [b'C', b'A', b'L', point_digit]
    } else {
        [b'C', panel::last_digit(pass.saturating_add(1)), b'-', point_digit]
    }
}

// One digit each for the pass and the point is what the four-digit display has room for.
const _: () = assert!(
    CALIBRATION_POINTS <= 9 && CALIBRATION_PASSES <= 9,
    "a calibration label has one digit for the point and one for the pass"
);

/// The mean of `ticks` readings summing to `sum` (kgf bits), if any were taken.
pub(super) fn entry_average(sum: i64, ticks: u32) -> Option<Kgf> {
    let mean = sum.checked_div(i64::from(ticks))?;
    i32::try_from(mean).ok().map(Kgf::from_bits)
}

impl Chart {
    /// Records calibration reading `reading` (its point in the first pass; merged into it in
    /// the second, REQ-CAL-06) and proposes the next step: the next point, home between the
    /// passes, or — after the last reading, or at the first reading that cannot be right —
    /// home to Ready with the calibration stored or refused (`n-02`, the old one kept).
    pub(super) fn confirm_point(
        &mut self,
        context: &mut Context,
        raw: Kgf,
        reading: u8,
        entered: u16,
    ) -> State {
        let taken = CalibrationPoint {
            raw,
            reference: Kgf::from_hundredths(i32::from(entered.min(ENTRY_MAX))),
        };
        let first_pass = usize::from(reading) < CALIBRATION_POINTS;
        let merged = match self.calibration_points.get_mut(point_of_reading(reading)) {
            Some(slot) if first_pass => {
                *slot = taken;
                Ok(())
            }
            Some(slot) => merge_passes(*slot, taken).map(|point| *slot = point),
            None => Err(CalibrationError::NotMonotonic),
        };
        let next = reading.saturating_add(1);
        let fitted = merged.and_then(|()| {
            // The first pass is checked on its own before the second starts: a mistyped
            // reading is refused now, not after four more pulls.
            let pass_done = point_of_reading(next) == 0;
            if pass_done { Calibration::new(&self.calibration_points).map(Some) } else { Ok(None) }
        });
        match fitted {
            Ok(None) => return State::calibration_pull(next, 0, 0),
            Ok(Some(_)) if usize::from(next) < CALIBRATION_READINGS => {
                return State::releasing(0, AfterRelease::NextPass);
            }
            Ok(Some(calibration)) => {
                self.calibration = calibration;
                self.record.calibration = Some(self.calibration_points);
                self.record.stamp_calibration(self.scale.zero());
                self.record.drivetrain.recommission();
                self.dirty = true;
                context.out.store = true;
                context.beep = Some(Beep::AtTension);
            }
            Err(_) => {
                self.notice = Some(Notice::CalibrationRejected);
                context.beep = Some(Beep::Refused);
            }
        }
        State::releasing(0, AfterRelease::Ready)
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Sample, Tick};
    use super::*;
    use crate::io::{Inputs, Key, LimitSwitches};
    use crate::machine::panel::KeyEvent;
    use crate::settings::PullKind;
    use crate::store::Record;

    /// REQ-CAL-10: a point pairs the gauge's reading with the raw reading averaged over the
    /// whole entry, not with the reading at the Start that confirms it (here a slip in the
    /// last third of the entry moved the reading 0.2 kgf).
    #[test]
    fn a_calibration_point_pairs_the_gauge_with_the_entry_mean() {
        let mut chart = Chart::new(Record::default(), &crate::test_support::paper_board());
        let (mut point, mut entered, mut sum, mut ticks) = (0_u8, 1_077_u16, 0_i64, 0_u32);
        let mut tick = |chart: &mut Chart, raw: Kgf, key: Option<KeyEvent>| {
            let sample = Sample { raw_average: raw, key, ..Sample::default() };
            let mut context = Context::new(sample);
            let _ = chart.calibration_entry(
                &mut context,
                &Tick(sample),
                &mut point,
                &mut entered,
                &mut sum,
                &mut ticks,
            );
            context.next
        };
        for n in 0..3_000 {
            let raw = if n < 2_000 { Kgf::from_int(10) } else { Kgf::from_tenths(102) };
            assert_eq!(tick(&mut chart, raw, None), None);
        }
        let next = tick(&mut chart, Kgf::from_tenths(102), Some(KeyEvent::Press(Key::Start)));
        assert_eq!(next, Some(State::calibration_pull(1, 0, 0)));
        // (2 000 × 10 + 1 001 × 10.2) / 3 001 = 10.0667 kgf.
        let paired = chart.calibration_points.first().map(|p| (p.raw.to_milli(), p.reference));
        assert_eq!(paired, Some((10_067, Kgf::from_hundredths(1_077))));
        // No reading at all (a Start in the entry's first tick cannot happen, but the pairing
        // is still defined): the reading of that tick.
        assert_eq!(entry_average(0, 0), None);
        assert_eq!(entry_average(-30, 3), Some(Kgf::from_bits(-10)));
    }

    #[test]
    fn calibration_settings_pull_to_the_four_points() {
        // Both passes: readings 0–3 and 4–7 pull to the same four points.
        for reading in 0..8_u8 {
            let target = CALIBRATION_TARGETS.get(usize::from(reading % 4)).copied();
            let settings = calibration_settings(reading);
            assert_eq!(Some(settings.tension()), target, "reading {reading}");
            assert_eq!(Some(settings.peak_target(PullKind::Main)), target);
        }
        if (CALIBRATION_POINTS, CALIBRATION_PASSES) == (4, 2) {
            let labels: [[u8; 4]; 8] = core::array::from_fn(calibration_label);
            assert_eq!(
                labels,
                [*b"CAL1", *b"CAL2", *b"CAL3", *b"CAL4", *b"C2-1", *b"C2-2", *b"C2-3", *b"C2-4"]
            );
        }
    }

    /// Every reading's label is its own and shows on the four digits whole: no character
    /// without a seven-segment form, for however many points and passes there are.
    #[test]
    fn calibration_labels_fit_the_display_and_name_each_reading_once() {
        let labels: [[u8; 4]; CALIBRATION_READINGS] = core::array::from_fn(calibration_label);
        for (reading, label) in labels.iter().enumerate() {
            let shown = panel::text(label);
            assert!(shown.iter().all(|&digit| digit != panel::BLANK), "{label:?}");
            let same = labels.iter().filter(|&other| other == label).count();
            assert_eq!(same, 1, "reading {reading}: {label:?}");
            let point = u8::try_from(point_of_reading(u8::try_from(reading).unwrap_or(0)));
            assert_eq!(label.last().copied(), point.ok().map(|p| b'1' + p));
        }
    }

    /// Confirms calibration reading `reading` with the raw reading `raw` and the keyed
    /// `entered` (hundredths); returns the proposed state and whether it asked to store.
    fn confirm(chart: &mut Chart, reading: u8, raw: i32, entered: i32) -> (State, bool) {
        let mut context = Context::new(Sample::default());
        let entered = u16::try_from(entered).unwrap_or(0);
        let next = chart.confirm_point(&mut context, Kgf::from_hundredths(raw), reading, entered);
        (next, context.out.store)
    }

    /// The hundredths of calibration reading `reading`'s target.
    fn target_hundredths(reading: u8) -> i32 {
        1_000 * (i32::from(reading % 4) + 1)
    }

    /// REQ-CAL-06: the eight readings — the first pass kept point by point, checked at its
    /// end and sent home for the second; the second merged into the first; after the eighth
    /// the merged points are fitted and stored.
    #[test]
    fn a_calibration_takes_two_passes_and_stores_their_means() {
        let mut chart = Chart::new(Record::default(), &crate::test_support::paper_board());
        for reading in 0..8_u8 {
            // Raw 0.50 low in the first pass and 0.46 low in the second; the gauge 0.04
            // above the target in the first pass, 0.02 in the second.
            let target = target_hundredths(reading);
            let (raw, entered) =
                if reading < 4 { (target - 50, target + 4) } else { (target - 46, target + 2) };
            let (next, store) = confirm(&mut chart, reading, raw, entered);
            let expected = match reading {
                3 => State::releasing(0, AfterRelease::NextPass),
                7 => State::releasing(0, AfterRelease::Ready),
                r => State::calibration_pull(r.saturating_add(1), 0, 0),
            };
            assert_eq!(next, expected, "after reading {reading}");
            assert_eq!(store, reading == 7, "stored after reading {reading}");
            assert_eq!(chart.record.calibration.is_some(), reading == 7);
        }
        assert_eq!(chart.notice, None);
        let mean = |a: i32, b: i32| {
            (Kgf::from_hundredths(a).to_bits() + Kgf::from_hundredths(b).to_bits()) >> 1
        };
        let Some(stored) = chart.record.calibration else { panic!("nothing stored") };
        for (point, stored) in (0_u8..).zip(stored) {
            let target = target_hundredths(point);
            assert_eq!(stored.raw.to_bits(), mean(target - 50, target - 46), "point {point}");
            assert_eq!(stored.reference.to_bits(), mean(target + 4, target + 2), "point {point}");
        }
        assert_eq!(chart.calibration.points(), &stored);
        // Home between the passes: the second pass's first point.
        let home = Sample {
            inputs: Inputs {
                limits: LimitSwitches { home: true, end: false },
                ..Inputs::default()
            },
            ..Sample::default()
        };
        let mut context = Context::new(home);
        let _ = chart.releasing(&mut context, &Tick(home), &mut 0, &mut AfterRelease::NextPass);
        assert_eq!(context.next, Some(State::calibration_pull(4, 0, 0)));
    }

    /// REQ-CAL-06: a second pass 0.30 kgf off the first at one point is refused (n-02, the
    /// old calibration kept, home to Ready); so is a first pass that cannot be fitted, at its
    /// fourth reading, before a second pass starts.
    #[test]
    fn a_calibration_whose_passes_disagree_or_whose_first_pass_is_wrong_is_refused() {
        let mut chart = Chart::new(Record::default(), &crate::test_support::paper_board());
        for reading in 0..7_u8 {
            let target = target_hundredths(reading);
            let entered = if reading == 6 { target + 30 } else { target };
            let (next, store) = confirm(&mut chart, reading, target - 50, entered);
            let refused = reading == 6;
            if refused || reading == 3 {
                let then = if refused { AfterRelease::Ready } else { AfterRelease::NextPass };
                assert_eq!(next, State::releasing(0, then), "after reading {reading}");
            }
            assert!(!store);
            assert_eq!(chart.notice.is_some(), refused, "after reading {reading}");
        }
        assert_eq!(chart.notice, Some(Notice::CalibrationRejected));
        assert_eq!(chart.record.calibration, None);
        // A first pass keyed 20.00 at every point: refused at its end.
        let mut chart = Chart::new(Record::default(), &crate::test_support::paper_board());
        for reading in 0..4_u8 {
            let (next, _) = confirm(&mut chart, reading, target_hundredths(reading) - 50, 2_000);
            if reading == 3 {
                assert_eq!(next, State::releasing(0, AfterRelease::Ready));
            }
        }
        assert_eq!(chart.notice, Some(Notice::CalibrationRejected));
        assert_eq!(chart.record.calibration, None);
    }
}
