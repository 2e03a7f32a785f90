//! Physics of the family's parameters: each test drives the twin through taut-core's drive
//! and pins one new behaviour — backlash, the gripper on the load cell, the bus clamp, the
//! current-sensing kinds, the bus-voltage code, hum, spikes, the friction range — and the
//! scheduled faults.
#![allow(
    clippy::float_arithmetic,
    clippy::arithmetic_side_effects,
    clippy::indexing_slicing,
    clippy::cast_precision_loss,
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::print_stdout,
    clippy::expect_used,
    reason = "host tests compute expectations in f64, index small recorded vectors, print \
              their figures, and a helper's failed expectation is a test failure"
)]

use taut_core::drive::{Direction, DriveCommand, DriveFault, LegState, Phase};
use taut_core::io::{Inputs, Outputs};
use taut_sim::family::ranges;
use taut_sim::params::NEWTONS_PER_KGF;
use taut_sim::{
    Axis, CurrentSenseParams, Fault, LoadCellFault, StringKind, StringState, Trace, Twin,
    TwinConfig, drive_at, run,
};

/// The family centre with every random sensor effect off, for tests that compare sensors
/// with the truth.
fn quiet(kind: StringKind) -> TwinConfig {
    let mut c = TwinConfig::family_centre(kind);
    c.load_cell.noise_volts = 0.0;
    c.load_cell.spikes.pwm_probability = 0.0;
    c.load_cell.spikes.commutation_probability = 0.0;
    c.load_cell.hum.volts = 0.0;
    c.current_sense.noise_amps = 0.0;
    c.bus_sense.noise_volts = 0.0;
    c
}

/// Drive in `direction` at `duty`, ramped over the first `ramp_ms`.
fn ramped(direction: Direction, duty: f64, ramp_ms: u32) -> impl FnMut(&Inputs) -> Outputs {
    let mut tick = 0_u32;
    move |_| {
        tick += 1;
        let ramp = if ramp_ms == 0 { 1.0 } else { (f64::from(tick) / f64::from(ramp_ms)).min(1.0) };
        Outputs { drive: drive_at(direction, duty * ramp), ..Outputs::default() }
    }
}

fn coast() -> impl FnMut(&Inputs) -> Outputs {
    |_| Outputs::default()
}

fn at(duty: f64, direction: Direction) -> impl FnMut(&Inputs) -> Outputs {
    move |_| Outputs { drive: drive_at(direction, duty), ..Outputs::default() }
}

/// A board biased at 1 V with 0.1 V/A: it reads signed currents, and taut-core's drive
/// (which reads codes as 0.2 V/A from zero) sees its zero as 5 A, below the 12 A trip, so the
/// drive keeps running while the test decodes the codes with the board's own scale.
fn signed_test_board(board: CurrentSenseParams) -> CurrentSenseParams {
    CurrentSenseParams { offset_volts: 1.0, volts_per_amp: 0.1, noise_amps: 0.0, ..board }
}

#[test]
fn backlash_the_load_cell_reads_nothing_until_the_dead_band_is_crossed() {
    let mut config = quiet(StringKind::TennisPolyester);
    config.mechanics.backlash_mm = 0.2;
    config.mechanics.gripper.mass_kg = 0.0;
    // The string is straight at power-up: any carriage travel loads it.
    config.string.slack_mm = 0.0;
    config.string.toe_mm = 0.5;
    let mut twin = Twin::new(&config).with_voltage_mode_drive();
    let start = twin.truth();
    // Power-up: the carriage rests on the release flank (homing drove it there).
    assert!((start.backlash_mm - 0.1).abs() < 1e-9, "{start:?}");
    let zero_code = twin.inputs().load_cell;
    let trace = run(&mut twin, 400, ramped(Direction::Pull, 0.15, 100));
    let crossing = trace
        .rows
        .iter()
        .position(|r| r.truth.backlash_mm <= -0.1 + 1e-9)
        .expect("the motor takes up the backlash");
    for (k, row) in trace.rows.iter().take(crossing).enumerate() {
        // (Zero but for the last bit of the carriage position's rounding.)
        assert!(row.truth.tension_kgf < 1e-9, "tick {k}: {:?}", row.truth);
        assert!((row.truth.carriage_mm - start.carriage_mm).abs() < 1e-9, "tick {k}");
        assert_eq!(row.inputs.load_cell, zero_code, "tick {k}");
    }
    let last = trace.last().expect("ran").truth;
    println!(
        "backlash 0.2 mm taken up in {crossing} ms; 400 ms later: {:.2} kgf, carriage {:+.3} mm",
        last.tension_kgf,
        last.carriage_mm - start.carriage_mm
    );
    assert!(crossing > 5, "the dead band takes time to cross: {crossing} ms");
    assert!(last.tension_kgf > 1.0 && last.backlash_mm <= -0.1 + 1e-9, "{last:?}");
    // The string loads only once the motor side has turned b/r past the rigid machine's.
    let mut rigid = config;
    rigid.mechanics.backlash_mm = 0.0;
    let mut rigid = Twin::new(&rigid).with_voltage_mode_drive();
    let rigid_trace = run(&mut rigid, 400, ramped(Direction::Pull, 0.15, 100));
    let loads = |t: &Trace| t.rows.iter().position(|r| r.truth.tension_kgf > 0.0).expect("loads");
    assert!(loads(&trace) > loads(&rigid_trace), "{} vs {}", loads(&trace), loads(&rigid_trace));
}

