//! A working day: the slow drifts of one machine across many consecutive cycles.
//!
//! # Theory of operation
//!
//! A machine that strings rackets all day warms up, and so does its shop. Four slow processes
//! move the physics the machine measured at power-up and at its calibration; each is a
//! first-order system advanced exactly (`x += (x∞ − x)·(1 − e^(−Δt/τ))`), so one call may cover
//! a millisecond of physics or the minutes the stringer spends between pulls
//! ([`crate::Twin::idle`]) alike.
//!
//! - **Shop temperature.** The ambient rises from `ambient_start_c` toward
//!   `ambient_start_c + ambient_rise_c` with the room's time constant (a shop warming through
//!   the morning).
//! - **Copper temperature (I²R heating).** The winding's temperature relaxes toward
//!   `ambient + P·R_th` with the winding's thermal time constant, `P` the copper loss of the
//!   phase currents (`Σ i²·R`, with `R` the hot resistance). The resistance follows it:
//!   `R = R_cold·(1 + α·(T − T_cold))`, `α` = 0.393 %/K for copper, `T_cold` the ambient at the
//!   start of the day (where the nameplate's resistance was measured).
//! - **Load-cell zero with temperature.** The load cell and its amplifier sit in the machine's
//!   frame: their temperature relaxes toward the ambient plus a share of the winding's rise
//!   over it (the motor warms the frame) with the frame's time constant; the zero moves by
//!   `zero_kgf_per_c` per kelvin from its temperature at the start of the day.
//! - **Load-cell creep under load.** Under a steady load the bar's output keeps rising by a
//!   fraction `creep_fraction` of the load with the creep time constant, and falls back the
//!   same way once unloaded (creep recovery): an apparent zero that lags every pull.
//! - **Wear.** The drivetrain's constant (Coulomb) friction grows by `wear_per_m` of its
//!   value per metre of carriage travel.
//!
//! All of it is off unless a session enables it ([`crate::Twin::enable_drift`]): a twin
//! without it is the twin every other figure was taken on, bit for bit.
//!
//! The family's drifts ([`DriftParams::family`]) are drawn per machine around typical values:
//! a strain-gauge chain's zero coefficient of ±0.02 % of full scale per kelvin (full scale
//! ≈ 54 kgf, so ±0.011 kgf/K), a shop warming 2–8 K, a winding at 2–4 K/W with a 10–20 min
//! constant (a 57 mm BLDC), creep of 0.02–0.05 % of the load with a 5–15 min constant, and
//! 0.1–0.4 % more friction per metre of travel (a day of a few hundred pulls is some 50 m of
//! travel: 5–20 % more friction by the evening, a worn drivetrain's pace compressed into a
//! day).

use crate::rng::SimRng;

/// Copper's temperature coefficient of resistance, 1/K.
pub const COPPER_ALPHA: f64 = 0.003_93;

/// One machine's slow drifts (see the module docs).
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct DriftParams {
    /// Shop temperature at power-up, °C.
    pub ambient_start_c: f64,
    /// How far the shop warms over the day, K.
    pub ambient_rise_c: f64,
    /// The room's time constant, s.
    pub ambient_tau_s: f64,
    /// Winding-to-ambient thermal resistance, K/W.
    pub winding_k_per_w: f64,
    /// The winding's thermal time constant, s.
    pub winding_tau_s: f64,
    /// The load cell's zero coefficient, kgf per K (either sign).
    pub zero_kgf_per_c: f64,
    /// Share of the winding's rise over ambient that reaches the load cell.
    pub frame_coupling: f64,
    /// The frame's (and load cell's) thermal time constant, s.
    pub frame_tau_s: f64,
    /// Creep after a long steady load, a fraction of the load.
    pub creep_fraction: f64,
    /// The creep's time constant, s.
    pub creep_tau_s: f64,
    /// Relative friction growth per metre of carriage travel.
    pub wear_per_m: f64,
}

impl DriftParams {
    /// Typical values: a shop warming 5 K in two hours, a winding at 3 K/W and 15 min, a zero
    /// coefficient of +0.011 kgf/K, a tenth of the winding's rise reaching the load cell over
    /// 20 min, 0.03 % creep over 10 min, 0.2 % more friction per metre.
    #[must_use]
    pub const fn typical() -> Self {
        Self {
            ambient_start_c: 20.0,
            ambient_rise_c: 5.0,
            ambient_tau_s: 7_200.0,
            winding_k_per_w: 3.0,
            winding_tau_s: 900.0,
            zero_kgf_per_c: 0.011,
            frame_coupling: 0.1,
            frame_tau_s: 1_200.0,
            creep_fraction: 3e-4,
            creep_tau_s: 600.0,
            wear_per_m: 0.002,
        }
    }

