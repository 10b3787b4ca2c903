//! Seeded sample point sets with known surfaces, for tests and benchmarks.

use glam::DVec3;
use std::f64::consts::TAU;

/// SplitMix64: a small seeded generator (deterministic on every platform).
#[derive(Debug, Clone)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator from `seed`.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `n` points uniformly distributed by area on the torus with major radius `major`
/// and tube radius `minor` around the `z` axis (rejection sampling on the tube angle),
/// from `seed`. The paper's torus has 16,200 points.
pub fn torus(n: usize, major: f64, minor: f64, seed: u64) -> Vec<DVec3> {
    let mut rng = SplitMix64::new(seed);
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let u = TAU * rng.next_f64();
        let v = TAU * rng.next_f64();
        // Area density is proportional to major + minor cos v.
        let accept = (major + minor * v.cos()) / (major + minor);
        if rng.next_f64() <= accept {
            let r = major + minor * v.cos();
            out.push(DVec3::new(r * u.cos(), r * u.sin(), minor * v.sin()));
        }
    }
    out
}

/// The distance from `p` to the torus of [`torus`].
pub fn torus_distance(p: DVec3, major: f64, minor: f64) -> f64 {
    let ring = DVec3::new(p.x, p.y, 0.0).length() - major;
    (ring * ring + p.z * p.z).sqrt() - minor
}

/// `n` points uniformly distributed by area on the sphere of radius `radius` about the
/// origin (uniform `z` and longitude: Archimedes' hat-box theorem), from `seed`.
pub fn sphere(n: usize, radius: f64, seed: u64) -> Vec<DVec3> {
    let mut rng = SplitMix64::new(seed);
    (0..n)
        .map(|_| {
            let z = 2.0 * rng.next_f64() - 1.0;
            let a = TAU * rng.next_f64();
            let r = (1.0 - z * z).max(0.0).sqrt();
            DVec3::new(r * a.cos(), r * a.sin(), z) * radius
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tolerance::POINT_EPS;

    #[test]
    fn torus_points_lie_on_the_torus_and_repeat_by_seed() {
        let a = torus(1000, 0.2, 0.08, 3);
        assert_eq!(a.len(), 1000);
        assert!(
            a.iter()
                .all(|p| torus_distance(*p, 0.2, 0.08).abs() < POINT_EPS)
        );
        assert_eq!(a, torus(1000, 0.2, 0.08, 3));
        assert_ne!(a, torus(1000, 0.2, 0.08, 4));
    }
}