#[test]
fn backlash_a_reversal_turns_the_motor_through_the_dead_band_before_the_carriage_moves() {
    let mut config = quiet(StringKind::NoString);
    config.mechanics.backlash_mm = 0.2;
    let mut twin = Twin::new(&config).with_voltage_mode_drive();
    run(&mut twin, 300, ramped(Direction::Pull, 0.2, 50));
    run(&mut twin, 100, coast());
    let rest = twin.truth();
    assert!(rest.carriage_mm_per_s == 0.0 && rest.carriage_mm > 2.0, "{rest:?}");
    // Stopped on the pull flank, or coasted a little way into the dead band.
    assert!(rest.backlash_mm < 0.1, "{rest:?}");
    let trace = run(&mut twin, 300, ramped(Direction::Release, 0.2, 50));
    let crossing = trace
        .rows
        .iter()
        .position(|r| r.truth.backlash_mm >= 0.1 - 1e-9)
        .expect("the motor crosses the dead band");
    let before: Vec<f64> = trace.rows[..crossing].iter().map(|r| r.truth.carriage_mm).collect();
    assert!(before.iter().all(|&x| (x - rest.carriage_mm).abs() < 1e-9), "{before:?}");
    let last = trace.last().expect("ran").truth;
    println!(
        "reversal: dead band crossed after {crossing} ms, then {:.2} mm/s",
        last.carriage_mm_per_s
    );
    assert!(last.carriage_mm < rest.carriage_mm - 1.0, "{last:?}");
}

#[test]
fn gripper_the_load_cell_reads_tension_plus_mass_times_acceleration() {
    let mut config = quiet(StringKind::TennisSynthetic);
    config.mechanics.backlash_mm = 0.0;
    config.mechanics.gripper.mass_kg = 1.5;
    // Damped, so the comparison is tick by tick; the family's 2–10 % rings around the same.
    config.mechanics.gripper.damping_ratio = 0.7;
    let m = config.mechanics.gripper.mass_kg;
    let mut twin = Twin::new(&config).with_voltage_mode_drive();
    // Accelerate, run into the string, brake hard on it.
    let mut tick = 0_u32;
    let trace = run(&mut twin, 900, |_| {
        tick += 1;
        let duty = if tick < 600 { 0.9 * (f64::from(tick) / 60.0).min(1.0) } else { 0.05 };
        Outputs { drive: drive_at(Direction::Pull, duty), ..Outputs::default() }
    });
    // The load cell is a second-order low-pass of `T + m·a` (ω_n, ζ): to a ramping input it
    // lags by 2ζ/ω_n, which the comparison takes into account.
    let g = config.mechanics.gripper;
    let lag_s = 2.0 * g.damping_ratio / (std::f64::consts::TAU * g.natural_frequency_hz());
    let v = |j: usize| trace.rows[j].truth.carriage_mm_per_s * 1e-3;
    let input = |j: usize| {
        // Central difference: the acceleration at the end of tick j.
        let accel = (v(j + 1) - v(j - 1)) / 2e-3;
        trace.rows[j].truth.tension_kgf + m * accel / NEWTONS_PER_KGF
    };
    let mut worst: f64 = 0.0;
    let mut largest_inertial: f64 = 0.0;
    // Skip the breakaway from stiction (a step in acceleration) and the step to braking.
    for k in (40..595).chain(610..trace.len() - 2) {
        let row = trace.rows[k].truth;
        let slope = (input(k + 1) - input(k - 1)) / 2e-3;
        let expected = input(k) - lag_s * slope;
        largest_inertial = largest_inertial.max((input(k) - row.tension_kgf).abs());
        worst = worst.max((row.load_cell_force_kgf - expected).abs());
    }
    println!(
        "gripper 1.5 kg on a {:.0} Hz load cell: inertial force up to {largest_inertial:.3} kgf, \
         worst |cell − (T + m·a)| {worst:.4} kgf (lag {:.2} ms)",
        g.natural_frequency_hz(),
        lag_s * 1e3
    );
    assert!(largest_inertial > 0.1, "the test must accelerate: {largest_inertial}");
    assert!(worst < 0.03, "{worst}");
    // Without a gripper the load cell reads the tension exactly.
    config.mechanics.gripper.mass_kg = 0.0;
    let mut bare = Twin::new(&config).with_voltage_mode_drive();
    let bare_trace = run(&mut bare, 300, ramped(Direction::Pull, 0.9, 60));
    assert!(bare_trace.rows.iter().all(|r| r.truth.load_cell_force_kgf == r.truth.tension_kgf));
}

