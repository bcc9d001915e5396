//! Random numbers for Monte Carlo estimates, as a pure function of
//! (seed, pixel, sample index, dimension): no generator state is shared
//! between pixels or threads, so an image is the same bit for bit whatever
//! the thread count, tile size or order in which pixels are computed, and
//! a render can be resumed at any sample index. The ray caster takes no
//! random numbers (one ray through each pixel centre).
//!
//! Two kinds ([`SamplerKind`]):
//! - `Hash`: every number is a hash of its key (independent samples).
//! - `Sobol`: the numbers a path tracer draws at fixed places of a path
//!   (the pixel position, and per scattering event up to [`QMC_EVENTS`]
//!   its structured draws: the first free-flight step, the shadow ray's
//!   first step, the environment-map sample, roulette and the scattered
//!   direction; see [`Slot`]) come from an Owen-scrambled Sobol sequence
//!   (the `sobol_burley` crate, Burley's hash-based nested uniform
//!   scrambling), padded: each pair of slots is its own 2D sequence with
//!   its own scramble and shuffle, so the first 2^k samples of a pixel
//!   hit every elementary interval of area 2^-k of any pair's square. The
//!   pixel's scramble seed is a hash of (seed, pixel, sample index /
//!   2^16). Numbers drawn a variable number of times (every tentative
//!   collision after the first) stay hashed, on their own dimensions.

/// Which random numbers a sampler gives.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SamplerKind {
    /// Independent hashed numbers for every dimension.
    Hash,
    /// Owen-scrambled Sobol points for the structured slots, hashes for
    /// the rest.
    #[default]
    Sobol,
}

impl SamplerKind {
    /// The kind a name (`hash` or `sobol`) stands for.
    pub fn from_name(name: &str) -> Option<SamplerKind> {
        match name {
            "hash" => Some(SamplerKind::Hash),
            "sobol" => Some(SamplerKind::Sobol),
            _ => None,
        }
    }

    /// The name of the kind (`hash` or `sobol`).
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Hash => "hash",
            SamplerKind::Sobol => "sobol",
        }
    }
}

/// Scattering events (the camera segment counting as event 0) whose
/// structured draws come from the Sobol sequence; later events' come from
/// the hash.
pub const QMC_EVENTS: u32 = 4;

/// A structured draw's place in an event's block of Sobol dimensions (the
/// pixel position takes the two dimensions before the first block). Slots
/// `2k` and `2k + 1` form one padded 2D sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Slot {
    /// The first exponential step of the event's free flight.
    Flight = 0,
    /// The hybrid surface-or-phase choice.
    Surface = 1,
    /// The environment map's direction, first coordinate.
    EnvU = 2,
    /// The environment map's direction, second coordinate.
    EnvV = 3,
    /// The first shadow ray's first exponential step.
    Shadow = 4,
    /// Russian roulette on the throughput.
    Roulette = 5,
    /// The scattered direction, first coordinate.
    DirU = 6,
    /// The scattered direction, second coordinate.
    DirV = 7,
}

/// Sobol dimensions 0 and 1 of a reversed-bit index by two byte tables
/// each: the generator is linear over GF(2), so the value is the XOR of
/// the values of the index's top and second bytes (the 16 bits
/// `sobol_burley` uses), two loads instead of a loop over the set bits.
static SOBOL_BYTES: std::sync::OnceLock<[[[u32; 256]; 2]; 2]> = std::sync::OnceLock::new();

/// `sobol_burley::parts::sobol_rev(rev, k)` for `k` 0 or 1, through
/// [`SOBOL_BYTES`].
#[inline(always)]
fn sobol_rev(rev: u32, k: u32) -> u32 {
    let t = SOBOL_BYTES.get_or_init(|| {
        std::array::from_fn(|k| {
            std::array::from_fn(|byte| {
                std::array::from_fn(|b| {
                    sobol_burley::parts::sobol_rev((b as u32) << (24 - 8 * byte), k as u32)
                })
            })
        })
    });
    let t = &t[k as usize & 1];
    t[0][(rev >> 24) as usize] ^ t[1][((rev >> 16) & 0xff) as usize]
}

/// Sobol dimensions per event block.
const SLOTS: u32 = 8;

/// Sample indices one Sobol sequence serves (`sobol_burley`'s limit); a
/// pixel's later samples start a fresh scramble every 2^16 samples.
const SOBOL_SPAN: u64 = 1 << 16;

/// The frame's sampler: a seed and a kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HashSampler {
    seed: u64,
    kind: SamplerKind,
}

/// The random stream of one pixel's sample: successive hashed dimensions,
/// and (Sobol) the structured slots.
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler {
    key: u64,
    dimension: u32,
    /// The Sobol index and the pixel's scramble seed (`None`: hashes only).
    sobol: Option<(u32, u64)>,
    /// The first Sobol dimension of the current event's block.
    base: u32,
}

