//! Shards: one of `N` independent jobs that together cover a volume's
//! units of work (brick layers, slices, macrocell layers), for running a
//! conversion or an index build as an array job under any scheduler.

use std::fmt;
use std::ops::Range;
use std::str::FromStr;

/// The most shards a job may be split into.
pub const MAX_SHARDS: u32 = 1 << 20;

/// Shard `index` of `count` (`0 <= index < count`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Shard {
    /// Which shard, from 0.
    pub index: u32,
    /// How many shards in all.
    pub count: u32,
}

impl Shard {
    /// Shard `index` of `count`, if `index < count <= MAX_SHARDS`.
    pub fn new(index: u32, count: u32) -> Option<Shard> {
        ((1..=MAX_SHARDS).contains(&count) && index < count).then_some(Shard { index, count })
    }

    /// The units `[start, end)` of `total` this shard owns: the shards
    /// split `total` into `count` contiguous runs whose lengths differ by
    /// at most one, in shard order (shards past `total` own none).
    pub fn units(&self, total: u64) -> Range<u64> {
        let at = |k: u32| (u128::from(total) * u128::from(k) / u128::from(self.count)) as u64;
        at(self.index)..at(self.index + 1)
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = String;

    /// Parse `K/N`: shard K (from 0) of N.
    fn from_str(s: &str) -> Result<Shard, String> {
        let (k, n) = s
            .split_once('/')
            .ok_or_else(|| format!("'{s}' is not K/N (shard K of N, K from 0)"))?;
        let num = |v: &str| -> Result<u32, String> {
            v.trim()
                .parse::<u32>()
                .map_err(|_| format!("'{s}': '{}' is not a whole number", v.trim()))
        };
        let (k, n) = (num(k)?, num(n)?);
        if n == 0 || n > MAX_SHARDS {
            return Err(format!("'{s}': the shard count must be 1..={MAX_SHARDS}"));
        }
        Shard::new(k, n)
            .ok_or_else(|| format!("'{s}': shard {k} does not exist (shards are numbered 0..{n})"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_cover_every_unit_once_in_order() {
        for total in [0u64, 1, 2, 7, 64, 1000, u64::MAX / 3] {
            for count in [1u32, 2, 3, 7, 64, 1000] {
                let mut next = 0;
                for index in 0..count {
                    let r = Shard { index, count }.units(total);
                    assert_eq!(r.start, next, "total {total} count {count} shard {index}");
                    assert!(r.end >= r.start);
                    let fair = total / count as u64;
                    assert!(r.end - r.start <= fair + 1 && r.end - r.start >= fair);
                    next = r.end;
                }
                assert_eq!(next, total);
            }
        }
    }

    #[test]
    fn parses_and_refuses() {
        assert_eq!("3/8".parse::<Shard>(), Ok(Shard { index: 3, count: 8 }));
        assert_eq!(" 0 / 1 ".parse::<Shard>(), Ok(Shard { index: 0, count: 1 }));
        for bad in ["8/8", "1/0", "3", "a/2", "-1/2", "1/2/3", "0/2000000"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        assert_eq!(Shard { index: 2, count: 5 }.to_string(), "2/5");
    }
}