    /// Machine `seed`'s drifts, drawn from the family's ranges (module docs).
    #[must_use]
    pub fn family(seed: u64) -> Self {
        let mut rng = SimRng::substream(seed, 0xD41F);
        Self {
            ambient_start_c: rng.range(15.0, 25.0),
            ambient_rise_c: rng.range(2.0, 8.0),
            ambient_tau_s: rng.range(3_600.0, 10_800.0),
            winding_k_per_w: rng.range(2.0, 4.0),
            winding_tau_s: rng.range(600.0, 1_200.0),
            zero_kgf_per_c: rng.sign() * rng.range(0.003, 0.011),
            frame_coupling: rng.range(0.05, 0.2),
            frame_tau_s: rng.range(900.0, 1_800.0),
            creep_fraction: rng.range(2e-4, 5e-4),
            creep_tau_s: rng.range(300.0, 900.0),
            wear_per_m: rng.range(0.001, 0.004),
        }
    }
}

/// The drifts' state over a day.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct Drift {
    params: DriftParams,
    time_s: f64,
    ambient_c: f64,
    winding_c: f64,
    frame_c: f64,
    creep_kgf: f64,
    travel_m: f64,
}

/// `x` relaxed toward `target` for `dt` with time constant `tau`.
fn relax(x: f64, target: f64, dt: f64, tau: f64) -> f64 {
    x + (target - x) * (1.0 - (-dt / tau.max(1e-9)).exp())
}

impl Drift {
    /// The start of the day: everything at the shop's temperature, no creep, no wear.
    #[must_use]
    pub const fn new(params: DriftParams) -> Self {
        let t0 = params.ambient_start_c;
        Self {
            params,
            time_s: 0.0,
            ambient_c: t0,
            winding_c: t0,
            frame_c: t0,
            creep_kgf: 0.0,
            travel_m: 0.0,
        }
    }

    /// Advances the day by `dt` s with copper loss `copper_w` (W), load `load_kgf` on the cell
    /// and `travel_m` of carriage travel in it.
    pub fn step(&mut self, dt: f64, copper_w: f64, load_kgf: f64, travel_m: f64) {
        let p = &self.params;
        self.time_s += dt;
        let warmed = 1.0 - (-self.time_s / p.ambient_tau_s.max(1e-9)).exp();
        self.ambient_c = p.ambient_start_c + p.ambient_rise_c * warmed;
        let winding_target = self.ambient_c + copper_w.max(0.0) * p.winding_k_per_w;
        self.winding_c = relax(self.winding_c, winding_target, dt, p.winding_tau_s);
        let frame_target = self.ambient_c + p.frame_coupling * (self.winding_c - self.ambient_c);
        self.frame_c = relax(self.frame_c, frame_target, dt, p.frame_tau_s);
        let creep_target = p.creep_fraction * load_kgf.max(0.0);
        self.creep_kgf = relax(self.creep_kgf, creep_target, dt, p.creep_tau_s);
        self.travel_m += travel_m.abs();
    }

    /// The parameters.
    #[must_use]
    pub const fn params(&self) -> &DriftParams {
        &self.params
    }

    /// Time since the start of the day, s.
    #[must_use]
    pub const fn time_s(&self) -> f64 {
        self.time_s
    }

    /// The shop's temperature, °C.
    #[must_use]
    pub const fn ambient_c(&self) -> f64 {
        self.ambient_c
    }

    /// The winding's temperature, °C.
    #[must_use]
    pub const fn winding_c(&self) -> f64 {
        self.winding_c
    }

    /// The winding's resistance over its cold value.
    #[must_use]
    pub fn resistance_factor(&self) -> f64 {
        1.0 + COPPER_ALPHA * (self.winding_c - self.params.ambient_start_c)
    }

    /// How far the load cell's zero has moved since the start of the day, kgf (temperature
    /// alone).
    #[must_use]
    pub fn zero_shift_kgf(&self) -> f64 {
        self.params.zero_kgf_per_c * (self.frame_c - self.params.ambient_start_c)
    }

    /// The creep in the load cell's reading now, kgf.
    #[must_use]
    pub const fn creep_kgf(&self) -> f64 {
        self.creep_kgf
    }

    /// The whole apparent offset of the load cell's reading: zero shift plus creep, kgf.
    #[must_use]
    pub fn offset_kgf(&self) -> f64 {
        self.zero_shift_kgf() + self.creep_kgf
    }

    /// The drivetrain's constant friction over its value at the start of the day.
    #[must_use]
    pub fn friction_factor(&self) -> f64 {
        1.0 + self.params.wear_per_m * self.travel_m
    }