#[test]
fn gripper_an_end_stop_rings_the_load_cell_at_its_natural_frequency() {
    let mut config = quiet(StringKind::NoString);
    config.mechanics.backlash_mm = 0.0;
    config.mechanics.gripper.mass_kg = 1.0;
    let f_n = config.mechanics.gripper.natural_frequency_hz();
    let mut twin = Twin::new(&config).with_voltage_mode_drive();
    // The home switch's wiring reads open, so the drive releases into the hard stop.
    twin.inject(Fault::LimitSwitchStuck { switch: taut_sim::LimitSwitch::Home, closed: false });
    let trace = run(&mut twin, 1_500, ramped(Direction::Release, 0.5, 50));
    let hit = trace
        .rows
        .iter()
        .position(|r| {
            r.truth.carriage_mm
                <= config.mechanics.home_switch_mm - config.mechanics.overtravel_mm + 1e-9
        })
        .expect("reaches the stop");
    let peak =
        trace.rows[hit..].iter().map(|r| r.truth.load_cell_force_kgf.abs()).fold(0.0, f64::max);
    let before = trace.rows[hit - 5].truth.load_cell_force_kgf.abs();
    // The carriage stops from v at once: the gripper's momentum rings the cell with an
    // amplitude of about v·√(k·m).
    let v = trace.rows[hit - 1].truth.carriage_mm_per_s.abs() * 1e-3;
    let g = config.mechanics.gripper;
    let amplitude = v * (g.load_cell_stiffness_n_per_m * g.mass_kg).sqrt() / NEWTONS_PER_KGF;
    println!(
        "home stop at {:.1} mm/s: the load cell rings to {peak:.2} kgf (v·√(k·m) = {amplitude:.2} kgf, \
         natural frequency {f_n:.0} Hz)",
        v * 1e3
    );
    assert!(before < 0.05 && peak > 0.5 * amplitude && peak < 1.1 * amplitude, "{before} {peak}");
    assert!((200.0..600.0).contains(&f_n));
}

#[test]
fn clamp_the_bus_rises_to_the_clamp_under_hard_braking_and_never_beyond() {
    for (clamp, capacitance) in [(28.0, 470e-6), (30.0, 1000e-6), (36.0, 470e-6)] {
        let mut config = quiet(StringKind::NoString);
        config.bridge.clamp_volts = Some(clamp);
        config.bridge.bus_capacitance_f = capacitance;
        let mut twin = Twin::new(&config).with_voltage_mode_drive();
        run(&mut twin, 600, ramped(Direction::Pull, 0.9, 200));
        let before = twin.truth();
        // Brake at half the back-EMF ratio (≈ 76 mm/s at full bus): ≈ 10 A flows back.
        let ratio = before.carriage_mm_per_s / 76.0;
        let trace = run(&mut twin, 60, at(0.5 * ratio, Direction::Pull));
        let peak = trace.rows.iter().map(|r| r.truth.bus_peak_volts).fold(0.0, f64::max);
        let clamped = trace.rows.iter().filter(|r| r.truth.bus_clamped).count();
        println!(
            "clamp {clamp} V, {:.0} µF: braking from {:.1} mm/s peaks at {peak:.3} V, clamp on \
             for {clamped} ms",
            capacitance * 1e6,
            before.carriage_mm_per_s
        );
        assert!(peak <= clamp + 1e-9, "{peak} > {clamp}");
        assert!(trace.rows.iter().all(|r| r.truth.bus_volts <= clamp + 1e-9));
        if clamp < 36.0 {
            assert!(peak > clamp - 1e-6 && clamped > 0, "the bus must reach the clamp: {peak}");
        }
    }
    // Without a clamp the same hard brake from full speed on 470 µF overshoots 30 V.
    let mut config = quiet(StringKind::NoString);
    config.bridge.clamp_volts = None;
    config.bridge.bus_capacitance_f = 470e-6;
    let mut twin = Twin::new(&config).with_voltage_mode_drive();
    run(&mut twin, 600, ramped(Direction::Pull, 0.9, 200));
    let ratio = twin.truth().carriage_mm_per_s / 76.0;
    let trace = run(&mut twin, 60, at(0.5 * ratio, Direction::Pull));
    let peak = trace.rows.iter().map(|r| r.truth.bus_peak_volts).fold(0.0, f64::max);
    println!("no clamp, 470 µF: {peak:.2} V");
    assert!(peak > 30.0, "{peak}");
}

