//! A small LRU cache of decoded TIFF blocks, bounded by bytes.
//!
//! Tile-by-tile reads with halos, and tile reads of striped files, decode the
//! same strips or tiles several times; keeping recently decoded blocks avoids
//! that. Eviction is least-recently-used by a logical clock (O(n) scan on
//! eviction, n = blocks held: a few hundred at most). An ordered map, not a
//! hash map: a hash map's per-process random seed made the fuzzer's coverage
//! of the reader differ between runs (docs/RELIABILITY.md, deterministic coverage).

use std::collections::BTreeMap;
use std::sync::Arc;

/// Byte-bounded LRU map from block index to decoded bytes.
pub(crate) struct BlockCache {
    capacity: usize,
    used: usize,
    clock: u64,
    map: BTreeMap<u32, (Arc<Vec<u8>>, u64)>,
}

impl BlockCache {
    /// Empty cache holding at most `capacity` bytes (0 disables caching).
    pub(crate) fn new(capacity: usize) -> Self {
        BlockCache {
            capacity,
            used: 0,
            clock: 0,
            map: BTreeMap::new(),
        }
    }

    /// The block, if cached (marks it recently used).
    pub(crate) fn get(&mut self, id: u32) -> Option<Arc<Vec<u8>>> {
        self.clock += 1;
        let now = self.clock;
        self.map.get_mut(&id).map(|e| {
            e.1 = now;
            e.0.clone()
        })
    }

    /// Insert a block, evicting least recently used ones to stay in budget.
    /// Blocks larger than the whole budget are not kept.
    pub(crate) fn put(&mut self, id: u32, data: Arc<Vec<u8>>) {
        let size = data.len();
        if size > self.capacity {
            return;
        }
        self.clock += 1;
        if let Some(old) = self.map.insert(id, (data, self.clock)) {
            self.used -= old.0.len();
        }
        self.used += size;
        while self.used > self.capacity {
            let oldest = self.map.iter().min_by_key(|(_, v)| v.1).map(|(k, _)| *k);
            match oldest {
                Some(k) => {
                    if let Some(v) = self.map.remove(&k) {
                        self.used -= v.0.len();
                    }
                }
                None => break,
            }
        }
    }

    /// Bytes currently held.
    #[cfg(test)]
    pub(crate) fn used(&self) -> usize {
        self.used
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn evicts_least_recently_used_within_budget() {
        let mut c = BlockCache::new(250);
        c.put(1, Arc::new(vec![1; 100]));
        c.put(2, Arc::new(vec![2; 100]));
        assert!(c.get(1).is_some()); // 1 is now more recent than 2
        c.put(3, Arc::new(vec![3; 100])); // over budget: evict 2
        assert!(c.get(2).is_none());
        assert_eq!(c.get(1).map(|v| v[0]), Some(1));
        assert_eq!(c.get(3).map(|v| v[0]), Some(3));
        assert_eq!(c.used(), 200);
        c.put(4, Arc::new(vec![4; 300])); // larger than the budget: not kept
        assert!(c.get(4).is_none());
        assert_eq!(c.used(), 200);
    }
}
