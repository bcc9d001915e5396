//! One value derived from an index, kept with it: a renderer's per-frame
//! set-up that depends only on the index and on a key it computes (which
//! cells a transfer function makes transparent, and the skipping
//! distances over them) is derived once and handed back while the key
//! stays the same, so frames after the first with the same transfer
//! function skip that work.

use std::any::Any;
use std::fmt;
use std::sync::{Arc, Mutex};

/// The values last derived under a few keys, of any type ([`SLOTS`] of
/// them: a new key replaces the least recently used). A clone of its
/// owner starts empty.
#[derive(Default)]
pub struct Memo {
    slots: Mutex<Vec<(u64, Arc<dyn Any + Send + Sync>)>>,
}

/// Values a [`Memo`] keeps (a frame's own rule and its shadows' each take
/// one, so two would do; a viewer switching between two transfer
/// functions takes two more).
pub const SLOTS: usize = 4;

impl Memo {
    /// The value kept under `key` if it is a `T`, else `make()`'s, kept
    /// for the next calls (an error is returned and nothing kept). `make`
    /// runs without the memo locked, so two threads asking at once may
    /// both derive the value; the last one is kept.
    pub fn get_or_try<T: Any + Send + Sync, E>(
        &self,
        key: u64,
        make: impl FnOnce() -> Result<T, E>,
    ) -> Result<Arc<T>, E> {
        {
            let mut slots = self.lock();
            let found = slots.iter().position(|(k, v)| *k == key && (**v).is::<T>());
            if let Some(i) = found {
                let hit = slots.remove(i);
                let v = hit.1.clone().downcast::<T>().ok();
                slots.push(hit);
                if let Some(v) = v {
                    return Ok(v);
                }
            }
        }
        let v = Arc::new(make()?);
        let mut slots = self.lock();
        slots.retain(|(k, _)| *k != key);
        if slots.len() >= SLOTS {
            slots.remove(0);
        }
        slots.push((key, v.clone()));
        Ok(v)
    }

    /// The slots (a panic while they were held left them whole: every
    /// change is one push or removal).
    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<(u64, Arc<dyn Any + Send + Sync>)>> {
        self.slots.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl Clone for Memo {
    fn clone(&self) -> Memo {
        Memo::default()
    }
}

impl fmt::Debug for Memo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let keys: Vec<u64> = self.lock().iter().map(|(k, _)| *k).collect();
        f.debug_struct("Memo").field("keys", &keys).finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_kept_per_key_and_type_and_errors_keep_nothing() {
        let m = Memo::default();
        let mut made = 0;
        let mut get = |key: u64, v: u32| {
            m.get_or_try::<u32, ()>(key, || {
                made += 1;
                Ok(v)
            })
            .map(|a| *a)
        };
        assert_eq!(get(1, 10), Ok(10));
        assert_eq!(get(1, 11), Ok(10));
        assert_eq!(get(2, 20), Ok(20));
        assert_eq!(get(1, 12), Ok(10));
        // Keys 3, 4 and 5 push out the least recently used, 2.
        for k in 3..=5 {
            assert_eq!(get(k, k as u32), Ok(k as u32));
        }
        assert_eq!(get(1, 13), Ok(10));
        assert_eq!(get(2, 21), Ok(21));
        assert_eq!(made, 6);
        // Another type under the same key is derived, not mistaken.
        assert_eq!(*m.get_or_try::<u64, ()>(1, || Ok(7)).unwrap(), 7);
        assert_eq!(m.get_or_try::<u64, &str>(9, || Err("no")), Err("no"));
        assert_eq!(*m.get_or_try::<u64, ()>(1, || Ok(8)).unwrap(), 7);
        assert_eq!(format!("{:?}", m.clone()), "Memo { keys: [] }");
    }
}