/// Decoded current (with the board's own scale) of the tick mean and the truth's signed
/// winding current, per row.
fn decoded(twin: &Twin, trace: &Trace) -> Vec<(f64, f64)> {
    let sense = *twin.current_sense();
    trace
        .rows
        .iter()
        .skip(1)
        .zip(trace.rows.iter())
        .map(|(next, row)| (sense.amps_of(next.inputs.motor_current), row.truth.winding_current_a))
        .collect()
}

#[test]
fn per_phase_shunts_read_the_signed_winding_current_and_zero_when_coasting() {
    let mut config = quiet(StringKind::NoString);
    config.current_sense = signed_test_board(CurrentSenseParams::per_phase_low_side());
    let mut twin = Twin::new(&config).with_voltage_mode_drive();
    // Motoring: the reading is the winding current, in both parts of every period.
    let motoring = run(&mut twin, 400, ramped(Direction::Pull, 0.6, 150));
    let v0 = twin.truth().carriage_mm_per_s;
    // Braking: a duty well below the back-EMF ratio drives the winding current backwards.
    let braking = run(&mut twin, 15, at(0.15, Direction::Pull));
    let mut worst: f64 = 0.0;
    let mut most_negative: f64 = 0.0;
    for (read, truth) in
        decoded(&twin, &motoring).into_iter().skip(200).chain(decoded(&twin, &braking))
    {
        worst = worst.max((read - truth).abs());
        most_negative = most_negative.min(read);
    }
    println!(
        "per-phase: worst |read − winding| {worst:.3} A; braking reads down to {most_negative:.2} A"
    );
    assert!(worst < 0.15, "{worst}");
    assert!(most_negative < -2.0, "braking must read negative: {most_negative}");
    // Coasting while the rotor still turns: no low side is on, the reading is zero.
    let coasting = run(&mut twin, 100, coast());
    assert!(twin.truth().motor_rpm > 100.0 || v0 > 0.0);
    let sense = *twin.current_sense();
    for row in coasting.rows.iter().skip(2) {
        assert!(sense.amps_of(row.inputs.motor_current).abs() < 0.03, "{:?}", row.inputs);
        assert_eq!(row.truth.winding_current_a, 0.0);
    }
}

#[test]
fn dc_link_mid_on_time_reads_the_winding_current_while_motoring() {
    for bidirectional in [false, true] {
        let mut config = quiet(StringKind::NoString);
        config.current_sense =
            CurrentSenseParams { noise_amps: 0.0, ..CurrentSenseParams::nominal() };
        if bidirectional {
            config.current_sense = signed_test_board(CurrentSenseParams::dc_link_mid_on_time(true));
        }
        let mut twin = Twin::new(&config).with_voltage_mode_drive();
        let motoring = run(&mut twin, 400, ramped(Direction::Pull, 0.6, 150));
        let worst = decoded(&twin, &motoring)
            .into_iter()
            .skip(200)
            .map(|(read, truth)| (read - truth).abs())
            .fold(0.0, f64::max);
        // Braking current flows back through the high side: negative on a bidirectional
        // amplifier, zero on a unidirectional one.
        let braking = run(&mut twin, 15, at(0.15, Direction::Pull));
        let lowest = decoded(&twin, &braking).into_iter().map(|(read, _)| read).fold(0.0, f64::min);
        println!(
            "DC link mid on-time (bidirectional {bidirectional}): worst {worst:.3} A; braking reads {lowest:.2} A"
        );
        assert!(worst < 0.15, "{worst}");
        if bidirectional {
            assert!(lowest < -2.0, "{lowest}");
        } else {
            assert!(lowest.abs() < 1e-3, "{lowest}");
        }
    }
}

