//! Exact, order-independent summation of f64 values.
//!
//! Global sums (kinetic energy, momentum) must not depend on the order of the terms, the thread
//! count or the partition into ranks. [`ExactSum`] accumulates every f64 exactly into integer
//! limbs (a fixed-point "superaccumulator" covering the whole f64 range), so the sum is the
//! correctly rounded value of the exact sum whatever the order. Two accumulators combine by
//! adding their limbs, which is how an all-reduce over ranks will combine them (integer sums).

/// Bits per limb; limbs are held in i64 so carries can be deferred.
const LIMB_BITS: i32 = 32;
/// Exponent of the least significant bit of limb 0 (below the smallest subnormal, 2⁻¹⁰⁷⁴).
const BASE_EXP: i32 = -1088;
/// Number of limbs: covers 2⁻¹⁰⁸⁸ … 2¹¹⁰⁴ (the f64 range plus room for carries).
const LIMBS: usize = 69;

/// Exact accumulator of f64 values.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExactSum {
    limbs: [i64; LIMBS],
    pending: u32,
}

impl Default for ExactSum {
    fn default() -> Self {
        Self::new()
    }
}

impl ExactSum {
    /// An empty sum (exactly zero).
    pub fn new() -> Self {
        ExactSum {
            limbs: [0; LIMBS],
            pending: 0,
        }
    }

    /// Add `x` exactly. Non-finite values are not representable; they poison the result as NaN
    /// through [`ExactSum::value`] only if the caller checks separately (hsph checks finiteness
    /// of particle state before summing).
    pub fn add(&mut self, x: f64) {
        if x == 0.0 || !x.is_finite() {
            return;
        }
        let bits = x.to_bits();
        let neg = (bits >> 63) != 0;
        let exp = ((bits >> 52) & 0x7ff) as i32;
        let frac = bits & ((1u64 << 52) - 1);
        // value = mant · 2^(e2)
        let (mant, e2) = if exp == 0 {
            (frac, -1074)
        } else {
            (frac | (1u64 << 52), exp - 1075)
        };
        let shift = e2 - BASE_EXP; // ≥ 14
        let limb = (shift / LIMB_BITS) as usize;
        let off = (shift % LIMB_BITS) as u32;
        // mant (≤ 53 bits) << off (< 32) fits in 85 bits: spread over three limbs.
        let wide = (mant as u128) << off;
        let sign = if neg { -1 } else { 1 };
        for k in 0..3 {
            let part = ((wide >> (32 * k)) & 0xffff_ffff) as i64;
            if part != 0 {
                self.limbs[limb + k] += sign * part;
            }
        }
        self.pending += 1;
        if self.pending >= 1 << 30 {
            self.normalise();
        }
    }

    /// Merge another accumulator (exact).
    pub fn merge(&mut self, other: &ExactSum) {
        self.normalise();
        let mut o = other.clone();
        o.normalise();
        for (a, b) in self.limbs.iter_mut().zip(o.limbs.iter()) {
            *a += *b;
        }
        self.normalise();
    }

    /// The limbs, normalised, for an integer all-reduce.
    pub fn limbs(&self) -> Vec<i64> {
        let mut c = self.clone();
        c.normalise();
        c.limbs.to_vec()
    }

    /// Rebuild from limbs (e.g. after an integer all-reduce of [`ExactSum::limbs`]).
    pub fn from_limbs(limbs: &[i64]) -> Self {
        let mut s = ExactSum::new();
        s.limbs.copy_from_slice(&limbs[..LIMBS]);
        s.pending = 1;
        s.normalise();
        s
    }

    /// Propagate carries so every limb but the top one lies in [0, 2³²).
    fn normalise(&mut self) {
        let mut carry = 0i64;
        for l in self.limbs.iter_mut() {
            let v = *l + carry;
            carry = v >> LIMB_BITS; // arithmetic shift: floor division
            *l = v - (carry << LIMB_BITS);
        }
        self.limbs[LIMBS - 1] += carry << LIMB_BITS;
        self.pending = 0;
    }

