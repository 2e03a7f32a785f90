//! A small seeded pseudo-random generator: the twin's only source of chance.
//!
//! # Theory of operation
//!
//! Every random thing the twin does — sensor noise, switching spikes, Hall glitches, the
//! Monte-Carlo draw of a scenario — comes from one [`SimRng`] seeded from the scenario's
//! `u64` seed, so a run is a pure function of its configuration: the same seed gives the same
//! trace, bit for bit, on any machine (the generator uses only integer operations; the
//! float conversions are exact).
//!
//! The generator is xoshiro256++ (Blackman & Vigna, 2019): 256 bits of state, period
//! 2²⁵⁶ − 1, passes BigCrush, a handful of shifts and adds per draw. Its state is filled from
//! the seed by SplitMix64, the seeding procedure its authors recommend (it never yields the
//! all-zero state). Normal deviates use the Box–Muller transform on two uniforms.
//!
//! Twenty lines of code instead of the `rand` stack keeps the twin's build light and its
//! stream stable across dependency upgrades.

/// The twin's seeded generator (xoshiro256++ seeded by SplitMix64).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SimRng {
    state: [u64; 4],
    /// The second deviate of the last Box–Muller pair, not yet handed out (stored as
    /// bits so the generator stays `Eq`).
    spare_normal: Option<u64>,
}