#[test]
fn dc_link_filtered_reads_duty_times_the_winding_current_on_average() {
    for tau in [0.1e-3, 0.3e-3, 1e-3] {
        let mut readings = Vec::new();
        let mut expected = 0.0;
        let mut winding = 0.0;
        for k in 0..10 {
            let phase = f64::from(k) / 10.0;
            let mut config = quiet(StringKind::NoString);
            config.current_sense =
                signed_test_board(CurrentSenseParams::dc_link_filtered(true, tau, phase));
            let mut twin = Twin::new(&config).with_voltage_mode_drive();
            // A stalled rotor: steady duty and current.
            twin.inject(Fault::CarriageJam);
            let trace = run(&mut twin, 60, at(0.3, Direction::Pull));
            assert!(
                trace.rows.iter().all(|r| r.truth.drive_fault.is_none()),
                "{:?}",
                trace.rows.iter().find_map(|r| r.truth.drive_fault)
            );
            let truth = twin.truth();
            // The bus carries the winding current during the high side's on-time, D·T − t_d.
            let on_share = truth.duty - config.bridge.dead_time_s * 20_000.0;
            expected = on_share * truth.winding_current_a;
            winding = truth.winding_current_a;
            readings.push(twin.current_sense().amps_of(twin.inputs().motor_current));
        }
        let mean = readings.iter().sum::<f64>() / readings.len() as f64;
        let low = readings.iter().copied().fold(f64::MAX, f64::min);
        let high = readings.iter().copied().fold(f64::MIN, f64::max);
        println!(
            "DC link RC τ {:.1} ms, winding {winding:.2} A: reads {low:.3}–{high:.3} A over the \
             sampling phase, mean {mean:.3} A; duty × I = {expected:.3} A",
            tau * 1e3
        );
        // On average over where it is read, exactly the on-time share of the current; at any
        // one phase within the filter's ripple, I·D·(1 − D)·T/τ.
        assert!((mean - expected).abs() < 0.02 * expected, "{mean} vs {expected}");
        let ripple = winding * 0.3 * 0.7 * 50e-6 / tau;
        assert!(high - low <= 1.1 * ripple + 0.01, "{low}..{high} vs ripple {ripple}");
    }
    // Mid on-time on the same stall reads the winding current itself.
    let mut config = quiet(StringKind::NoString);
    config.current_sense = signed_test_board(CurrentSenseParams::dc_link_mid_on_time(true));
    let mut twin = Twin::new(&config).with_voltage_mode_drive();
    twin.inject(Fault::CarriageJam);
    run(&mut twin, 60, at(0.3, Direction::Pull));
    let read = twin.current_sense().amps_of(twin.inputs().motor_current);
    let winding = twin.truth().winding_current_a;
    assert!((read - winding).abs() < 0.05, "{read} vs {winding}");
}

#[test]
fn amplifier_zero_reads_code_2048_bidirectional_and_0_unidirectional() {
    for (board, zero) in [
        (CurrentSenseParams::per_phase_low_side(), 2048_u16),
        (CurrentSenseParams::dc_link_mid_on_time(true), 2048),
        (CurrentSenseParams::dc_link_filtered(true, 0.5e-3, 0.3), 2048),
        (CurrentSenseParams::dc_link_mid_on_time(false), 0),
        (CurrentSenseParams::dc_link_filtered(false, 0.5e-3, 0.3), 0),
    ] {
        assert_eq!(board.ideal_code(0.0).get(), zero, "{}", board.name());
        let mut config = quiet(StringKind::NoString);
        config.current_sense = CurrentSenseParams { noise_amps: 0.0, ..board };
        let mut twin = Twin::new(&config).with_voltage_mode_drive();
        let trace = run(&mut twin, 50, coast());
        // (Row 0's inputs come before the first PWM period: the firmware's tick mean of no
        // samples is code 0.)
        let codes: Vec<u16> =
            trace.rows.iter().skip(1).map(|r| r.inputs.motor_current.get()).collect();
        assert!(codes.iter().all(|&code| code == zero), "{}: {codes:?}", board.name());
        // 5 A reads 0.5 V (or 1 V) above the zero.
        let volts_per_amp = board.volts_per_amp;
        let expected = zero + (5.0 * volts_per_amp * 4096.0 / 5.0).round() as u16;
        assert_eq!(board.ideal_code(5.0).get(), expected);
    }
}