    /// The correctly rounded f64 nearest to the exact sum.
    pub fn value(&self) -> f64 {
        let mut c = self.clone();
        c.normalise();
        let neg = c.limbs[LIMBS - 1] < 0;
        if neg {
            // two's complement negate over the limb vector
            for l in c.limbs.iter_mut() {
                *l = -*l;
            }
            c.normalise();
        }
        let Some(top) = c.limbs.iter().rposition(|&l| l != 0) else {
            return 0.0;
        };
        // Take up to three limbs (≥ 65 significant bits when top ≥ 2) plus a sticky bit.
        let lo = top.saturating_sub(2);
        let mut acc: u128 = 0;
        for k in (lo..=top).rev() {
            acc = (acc << 32) | (c.limbs[k] as u64 as u128);
        }
        let sticky = c.limbs[..lo].iter().any(|&l| l != 0);
        if sticky {
            acc |= 1;
        }
        let scale = BASE_EXP + LIMB_BITS * lo as i32;
        // two exact power-of-two steps keep the intermediate normal (2^-1088 alone underflows)
        let half = scale / 2;
        let mag = (acc as f64) * pow2(half) * pow2(scale - half);
        if neg {
            -mag
        } else {
            mag
        }
    }
}

/// 2^e as f64 for e in the normal-and-beyond range, computed in two exact steps.
fn pow2(e: i32) -> f64 {
    let half = e / 2;
    f64::powi(2.0, half) * f64::powi(2.0, e - half)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(s: &mut u64) -> f64 {
        *s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let u = (*s >> 11) as f64 / (1u64 << 53) as f64;
        (u - 0.5) * 10f64.powi(((*s >> 3) % 12) as i32 - 6)
    }

    #[test]
    fn order_independent_and_exact_on_cancellation() {
        let mut seed = 7;
        let xs: Vec<f64> = (0..5000).map(|_| lcg(&mut seed)).collect();
        let mut a = ExactSum::new();
        xs.iter().for_each(|&x| a.add(x));
        let mut b = ExactSum::new();
        xs.iter().rev().for_each(|&x| b.add(x));
        assert_eq!(a.value().to_bits(), b.value().to_bits());
        // split into "ranks" and merge
        let mut parts: Vec<ExactSum> = (0..7).map(|_| ExactSum::new()).collect();
        for (i, &x) in xs.iter().enumerate() {
            parts[i % 7].add(x);
        }
        let mut m = ExactSum::new();
        parts.iter().for_each(|p| m.merge(p));
        assert_eq!(a.value().to_bits(), m.value().to_bits());
        // 1e16 + 1 - 1e16 = 1 exactly, where naive summation gives 0 or 2
        let mut c = ExactSum::new();
        for x in [1e16, 1.0, -1e16, 3.5e-300, -3.5e-300] {
            c.add(x);
        }
        assert_eq!(c.value(), 1.0);
        let mut d = ExactSum::new();
        d.add(-2.5);
        d.add(0.125);
        assert_eq!(d.value(), -2.375);
        assert_eq!(ExactSum::from_limbs(&d.limbs()).value(), -2.375);
    }

    #[test]
    fn correctly_rounded_against_rational_reference() {
        // 0.1 + 0.2 summed exactly then rounded is the f64 nearest to 0.1+0.2 (as reals),
        // which is 0.30000000000000004 (the nearest double to the exact sum of the two doubles).
        let mut s = ExactSum::new();
        s.add(0.1);
        s.add(0.2);
        assert_eq!(s.value(), 0.1 + 0.2);
        // a single value round-trips, including subnormals and huge numbers
        for x in [1.0, -3.0e-310, 1.7e308, 123.456, -5e-324] {
            let mut t = ExactSum::new();
            t.add(x);
            assert_eq!(t.value().to_bits(), x.to_bits(), "{x}");
        }
    }
}
