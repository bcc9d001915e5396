//! Count, mean, sum of squared deviations, minimum and maximum of finite
//! values in `f64`: computed in two passes over a block held in memory
//! (pairwise sums, as numpy sums; the corrected two-pass formula for the
//! squares), and combined between blocks with Chan
//! et al.'s formula, in a fixed order, so the result does not depend on
//! the thread count.

/// The moments of a set of finite values. The mean is held as a shift
/// (a first estimate) plus the mean offset from it, so blocks of values
/// far from zero but close together merge without losing their spread to
/// the rounding of their means.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moments {
    /// How many values.
    pub count: u64,
    /// The shift: a first estimate of the mean (0 when there are none).
    pub shift: f64,
    /// The mean of the values minus `shift`.
    pub offset: f64,
    /// The sum of their squared deviations from the mean.
    pub m2: f64,
    /// The smallest value (+inf when there are none).
    pub min: f64,
    /// The largest value (-inf when there are none).
    pub max: f64,
}

impl Default for Moments {
    fn default() -> Moments {
        Moments::EMPTY
    }
}

/// Values whose deviations are held at a time.
const BLOCK: usize = 1 << 16;

/// Sum of `xs` by pairwise summation (blocks of 128 summed in 8 lanes),
/// numpy's method: the rounding error grows with the logarithm of the
/// length, not the length.
pub(crate) fn pairwise_sum(xs: &[f64]) -> f64 {
    if xs.len() <= 128 {
        let mut lanes = [0.0f64; 8];
        let mut chunks = xs.chunks_exact(8);
        for c in &mut chunks {
            for (l, x) in lanes.iter_mut().zip(c) {
                *l += x;
            }
        }
        let tail: f64 = chunks.remainder().iter().sum();
        return ((lanes[0] + lanes[1]) + (lanes[2] + lanes[3]))
            + ((lanes[4] + lanes[5]) + (lanes[6] + lanes[7]))
            + tail;
    }
    let half = (xs.len() / 2).next_multiple_of(8);
    pairwise_sum(&xs[..half]) + pairwise_sum(&xs[half..])
}

impl Moments {
    /// No values.
    pub const EMPTY: Moments = Moments {
        count: 0,
        shift: 0.0,
        offset: 0.0,
        m2: 0.0,
        min: f64::INFINITY,
        max: f64::NEG_INFINITY,
    };

    /// The moments of `xs` (finite values): a first mean, the mean offset
    /// from it (what the first mean's rounding lost), then the squared
    /// deviations from the mean.
    pub fn of(xs: &[f64]) -> Moments {
        if xs.is_empty() {
            return Moments::EMPTY;
        }
        let n = xs.len() as f64;
        let shift = pairwise_sum(xs) / n;
        let cap = xs.len().min(BLOCK);
        let (mut dev, mut sq) = (Vec::with_capacity(cap), Vec::with_capacity(cap));
        let (mut sum, mut min, mut max) = (0.0, f64::INFINITY, f64::NEG_INFINITY);
        // In blocks, so a large set needs no copy of its own size.
        for block in xs.chunks(BLOCK) {
            dev.clear();
            for &x in block {
                min = min.min(x);
                max = max.max(x);
                dev.push(x - shift);
            }
            sum += pairwise_sum(&dev);
        }
        let offset = sum / n;
        let (mut m2, mut drift) = (0.0, 0.0);
        for block in xs.chunks(BLOCK) {
            dev.clear();
            sq.clear();
            for &x in block {
                let d = (x - shift) - offset;
                dev.push(d);
                sq.push(d * d);
            }
            drift += pairwise_sum(&dev);
            m2 += pairwise_sum(&sq);
        }
        // The corrected two-pass formula (Chan, Golub and LeVeque): the
        // deviations' sum, zero but for the mean's rounding, takes out
        // what that rounding added to the squares.
        let m2 = (m2 - drift * drift / n).max(0.0);
        Moments {
            count: xs.len() as u64,
            shift,
            offset,
            m2,
            min,
            max,
        }
    }