#[test]
fn bus_voltage_code_follows_the_divider_through_the_oversampler() {
    for ratio in [ranges::BUS_DIVIDER.low, 12.0, ranges::BUS_DIVIDER.high] {
        let mut config = quiet(StringKind::NoString);
        config.bus_sense.divider_ratio = ratio;
        config.bridge.clamp_volts = None;
        let mut twin = Twin::new(&config).with_voltage_mode_drive();
        let bus = twin.truth().bus_volts;
        let code = twin.inputs().bus_voltage;
        let expected = (bus / ratio * 4096.0 / 5.0).round() as u16;
        assert_eq!(code.get(), expected, "ratio {ratio}");
        // Braking pumps the bus; the code follows within the oversampler's 0.8 ms.
        run(&mut twin, 600, ramped(Direction::Pull, 0.9, 200));
        let speed = twin.truth().carriage_mm_per_s / 76.0;
        let trace = run(&mut twin, 40, at(0.5 * speed, Direction::Pull));
        for pair in trace.rows.windows(3) {
            let read = twin.bus_sense().volts_of(pair[2].inputs.bus_voltage);
            // The code read in tick 2 averages the last complete 16-period block, which can
            // reach back into tick 0; the truth records each tick's end value and peak, not
            // its minimum, so the lower bound allows the within-tick ripple of a bus being
            // pumped and drained by PWM braking (≈ 0.1 V).
            let low =
                pair[0].truth.bus_volts.min(pair[1].truth.bus_volts).min(pair[2].truth.bus_volts)
                    - 0.1;
            let high = pair[0].truth.bus_peak_volts.max(pair[1].truth.bus_peak_volts) + 0.02;
            assert!(read >= low && read <= high, "{read} outside {low}..{high}");
        }
    }
}

/// The amplitude of the `frequency_hz` component of a series sampled at 1 kHz.
fn tone_amplitude(samples: &[f64], frequency_hz: f64) -> f64 {
    let n = samples.len() as f64;
    let mean = samples.iter().sum::<f64>() / n;
    let (mut re, mut im) = (0.0, 0.0);
    for (k, x) in samples.iter().enumerate() {
        let angle = std::f64::consts::TAU * frequency_hz * k as f64 * 1e-3;
        re += (x - mean) * angle.cos();
        im += (x - mean) * angle.sin();
    }
    2.0 * (re * re + im * im).sqrt() / n
}

#[test]
fn mains_hum_shows_at_its_frequency_in_the_load_cell_codes() {
    for mains in [50.0, 60.0] {
        let mut config = quiet(StringKind::NoString);
        config.load_cell.hum.volts = 8e-3;
        config.load_cell.hum.frequency_hz = mains;
        config.load_cell.hum.phase_deg = 30.0;
        let mut twin = Twin::new(&config).with_voltage_mode_drive();
        let trace = run(&mut twin, 2_000, coast());
        let codes: Vec<f64> =
            trace.rows.iter().map(|r| f64::from(r.inputs.load_cell.get())).collect();
        let volts_per_code = 5.0 / 4096.0;
        let at_mains = tone_amplitude(&codes, mains) * volts_per_code;
        let other = tone_amplitude(&codes, 110.0 - mains) * volts_per_code;
        println!(
            "hum {mains} Hz: {:.2} mV at {mains} Hz, {:.3} mV at {} Hz",
            at_mains * 1e3,
            other * 1e3,
            110.0 - mains
        );
        assert!((at_mains - 8e-3).abs() < 0.5e-3, "{at_mains}");
        assert!(other < 0.5e-3, "{other}");
    }
}

#[test]
fn spikes_at_the_top_of_the_range_reach_5_kgf_in_one_sample() {
    let config = TwinConfig::on_axis(Axis::Spikes, 1.0, StringKind::TennisSynthetic);
    let mut twin = Twin::new(&config).with_voltage_mode_drive();
    // Pull into the string and hold about 3 A.
    let trace = run(&mut twin, 4_000, ramped(Direction::Pull, 0.35, 200));
    let sensitivity = config.load_cell.volts_per_kgf;
    let kgf_per_code = 5.0 / 4096.0 / sensitivity;
    let deviations: Vec<f64> = trace
        .rows
        .windows(2)
        .map(|w| {
            let code = f64::from(w[1].inputs.load_cell.get());
            let clean = f64::from(taut_sim::sensors::adc(w[0].truth.load_cell_volts).get());
            (code - clean).abs() * kgf_per_code
        })
        .collect();
    let switching = trace.rows.iter().filter(|r| r.truth.duty > 0.0).count();
    let spikes = deviations.iter().filter(|&&d| d > 0.3).count();
    let big = deviations.iter().filter(|&&d| d >= 5.0).count();
    let largest = deviations.iter().copied().fold(0.0, f64::max);
    println!(
        "spikes: {spikes} of {switching} switching samples ({:.1} %), {big} of them ≥ 5 kgf, largest {largest:.1} kgf",
        100.0 * spikes as f64 / switching as f64
    );
    assert!(big > 0 && largest >= 5.0, "{largest}");
    assert!((spikes as f64) < 0.1 * switching as f64, "{spikes}");
}