/// A 64-bit mix with full avalanche (SplitMix64's finaliser).
#[inline(always)]
pub(crate) fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl HashSampler {
    /// A hash sampler with `seed`.
    pub fn new(seed: u64) -> HashSampler {
        HashSampler::with_kind(seed, SamplerKind::Hash)
    }

    /// A sampler of `kind` with `seed`.
    pub fn with_kind(seed: u64, kind: SamplerKind) -> HashSampler {
        HashSampler { seed, kind }
    }

    /// The stream of sample `index` of pixel `(x, y)`.
    #[inline]
    pub fn pixel(&self, x: u32, y: u32, index: u64) -> PixelSampler {
        let pixel = (u64::from(y) << 32) | u64::from(x);
        let pixel_key = mix(self.seed ^ mix(pixel));
        let key = mix(pixel_key.wrapping_add(index));
        let sobol = match self.kind {
            SamplerKind::Hash => None,
            SamplerKind::Sobol => {
                let span = index / SOBOL_SPAN;
                let seed = mix(pixel_key ^ mix(span ^ 0x5851_f42d_4c95_7f2d));
                Some(((index % SOBOL_SPAN) as u32, seed))
            }
        };
        PixelSampler {
            key,
            dimension: 0,
            sobol,
            base: 2,
        }
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

    /// Pair `pair`'s shuffled (reversed-bit) Sobol index and the
    /// scrambles of its two coordinates: each pair of the padded sequence
    /// has its own, from one 64-bit hash of the pixel's seed and the pair.
    #[inline(always)]
    fn shuffle(index: u32, seed: u64, pair: u32) -> (u32, [u32; 2]) {
        let h = mix(seed ^ u64::from(pair).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        let (lo, hi) = (h as u32, (h >> 32) as u32);
        let rev = sobol_burley::parts::owen_scramble_rev(index.reverse_bits(), lo);
        (rev, [hi, hi ^ lo.rotate_left(16)])
    }

    /// Coordinate `k` (0 or 1) of a shuffled index: Sobol dimension `k`,
    /// Owen-scrambled by its own scramble.
    #[inline(always)]
    fn coordinate((rev, scrambles): (u32, [u32; 2]), k: u32) -> f32 {
        use sobol_burley::parts::{owen_scramble_rev, u32_to_f32_norm};
        let k = k & 1;
        let x = owen_scramble_rev(sobol_rev(rev, k), scrambles[k as usize]);
        u32_to_f32_norm(x.reverse_bits())
    }

    /// The point of the padded 2D Owen-scrambled Sobol sequence `pair`.
    #[inline(always)]
    fn sobol_2d(index: u32, seed: u64, pair: u32) -> (f32, f32) {
        let s = Self::shuffle(index, seed, pair);
        (Self::coordinate(s, 0), Self::coordinate(s, 1))
    }

    /// Sobol dimension `d` of this sample: coordinate `d % 2` of pair
    /// `d / 2`.
    #[inline(always)]
    fn sobol_at(index: u32, seed: u64, d: u32) -> f32 {
        Self::coordinate(Self::shuffle(index, seed, d >> 1), d & 1)
    }

    /// The pixel position's two numbers (Sobol pair 0, or the next two
    /// hashed dimensions).
    #[inline(always)]
    pub fn pixel_2d(&mut self) -> (f32, f32) {
        match self.sobol {
            Some((i, seed)) => Self::sobol_2d(i, seed, 0),
            None => self.next_2d(),
        }
    }

    /// Start the structured draws of scattering event `event` (0: the
    /// camera segment).
    #[inline(always)]
    pub fn event(&mut self, event: u32) {
        self.base = if event < QMC_EVENTS {
            2 + event * SLOTS
        } else {
            u32::MAX
        };
    }

    /// The number of `slot` in the current event: from the Sobol sequence
    /// when this is one and the event is among the first [`QMC_EVENTS`],
    /// else the next hashed dimension's (so a hash sampler draws exactly
    /// the numbers of [`PixelSampler::next_1d`]).
    #[inline(always)]
    pub fn slot(&mut self, slot: Slot) -> f32 {
        match self.sobol {
            Some((i, seed)) if self.base != u32::MAX => {
                Self::sobol_at(i, seed, self.base + slot as u32)
            }
            _ => self.next_1d(),
        }
    }

    /// The numbers of slots `first` and `first + 1` (a pair: `first` even)
    /// in the current event, as two calls of [`PixelSampler::slot`] give,
    /// at the cost of one Sobol index shuffle.
    #[inline(always)]
    pub fn slot_2d(&mut self, first: Slot) -> (f32, f32) {
        debug_assert!((first as u32).is_multiple_of(2));
        match self.sobol {
            Some((i, seed)) if self.base != u32::MAX => {
                Self::sobol_2d(i, seed, (self.base + first as u32) >> 1)
            }
            _ => self.next_2d(),
        }
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

    /// Whether the points `(u, v)` (2^k of them) put exactly one point in
    /// every elementary interval `[i/2^a, (i+1)/2^a) × [j/2^b, (j+1)/2^b)`
    /// with `a + b = k`: the (0, k, 2)-net property.
    fn is_net(points: &[(f32, f32)], k: u32) -> bool {
        (0..=k).all(|a| {
            let b = k - a;
            let mut hit = vec![false; 1 << k];
            points.iter().all(|&(u, v)| {
                let i = (u * (1u32 << a) as f32) as usize;
                let j = (v * (1u32 << b) as f32) as usize;
                !std::mem::replace(&mut hit[(i << b) | j], true)
            })
        })
    }

    /// The Sobol sampler's structured pairs are (0, k, 2)-nets for every
    /// power of two of a pixel's first samples, and each slot alone hits
    /// every interval of 1/2^k once; the hash sampler's numbers are not
    /// (the property is the sampler's, not the test's).
    #[test]
    fn sobol_pairs_are_stratified_and_hashes_are_not() {
        let sobol = HashSampler::with_kind(3, SamplerKind::Sobol);
        let hash = HashSampler::new(3);
        for (x, y) in [(0, 0), (5, 9), (200, 17)] {
            for k in [2, 4, 6, 8] {
                let n = 1u64 << k;
                let pairs = |s: &HashSampler, event: u32, a: Slot, b: Slot| -> Vec<(f32, f32)> {
                    (0..n)
                        .map(|i| {
                            let mut p = s.pixel(x, y, i);
                            if event == u32::MAX {
                                return p.pixel_2d();
                            }
                            p.event(event);
                            (p.slot(a), p.slot(b))
                        })
                        .collect()
                };
                for (event, a, b) in [
                    (u32::MAX, Slot::DirU, Slot::DirV),
                    (1, Slot::DirU, Slot::DirV),
                    (3, Slot::EnvU, Slot::EnvV),
                    (0, Slot::Flight, Slot::Surface),
                    (2, Slot::Shadow, Slot::Roulette),
                ] {
                    let p = pairs(&sobol, event, a, b);
                    assert!(is_net(&p, k), "pixel {x},{y} event {event} {a:?} k {k}");
                    let h = pairs(&hash, event, a, b);
                    if k >= 4 {
                        assert!(!is_net(&h, k), "hash: pixel {x},{y} event {event} k {k}");
                    }
                }
            }
        }
        // Past the Sobol events, and past 2^16 samples (a fresh
        // scramble), numbers are still in [0, 1) and deterministic.
        let mut p = sobol.pixel(1, 2, (1 << 16) + 5);
        p.event(QMC_EVENTS);
        let u = p.slot(Slot::DirU);
        assert!((0.0..1.0).contains(&u));
        let mut q = sobol.pixel(1, 2, (1 << 16) + 5);
        q.event(QMC_EVENTS);
        assert_eq!(q.slot(Slot::DirU), u);
        // A pair at once is its two slots.
        let mut a = sobol.pixel(7, 8, 9);
        let mut b = a;
        a.event(1);
        b.event(1);
        assert_eq!(
            a.slot_2d(Slot::DirU),
            (b.slot(Slot::DirU), b.slot(Slot::DirV))
        );
        assert_ne!(
            sobol.pixel(1, 2, 1 << 16).pixel_2d(),
            sobol.pixel(1, 2, 0).pixel_2d()
        );
    }

    /// The byte tables give the crate's Sobol values for every 16-bit
    /// index.
    #[test]
    fn sobol_byte_tables_match_the_crate() {
        for i in 0..1u32 << 16 {
            let rev = i.reverse_bits();
            for k in 0..2 {
                assert_eq!(sobol_rev(rev, k), sobol_burley::parts::sobol_rev(rev, k));
            }
        }
    }

    /// A hash sampler's slots and pixel position are its plain stream, in
    /// call order (`--sampler hash` draws independent numbers exactly as
    /// before the Sobol sampler came).
    #[test]
    fn hash_slots_are_the_plain_stream() {
        let s = HashSampler::new(11);
        let mut a = s.pixel(4, 5, 6);
        let mut b = s.pixel(4, 5, 6);
        let mut got = vec![a.pixel_2d().0];
        a.event(2);
        got.push(a.slot(Slot::DirV));
        got.push(a.next_1d());
        got.push(a.slot(Slot::Flight));
        let want: Vec<f32> = (0..5).map(|_| b.next_1d()).collect();
        assert_eq!(got, [want[0], want[2], want[3], want[4]]);
    }

    /// Different pixels and seeds get different scrambles of the Sobol
    /// sequence (no two pixels see the same points).
    #[test]
    fn sobol_scrambles_differ_between_pixels_and_seeds() {
        let s = HashSampler::with_kind(1, SamplerKind::Sobol);
        let base = s.pixel(0, 0, 3).pixel_2d();
        for other in [
            s.pixel(1, 0, 3).pixel_2d(),
            s.pixel(0, 1, 3).pixel_2d(),
            HashSampler::with_kind(2, SamplerKind::Sobol)
                .pixel(0, 0, 3)
                .pixel_2d(),
        ] {
            assert_ne!(base, other);
        }
    }
}