    /// The moments of the union of the values of `self` and `other`.
    pub fn merge(&self, other: &Moments) -> Moments {
        if other.count == 0 {
            return *self;
        }
        if self.count == 0 {
            return *other;
        }
        let (na, nb) = (self.count as f64, other.count as f64);
        let n = na + nb;
        let d = (other.shift - self.shift) + (other.offset - self.offset);
        Moments {
            count: self.count + other.count,
            shift: self.shift,
            offset: self.offset + d * (nb / n),
            m2: self.m2 + other.m2 + d * d * (na * nb / n),
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// The moments of all `parts`, merged pairwise in their order (the
    /// same tree for the same parts, whatever computed them).
    pub fn merge_all(parts: &[Moments]) -> Moments {
        match parts.len() {
            0 => Moments::EMPTY,
            1 => parts[0],
            n => Moments::merge_all(&parts[..n / 2]).merge(&Moments::merge_all(&parts[n / 2..])),
        }
    }

    /// The mean, `None` without values.
    pub fn mean(&self) -> Option<f64> {
        (self.count > 0).then_some(self.shift + self.offset)
    }

    /// The standard deviation with `ddof` degrees of freedom subtracted
    /// (numpy's `std(ddof=...)`; 0 is the population SD, numpy's
    /// default), `None` when there are no more values than `ddof`.
    pub fn sd(&self, ddof: u64) -> Option<f64> {
        (self.count > ddof).then(|| (self.m2 / (self.count - ddof) as f64).sqrt())
    }

    /// The smallest and largest value, `None` without values.
    pub fn range(&self) -> Option<(f64, f64)> {
        (self.count > 0).then_some((self.min, self.max))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The textbook two-pass formulas, summed naively in f64.
    fn reference(xs: &[f64]) -> (f64, f64) {
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
        (mean, var.sqrt())
    }

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * a.abs().max(b.abs()).max(1e-300)
    }

    #[test]
    fn pairwise_sum_is_the_sum() {
        for n in [0usize, 1, 7, 8, 9, 128, 129, 1000, 4097] {
            let xs: Vec<f64> = (0..n).map(|i| i as f64).collect();
            let want = (n * n.saturating_sub(1) / 2) as f64;
            assert_eq!(pairwise_sum(&xs), want, "{n}");
        }
    }

    #[test]
    fn blocks_merged_give_the_moments_of_the_whole() {
        let mut rng = fastrand::Rng::with_seed(7);
        let xs: Vec<f64> = (0..100_003).map(|_| 1000.0 + rng.f64() * 3.0).collect();
        let whole = Moments::of(&xs);
        let (mean, sd) = reference(&xs);
        assert!(close(whole.mean().unwrap(), mean, 1e-13), "{mean}");
        assert!(close(whole.sd(0).unwrap(), sd, 1e-11));
        for block in [1usize, 10, 999, 65536] {
            let parts: Vec<Moments> = xs.chunks(block).map(Moments::of).collect();
            let m = Moments::merge_all(&parts);
            assert_eq!(m.count, whole.count);
            assert!(close(m.mean().unwrap(), mean, 1e-13), "{block}");
            assert!(close(m.sd(0).unwrap(), sd, 1e-12), "{block}");
            assert_eq!((m.min, m.max), (whole.min, whole.max));
        }
    }

    #[test]
    fn empty_and_single_values() {
        let e = Moments::of(&[]);
        assert_eq!((e.mean(), e.sd(0), e.range()), (None, None, None));
        assert_eq!(Moments::merge_all(&[e, e]).count, 0);
        let one = Moments::of(&[5.0]);
        assert_eq!(
            (one.mean(), one.sd(0), one.sd(1)),
            (Some(5.0), Some(0.0), None)
        );
        assert_eq!(e.merge(&one), one);
        assert_eq!(one.merge(&e), one);
    }
}