/// One SplitMix64 step: advances `seed` and returns the next output.
fn splitmix64(seed: &mut u64) -> u64 {
    *seed = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *seed;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl SimRng {
    /// A generator whose whole stream is determined by `seed`.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        let mut s = seed;
        Self {
            state: [splitmix64(&mut s), splitmix64(&mut s), splitmix64(&mut s), splitmix64(&mut s)],
            spare_normal: None,
        }
    }

    /// A generator for an independent sub-stream: `seed` mixed with a `stream` label, so the
    /// noise of one sensor does not shift when another sensor draws more or fewer numbers.
    #[must_use]
    pub fn substream(seed: u64, stream: u64) -> Self {
        let mut s = seed ^ stream.wrapping_mul(0xD1B5_4A32_D192_ED03);
        Self::new(splitmix64(&mut s))
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let [s0, s1, s2, s3] = self.state;
        let result = s0.wrapping_add(s3).rotate_left(23).wrapping_add(s0);
        let t = s1 << 17;
        let mut s2 = s2 ^ s0;
        let mut s3 = s3 ^ s1;
        let s1 = s1 ^ s2;
        let s0 = s0 ^ s3;
        s2 ^= t;
        s3 = s3.rotate_left(45);
        self.state = [s0, s1, s2, s3];
        result
    }

    /// A uniform number in `[0, 1)` with 53 random bits (exactly representable).
    pub fn uniform(&mut self) -> f64 {
        // 2⁻⁵³ × a 53-bit integer: every value is an exact f64.
        (self.next_u64() >> 11) as f64 * (1.0 / 9_007_199_254_740_992.0)
    }

    /// A uniform number in `[low, high)`.
    pub fn range(&mut self, low: f64, high: f64) -> f64 {
        low + (high - low) * self.uniform()
    }

    /// A uniform integer in `0 .. n` (`0` when `n == 0`), by Lemire's multiply-shift (the
    /// bias is below 2⁻³² for the small `n` the twin uses).
    pub fn below(&mut self, n: u32) -> u32 {
        let wide = (self.next_u64() >> 32).wrapping_mul(u64::from(n));
        u32::try_from(wide >> 32).unwrap_or(0)
    }

    /// `true` with probability `p` (clamped to `[0, 1]`); draws nothing when `p ≤ 0`, so a
    /// disabled effect does not consume the stream.
    pub fn chance(&mut self, p: f64) -> bool {
        p > 0.0 && self.uniform() < p
    }

    /// The number of failures before the first success of independent trials that each
    /// succeed with probability `p` (geometric distribution): lets a rare per-trial event
    /// be scheduled with one draw per event instead of one per trial. `u64::MAX` when
    /// `p ≤ 0`.
    pub fn geometric_gap(&mut self, p: f64) -> u64 {
        if p <= 0.0 {
            return u64::MAX;
        }
        if p >= 1.0 {
            return 0;
        }
        // 1 − u ∈ (0, 1]: ln is finite and ≤ 0; ln(1 − p) < 0.
        let gap = ((1.0 - self.uniform()).ln() / (-p).ln_1p()).floor();
        if gap >= 1.8e19 { u64::MAX } else { gap as u64 }
    }

    /// A standard normal deviate (Box–Muller; each pair of uniforms yields two deviates,
    /// the second kept for the next call).
    pub fn normal(&mut self) -> f64 {
        if let Some(bits) = self.spare_normal.take() {
            return f64::from_bits(bits);
        }
        // 1 − u ∈ (0, 1], so the logarithm is finite.
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        let radius = (-2.0 * u1.ln()).sqrt();
        let (sin, cos) = (core::f64::consts::TAU * u2).sin_cos();
        self.spare_normal = Some((radius * sin).to_bits());
        radius * cos
    }

    /// A normal deviate with standard deviation `sigma` (zero and no draw when `sigma ≤ 0`).
    pub fn gaussian(&mut self, sigma: f64) -> f64 {
        if sigma > 0.0 { sigma * self.normal() } else { 0.0 }
    }

    /// `+1.0` or `-1.0` with equal probability.
    pub fn sign(&mut self) -> f64 {
        if self.next_u64() >> 63 == 0 { 1.0 } else { -1.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_stream_different_seed_different_stream() {
        let mut a = SimRng::new(7);
        let mut b = SimRng::new(7);
        let mut c = SimRng::new(8);
        let xs: Vec<u64> = (0..100).map(|_| a.next_u64()).collect();
        let ys: Vec<u64> = (0..100).map(|_| b.next_u64()).collect();
        let zs: Vec<u64> = (0..100).map(|_| c.next_u64()).collect();
        assert_eq!(xs, ys);
        assert_ne!(xs, zs);
    }

    #[test]
    fn uniform_and_normal_moments() {
        let mut rng = SimRng::new(1);
        let n = 200_000;
        let (mut sum, mut sum2, mut nsum, mut nsum2) = (0.0, 0.0, 0.0, 0.0);
        for _ in 0..n {
            let u = rng.uniform();
            assert!((0.0..1.0).contains(&u));
            sum += u;
            sum2 += u * u;
            let z = rng.normal();
            nsum += z;
            nsum2 += z * z;
        }
        let n = f64::from(n);
        assert!((sum / n - 0.5).abs() < 0.005);
        assert!((sum2 / n - 1.0 / 3.0).abs() < 0.005);
        assert!((nsum / n).abs() < 0.01);
        assert!((nsum2 / n - 1.0).abs() < 0.02);
    }

    #[test]
    fn geometric_gap_has_the_right_mean() {
        let mut rng = SimRng::new(9);
        let p = 0.01;
        let n = 20_000;
        let total: f64 = (0..n).map(|_| rng.geometric_gap(p) as f64).sum();
        let mean = total / f64::from(n);
        // Mean of failures before a success: (1 − p) / p = 99.
        assert!((mean / 99.0 - 1.0).abs() < 0.03, "{mean}");
        assert_eq!(rng.geometric_gap(0.0), u64::MAX);
        assert_eq!(rng.geometric_gap(1.0), 0);
    }

    #[test]
    fn below_stays_in_range() {
        let mut rng = SimRng::new(3);
        let mut seen = [false; 6];
        for _ in 0..1000 {
            let k = rng.below(6);
            assert!(k < 6);
            seen[k as usize] = true;
        }
        assert!(seen.iter().all(|&s| s));
        assert_eq!(rng.below(0), 0);
    }
}