/// How far the carriage coasts from its speed at `duty`.
fn coast_distance(config: &TwinConfig) -> (f64, f64) {
    let mut twin = Twin::new(config).with_voltage_mode_drive();
    run(&mut twin, 700, ramped(Direction::Pull, 0.6, 200));
    let from = twin.truth();
    let trace = run(&mut twin, 2_000, coast());
    let stop = trace.rows.iter().position(|r| r.truth.carriage_mm_per_s == 0.0).unwrap_or(2_000);
    (twin.truth().carriage_mm - from.carriage_mm, stop as f64 * 1e-3)
}

#[test]
fn the_ball_screw_end_of_the_friction_axis_coasts_far() {
    let low = coast_distance(&TwinConfig::on_axis(Axis::Friction, 0.0, StringKind::NoString));
    let high = coast_distance(&TwinConfig::on_axis(Axis::Friction, 1.0, StringKind::NoString));
    let mut heavy_ball = TwinConfig::on_axis(Axis::Friction, 0.0, StringKind::NoString);
    heavy_ball.motor.rotor_inertia_kg_m2 *= ranges::INERTIA_SCALE.high;
    heavy_ball.mechanics.gear_inertia_kg_m2 *= ranges::INERTIA_SCALE.high;
    let heavy = coast_distance(&heavy_ball);
    println!(
        "coast from duty 0.6: ball-screw end {:.2} mm in {:.2} s, worn trapezoidal {:.2} mm in {:.2} s, \
         ball screw with 2× inertia {:.2} mm in {:.2} s",
        low.0, low.1, high.0, high.1, heavy.0, heavy.1
    );
    // Coasting without a string, the motor's own iron losses (fixed by the nameplate's
    // no-load current) take most of the energy: the drivetrain's friction adds the rest.
    assert!(low.0 > 1.2 * high.0 && low.1 > high.1, "{low:?} vs {high:?}");
    assert!(heavy.1 > 0.3, "the heavy ball-screw machine coasts ≈ 0.4 s: {heavy:?}");
}

#[test]
fn a_shorted_phase_drives_the_current_past_the_trip() {
    let mut config = TwinConfig::nominal(StringKind::NoString);
    config.current_sense.noise_amps = 0.0;
    let mut healthy = Twin::new(&config).with_voltage_mode_drive();
    healthy.inject(Fault::CarriageJam);
    let duty = 0.35;
    run(&mut healthy, 100, at(duty, Direction::Pull));
    let stall = healthy.truth();
    assert_eq!(stall.drive_fault, None, "{stall:?}");
    // Short most of a phase the stalled sector drives.
    let phase = Phase::ALL
        .into_iter()
        .find(|&p| stall.pattern.leg(p) == LegState::High)
        .expect("a driven pattern");
    let mut shorted = healthy.clone();
    shorted.inject(Fault::ShortedPhase { phase, shorted_percent: 80 });
    let trace = run(&mut shorted, 20, at(duty, Direction::Pull));
    let tripped = trace.rows.iter().position(|r| r.truth.drive_fault.is_some()).expect("trips");
    let peak = trace.rows.iter().map(|r| r.truth.peak_current_a).fold(0.0, f64::max);
    let fault = shorted.truth().drive_fault;
    println!(
        "stall at duty {duty}: {:.2} A healthy; phase {phase:?} 80 % shorted: peak {peak:.1} A, \
         {fault:?} after {tripped} ms",
        stall.current_a
    );
    assert!(stall.current_a < 11.0);
    assert!(matches!(fault, Some(DriveFault::Overcurrent | DriveFault::OvercurrentTrip)));
    assert!(tripped <= 3, "{tripped}");
    // Healthy again after clearing (the short is gone; the drive fault stays latched).
    shorted.clear_injected();
    shorted.apply(&Outputs {
        drive: DriveCommand::Coast,
        clear_drive_fault: true,
        ..Outputs::default()
    });
    run(&mut shorted, 30, coast());
    let again = run(&mut shorted, 100, at(duty, Direction::Pull));
    assert!(again.rows.iter().all(|r| r.truth.drive_fault.is_none()));
}

