//! A bounded, thread-safe cache of decoded bricks.

use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, Mutex};

const SHARDS: usize = 16;

struct Shard<T> {
    map: HashMap<u64, Arc<[T]>>,
    order: VecDeque<u64>,
}

/// Keeps at most about `capacity` decoded bricks, evicting the oldest
/// inserted first. Lookups lock one of several shards, so threads working on
/// different bricks rarely contend. Decoding happens outside the lock: two
/// threads missing the same brick at once both decode it and one copy wins.
pub struct BrickCache<T> {
    shards: Vec<Mutex<Shard<T>>>,
    per_shard: usize,
}

impl<T> BrickCache<T> {
    /// A cache holding about `capacity` bricks (at least one per shard).
    pub fn new(capacity: usize) -> BrickCache<T> {
        let per_shard = capacity.div_ceil(SHARDS).max(1);
        BrickCache {
            shards: (0..SHARDS)
                .map(|_| {
                    Mutex::new(Shard {
                        map: HashMap::new(),
                        order: VecDeque::new(),
                    })
                })
                .collect(),
            per_shard,
        }
    }

    /// The brick `id`, decoded by `load` if it is not cached.
    pub fn get_or_load<E>(
        &self,
        id: u64,
        load: impl FnOnce() -> Result<Vec<T>, E>,
    ) -> Result<Arc<[T]>, E> {
        let shard = &self.shards[(id as usize) % SHARDS];
        if let Some(hit) = lock(shard).map.get(&id) {
            return Ok(hit.clone());
        }
        let brick: Arc<[T]> = load()?.into();
        let mut s = lock(shard);
        if let Some(hit) = s.map.get(&id) {
            return Ok(hit.clone());
        }
        while s.map.len() >= self.per_shard {
            match s.order.pop_front() {
                Some(old) => {
                    s.map.remove(&old);
                }
                None => break,
            }
        }
        s.map.insert(id, brick.clone());
        s.order.push_back(id);
        Ok(brick)
    }

    /// Number of bricks held now.
    pub fn len(&self) -> usize {
        self.shards.iter().map(|s| lock(s).map.len()).sum()
    }

    /// Whether the cache holds nothing.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    // A panic while holding the lock cannot leave a shard inconsistent
    // (inserts and removals are single calls), so a poisoned lock is usable.
    m.lock().unwrap_or_else(|p| p.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stays_bounded_and_returns_loaded_data() {
        let c: BrickCache<u8> = BrickCache::new(32);
        for id in 0..1000u64 {
            let b = c
                .get_or_load(id, || Ok::<_, ()>(vec![id as u8; 4]))
                .unwrap();
            assert_eq!(b[0], id as u8);
        }
        assert!(c.len() <= 32);
        let again = c.get_or_load(999, || Err(())).unwrap();
        assert_eq!(again[3], (999 % 256) as u8);
    }
}
