//! Random numbers for Monte Carlo estimates, as a pure function of
//! (seed, pixel, sample index, dimension): no generator state is shared
//! between pixels or threads, so an image is the same bit for bit whatever
//! the thread count, tile size or order in which pixels are computed, and
//! a render can be resumed at any sample index. The ray caster takes no
//! random numbers (one ray through each pixel centre).

/// The frame's sampler: a seed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HashSampler {
    seed: u64,
}

/// The random stream of one pixel's sample: successive dimensions.
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler {
    key: u64,
    dimension: u32,
}

/// A 64-bit mix with full avalanche (SplitMix64's finaliser).
#[inline(always)]
pub(crate) fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl HashSampler {
    /// A sampler with `seed`.
    pub fn new(seed: u64) -> HashSampler {
        HashSampler { seed }
    }

    /// The stream of sample `index` of pixel `(x, y)`.
    #[inline]
    pub fn pixel(&self, x: u32, y: u32, index: u64) -> PixelSampler {
        let pixel = (u64::from(y) << 32) | u64::from(x);
        let key = mix(mix(self.seed ^ mix(pixel)).wrapping_add(index));
        PixelSampler { key, dimension: 0 }
    }
}

impl PixelSampler {
    /// The number for `dimension` of this stream, in `[0, 1)`.
    #[inline(always)]
    pub fn at(&self, dimension: u32) -> f32 {
        let h = mix(self.key ^ mix(u64::from(dimension).wrapping_add(0x9e37_79b9_7f4a_7c15)));
        // 24 random bits: every value is exact in f32 and below 1.
        (h >> 40) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// The next dimension's number, in `[0, 1)`.
    #[inline(always)]
    pub fn next_1d(&mut self) -> f32 {
        let u = self.at(self.dimension);
        self.dimension += 1;
        u
    }

    /// The next two dimensions' numbers.
    #[inline(always)]
    pub fn next_2d(&mut self) -> (f32, f32) {
        (self.next_1d(), self.next_1d())
    }

    /// The dimension the next number comes from.
    pub fn dimension(&self) -> u32 {
        self.dimension
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_pure_functions_of_their_key() {
        let s = HashSampler::new(42);
        let mut a = s.pixel(3, 7, 11);
        let mut b = s.pixel(3, 7, 11);
        for _ in 0..100 {
            assert_eq!(a.next_1d(), b.next_1d());
        }
        assert_eq!(s.pixel(3, 7, 11).at(5), {
            let mut c = s.pixel(3, 7, 11);
            (0..5).for_each(|_| {
                c.next_1d();
            });
            c.next_1d()
        });
        // Any change of seed, pixel, index or dimension changes the number.
        let base = s.pixel(3, 7, 11).at(0);
        for other in [
            HashSampler::new(43).pixel(3, 7, 11).at(0),
            s.pixel(4, 7, 11).at(0),
            s.pixel(3, 8, 11).at(0),
            s.pixel(7, 3, 11).at(0),
            s.pixel(3, 7, 12).at(0),
            s.pixel(3, 7, 11).at(1),
        ] {
            assert_ne!(base, other);
        }
    }

    /// Uniform in [0, 1) and uncorrelated between neighbouring keys: the
    /// mean, variance and lag correlation of a million numbers drawn across
    /// pixels, indices and dimensions, and a 64-bin histogram (chi-square).
    #[test]
    fn numbers_are_uniform_and_uncorrelated() {
        let s = HashSampler::new(7);
        let mut bins = [0u32; 64];
        let (mut sum, mut sum2, mut lag) = (0.0f64, 0.0f64, 0.0f64);
        let mut prev = 0.5f64;
        let mut n = 0u32;
        for y in 0..16 {
            for x in 0..16 {
                for i in 0..64 {
                    let p = s.pixel(x, y, i);
                    for d in 0..61 {
                        let u = p.at(d);
                        assert!((0.0..1.0).contains(&u));
                        bins[(u * 64.0) as usize] += 1;
                        let u = u as f64;
                        sum += u;
                        sum2 += u * u;
                        lag += (u - 0.5) * (prev - 0.5);
                        prev = u;
                        n += 1;
                    }
                }
            }
        }
        let n = n as f64;
        let mean = sum / n;
        let var = sum2 / n - mean * mean;
        assert!((mean - 0.5).abs() < 0.002, "mean {mean}");
        assert!((var - 1.0 / 12.0).abs() < 0.001, "variance {var}");
        assert!((lag / n).abs() < 0.001, "lag correlation {}", lag / n);
        let expect = n / 64.0;
        let chi2: f64 = bins
            .iter()
            .map(|&b| (b as f64 - expect).powi(2) / expect)
            .sum();
        // 63 degrees of freedom: the 99.9% point is about 104.
        assert!(chi2 < 104.0, "chi-square {chi2}");
    }
}