#[test]
fn scheduled_faults_start_at_their_tick() {
    let config = quiet(StringKind::TennisSynthetic);
    let mut twin = Twin::new(&config).with_voltage_mode_drive();
    twin.inject_at(1_500, Fault::StringBreak);
    twin.inject_at(1_700, Fault::LoadCell(LoadCellFault::Short));
    twin.inject_at(1_800, Fault::HallLineStuck { phase: Phase::B, level: true });
    let trace = run(&mut twin, 2_000, ramped(Direction::Pull, 0.5, 100));
    // Row k holds the truth at the end of tick k and the inputs sampled at its start.
    assert_eq!(trace.rows[1_499].truth.string, StringState::Taut);
    assert!(trace.rows[1_499].truth.tension_kgf > 1.0);
    assert_eq!(trace.rows[1_500].truth.string, StringState::Broken);
    assert_eq!(trace.rows[1_500].truth.tension_kgf, 0.0);
    assert!(trace.rows[1_700].inputs.load_cell.get() < 4_095);
    assert_eq!(trace.rows[1_701].inputs.load_cell.get(), 4_095);
    // The stuck line: the drive's Hall filter flags an invalid code or a skipped sector soon.
    let faulted = trace.rows[1_800..].iter().position(|r| r.truth.drive_fault.is_some());
    assert!(faulted.is_some(), "{:?}", trace.last().map(|r| r.truth));
    // Deterministic: the same schedule gives the same run.
    let mut again = Twin::new(&config).with_voltage_mode_drive();
    again.inject_at(1_800, Fault::HallLineStuck { phase: Phase::B, level: true });
    again.inject_at(1_700, Fault::LoadCell(LoadCellFault::Short));
    again.inject_at(1_500, Fault::StringBreak);
    let trace_again = run(&mut again, 2_000, ramped(Direction::Pull, 0.5, 100));
    assert_eq!(trace, trace_again);

    // A stalled rotor and a shorted phase, scheduled the same way.
    let mut config = quiet(StringKind::NoString);
    config.current_sense = CurrentSenseParams { noise_amps: 0.0, ..CurrentSenseParams::nominal() };
    let mut twin = Twin::new(&config).with_voltage_mode_drive();
    twin.inject_at(600, Fault::CarriageJam);
    twin.inject_at(700, Fault::ShortedPhase { phase: Phase::A, shorted_percent: 90 });
    let trace = run(&mut twin, 800, ramped(Direction::Pull, 0.3, 100));
    assert!(trace.rows[599].truth.motor_rpm > 100.0);
    assert!(trace.rows[600..].iter().all(|r| r.truth.motor_rpm == 0.0 && r.truth.stuck));
    assert!(trace.rows[..700].iter().all(|r| r.truth.drive_fault.is_none()));
    let tripped = trace.rows[700..].iter().position(|r| r.truth.drive_fault.is_some());
    println!("jam at 600 ms, phase A 90 % shorted at 700 ms: drive fault after {tripped:?} ms");
    // (This rotor stalled in a sector that drives phase A.)
    assert!(tripped.is_some_and(|ms| ms <= 3), "{tripped:?}");
}

#[test]
fn every_machine_of_the_family_runs() {
    // A short pull on a handful of family machines, through taut-core's drive; the drive
    // may latch an overcurrent on a bidirectional board (taut-core does not yet read its
    // mid-rail zero), nothing else may go wrong.
    for seed in 0..20 {
        let config = TwinConfig::family(seed);
        let mut twin = Twin::new(&config).with_voltage_mode_drive();
        let trace = run(&mut twin, 300, ramped(Direction::Pull, 0.3, 100));
        for row in &trace.rows {
            let t = row.truth;
            assert!(
                t.tension_kgf.is_finite() && t.carriage_mm.is_finite() && t.bus_volts.is_finite()
            );
            assert!(t.bus_volts <= config.bridge.clamp_volts.expect("clamp") + 1e-9);
        }
        let fault = twin.truth().drive_fault;
        if !config.current_sense.bidirectional() {
            assert_eq!(fault, None, "seed {seed}: {}", config.current_sense.name());
            assert!(twin.truth().carriage_mm > 1.0, "seed {seed}: {:?}", twin.truth());
        }
    }
}
