//! How the films of consecutive shares of the same rays combine, front
//! to back, into the film of whole rays.

use crate::film::{Film, Px};

/// How the films of consecutive shares of the same rays combine, front to
/// back ([`Film::composite`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Composite {
    /// Premultiplied colour, front over back (DVR).
    Over,
    /// The front-most share that hit (iso-surfaces).
    FirstHit,
    /// The largest value, the front-most on ties (MIP).
    Max,
    /// The smallest value, the front-most on ties (MinIP).
    Min,
    /// The sum of the values (X-ray).
    Sum,
}

impl Px {
    /// Join `f`, the share behind what was joined so far, by `how`.
    #[inline]
    pub(crate) fn join(&mut self, f: &Px, how: Composite) {
        self.count = self.count.max(f.count);
        self.samples += f.samples;
        let n = f.count.max(1) as f64;
        let c = f.rgba.map(|c| c / n);
        let v = f.value;
        match how {
            Composite::Over => {
                let keep = 1.0 - self.rgba[3];
                for (a, b) in self.rgba.iter_mut().zip(c) {
                    *a += keep * b;
                }
            }
            Composite::FirstHit => {
                if self.value.is_nan() && !v.is_nan() {
                    (self.rgba, self.value, self.depth) = (c, v, f.depth);
                }
            }
            Composite::Max | Composite::Min => {
                let beats = match how {
                    Composite::Max => v > self.value,
                    _ => v < self.value,
                };
                if !v.is_nan() && (self.value.is_nan() || beats) {
                    (self.value, self.depth) = (v, f.depth);
                }
            }
            Composite::Sum => {
                if !v.is_nan() {
                    self.value = if self.value.is_nan() {
                        v
                    } else {
                        self.value + v
                    };
                }
            }
        }
    }
}

impl Film {
    /// The film of whole rays from the films of their consecutive shares
    /// (see [`crate::distributed`]), given front to back, combined per
    /// pixel by `how`. Totals add up; the render time is the slowest
    /// share's.
    pub fn composite(front_to_back: &[&Film], how: Composite) -> Film {
        let Some(first) = front_to_back.first() else {
            return Film::new(0, 0);
        };
        let mut out = Film::new(first.width, first.height);
        for f in front_to_back {
            let s = &mut out.stats;
            s.rays += f.stats.rays;
            s.samples += f.stats.samples;
            s.skips += f.stats.skips;
            s.culled_blocks += f.stats.culled_blocks;
            s.render_s = s.render_s.max(f.stats.render_s);
        }
        for p in 0..out.rgba.len() {
            let mut acc = Px::START;
            for f in front_to_back {
                acc.join(&f.px(p), how);
            }
            out.set(p, &acc);
        }
        out
    }
}
