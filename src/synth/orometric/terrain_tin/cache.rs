//! The bounded caches of built super-tiles and reconstruction blocks: one
//! builder per entry (other threads wait), least recently used dropped
//! beyond a byte budget.

use super::super::tin::Tin;
use super::CACHE_BYTES;
use crate::error::Error;
use crate::error::Result;
use std::sync::Arc;
use std::sync::Mutex;
use std::sync::OnceLock;

/// The final TIN of one super-tile: the global triangles touching it.
pub(super) struct Super {
    pub(super) tin: Tin,
    pub(super) n_samples: usize,
    pub(super) bytes: usize,
}

/// The finished cells of one super-tile (see [`TinTerrain::build_block`]).
pub(super) struct Block {
    pub(super) cells: Vec<f32>,
}

/// Something kept in a [`Cache`], with its heap size.
pub(super) trait Cached {
    fn bytes(&self) -> usize;
}

impl Cached for Super {
    fn bytes(&self) -> usize {
        self.bytes
    }
}

impl Cached for Block {
    fn bytes(&self) -> usize {
        self.cells.len() * 4 + std::mem::size_of::<Block>()
    }
}

pub(super) type Slot<T> = Arc<OnceLock<std::result::Result<Arc<T>, String>>>;

/// LRU cache of super-tiles or blocks: (key, last use, slot).
pub(super) struct Cache<T> {
    pub(super) tick: u64,
    pub(super) slots: Vec<(u64, u64, Slot<T>)>,
}

impl<T: Cached> Cache<T> {
    pub(super) fn new() -> Mutex<Cache<T>> {
        Mutex::new(Cache {
            tick: 0,
            slots: Vec::new(),
        })
    }
}

/// The value cached under `key` in `cache`, built by `build` if absent
/// (one builder per key, other threads wait); least recently used entries
/// are dropped beyond [`CACHE_BYTES`] (an entry in use elsewhere lives on
/// through its Arc).
pub(super) fn cached<T: Cached>(
    cache: &Mutex<Cache<T>>,
    key: u64,
    build: impl FnOnce() -> Result<T>,
) -> Result<Arc<T>> {
    let slot = {
        let mut c = cache.lock().unwrap_or_else(|e| e.into_inner());
        c.tick += 1;
        let tick = c.tick;
        if let Some(s) = c.slots.iter_mut().find(|s| s.0 == key) {
            s.1 = tick;
            s.2.clone()
        } else {
            let s: Slot<T> = Arc::new(OnceLock::new());
            c.slots.push((key, tick, s.clone()));
            let min_keep = 8 + 4 * rayon::current_num_threads();
            loop {
                let bytes: usize = c
                    .slots
                    .iter()
                    .filter_map(|s| match s.2.get() {
                        Some(Ok(t)) => Some(t.bytes()),
                        _ => None,
                    })
                    .sum();
                if bytes <= CACHE_BYTES || c.slots.len() <= min_keep {
                    break;
                }
                let Some(old) = c
                    .slots
                    .iter()
                    .enumerate()
                    .filter(|(_, s)| s.0 != key)
                    .min_by_key(|(_, s)| s.1)
                    .map(|(i, _)| i)
                else {
                    break;
                };
                c.slots.swap_remove(old);
            }
            s
        }
    };
    match slot.get_or_init(|| build().map(Arc::new).map_err(|e| e.to_string())) {
        Ok(t) => Ok(t.clone()),
        Err(m) => Err(Error::invalid(m.clone())),
    }
}