    /// Carriage travel since the start of the day, m.
    #[must_use]
    pub const fn travel_m(&self) -> f64 {
        self.travel_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cold_idle_machine_follows_the_shop_alone() {
        let mut drift = Drift::new(DriftParams::typical());
        drift.step(7_200.0, 0.0, 0.0, 0.0);
        // The shop rose 5·(1 − 1/e) ≈ 3.16 K; the winding and frame lag it a little.
        assert!((drift.ambient_c() - (20.0 + 5.0 * (1.0 - (-1.0f64).exp()))).abs() < 1e-9);
        assert!(drift.winding_c() > 20.0 && drift.winding_c() <= drift.ambient_c());
        assert!(drift.zero_shift_kgf() > 0.0 && drift.zero_shift_kgf() < 0.011 * 3.2);
        assert_eq!(drift.friction_factor(), 1.0);
        assert_eq!(drift.creep_kgf(), 0.0);
    }

    #[test]
    fn copper_loss_heats_the_winding_to_its_steady_rise_and_its_resistance_follows() {
        let mut drift = Drift::new(DriftParams { ambient_rise_c: 0.0, ..DriftParams::typical() });
        // 20 W for ten time constants: the winding 60 K over the shop, R up 23.6 %.
        for _ in 0..9_000 {
            drift.step(1.0, 20.0, 0.0, 0.0);
        }
        assert!((drift.winding_c() - 80.0).abs() < 0.01, "{}", drift.winding_c());
        assert!((drift.resistance_factor() - (1.0 + COPPER_ALPHA * 60.0)).abs() < 1e-4);
        // A tenth of it reaches the load cell: 6 K, 0.066 kgf of zero.
        assert!((drift.zero_shift_kgf() - 0.066).abs() < 0.001, "{}", drift.zero_shift_kgf());
        // One long step is the same as many short ones (exact first-order steps).
        let mut once = Drift::new(DriftParams { ambient_rise_c: 0.0, ..DriftParams::typical() });
        once.step(9_000.0, 20.0, 0.0, 0.0);
        assert!((once.winding_c() - drift.winding_c()).abs() < 1e-6);
    }

    #[test]
    fn creep_rises_under_load_and_recovers_unloaded() {
        let mut drift = Drift::new(DriftParams::typical());
        drift.step(600.0, 0.0, 30.0, 0.0);
        let loaded = drift.creep_kgf();
        assert!((loaded - 30.0 * 3e-4 * (1.0 - (-1.0f64).exp())).abs() < 1e-9);
        drift.step(600.0, 0.0, 0.0, 0.0);
        assert!((drift.creep_kgf() - loaded * (-1.0f64).exp()).abs() < 1e-9);
    }

    #[test]
    fn wear_grows_friction_with_travel_in_either_direction() {
        let mut drift = Drift::new(DriftParams::typical());
        drift.step(1.0, 0.0, 0.0, 0.5);
        drift.step(1.0, 0.0, 0.0, -0.5);
        assert!((drift.friction_factor() - 1.002).abs() < 1e-12);
        assert!((drift.travel_m() - 1.0).abs() < 1e-12);
    }

    /// The mean load-cell code over `ticks` ticks of a twin at rest.
    fn mean_code(twin: &mut crate::Twin, ticks: u32) -> f64 {
        let mut sum = 0.0;
        for _ in 0..ticks {
            twin.advance_tick();
            sum += f64::from(twin.inputs().load_cell.get());
        }
        sum / f64::from(ticks)
    }

    #[test]
    fn the_twin_reads_the_days_zero_shift_and_heats_its_winding_only_when_enabled() {
        use crate::{StringKind, Twin, TwinConfig};
        let config = TwinConfig::nominal(StringKind::TennisSynthetic);
        let mut plain = Twin::new(&config);
        let mut day = Twin::new(&config);
        day.enable_drift(DriftParams { frame_coupling: 0.0, ..DriftParams::typical() });
        // At the start of the day the two are the same twin.
        assert_eq!(mean_code(&mut plain, 100), mean_code(&mut day, 100));
        plain.idle(20_000.0);
        day.idle(20_000.0);
        let Some(drift) = day.drift() else { panic!("enabled") };
        let shift = drift.zero_shift_kgf();
        // The shop warmed ≈ 4.7 K: ≈ 0.05 kgf of zero, ≈ 4.5 codes at 92 mV/kgf.
        assert!((shift - 0.011 * 5.0 * (1.0 - (-20_000.0f64 / 7_200.0).exp())).abs() < 0.003);
        let codes = shift * 0.092 * 4_096.0 / 5.0;
        let moved = mean_code(&mut day, 500) - mean_code(&mut plain, 500);
        assert!((moved - codes).abs() < 0.5, "moved {moved} codes, expected {codes}");
        assert!(plain.drift().is_none());
    }

    #[test]
    fn the_family_draws_each_machine_its_own_drifts_within_the_ranges() {
        let a = DriftParams::family(1);
        let b = DriftParams::family(2);
        assert_ne!(a, b);
        assert_eq!(a, DriftParams::family(1));
        for seed in 0..200 {
            let p = DriftParams::family(seed);
            assert!((0.003..=0.011).contains(&p.zero_kgf_per_c.abs()), "{p:?}");
            assert!((2.0..=8.0).contains(&p.ambient_rise_c));
            assert!((0.001..=0.004).contains(&p.wear_per_m));
        }
    }
}
