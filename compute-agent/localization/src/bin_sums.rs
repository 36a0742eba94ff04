//! Weight per histogram bin, for the KLD count and the estimate's heaviest block: an
//! open-addressing table keyed by the bin's packed coordinates. Sorting the particles'
//! (bin, weight) pairs, twice per update, was 4 % of an update at 2,000 particles; this
//! is one probe per particle.

/// Summed weights per `u64` bin key (any key).
#[derive(Clone, Debug, Default)]
pub struct BinSums {
    /// (key, sum) per slot, a power of two of them; `None` is free
    slots: Vec<Option<(u64, f64)>>,
    /// keys in first-insertion order, so iteration is deterministic and cheap
    keys: Vec<u64>,
}

impl BinSums {
    /// Empties the table and makes room for up to `n` distinct keys.
    pub fn reset(&mut self, n: usize) {
        let want = (2 * n.max(8)).next_power_of_two();
        if self.slots.len() < want {
            self.slots = vec![None; want];
        } else {
            // clear only what was used: the table stays allocated across updates
            for &k in &self.keys {
                let i = self.find(k);
                self.slots[i] = None;
            }
        }
        self.keys.clear();
    }

    /// The slot holding `key`, or the empty one where it would go.
    #[inline]
    fn find(&self, key: u64) -> usize {
        let mask = self.slots.len() - 1;
        // Fibonacci hashing: the packed coordinates differ in low and middle bits
        let mut i = (key.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 32) as usize & mask;
        loop {
            match self.slots[i] {
                Some((k, _)) if k != key => i = (i + 1) & mask,
                _ => return i,
            }
        }
    }

    /// Adds `w` to `key`'s sum. At most the `n` given to [`BinSums::reset`] keys.
    #[inline]
    pub fn add(&mut self, key: u64, w: f64) {
        assert!(self.keys.len() * 2 < self.slots.len(), "more keys than reset for");
        let i = self.find(key);
        match &mut self.slots[i] {
            Some((_, sum)) => *sum += w,
            free => {
                *free = Some((key, w));
                self.keys.push(key);
            }
        }
    }

    /// `key`'s sum (0 for a key never added).
    #[inline]
    pub fn get(&self, key: u64) -> f64 {
        if self.slots.is_empty() {
            return 0.0;
        }
        self.slots[self.find(key)].map_or(0.0, |(_, sum)| sum)
    }

    /// (key, sum) of every key added, in the order first added.
    pub fn iter(&self) -> impl Iterator<Item = (u64, f64)> + '_ {
        self.keys.iter().map(|&k| (k, self.get(k)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_per_key_and_clears_between_uses() {
        let mut b = BinSums::default();
        b.reset(4);
        for (k, w) in [(3u64, 0.5), (1 << 40, 0.25), (3, 0.125), (0, 1.0), (u64::MAX, 2.0)] {
            b.add(k, w);
        }
        assert_eq!(b.iter().collect::<Vec<_>>(), vec![(3, 0.625), (1 << 40, 0.25), (0, 1.0), (u64::MAX, 2.0)]);
        assert_eq!(b.get(7), 0.0);
        b.reset(4);
        assert_eq!(b.iter().count(), 0);
        assert_eq!(b.get(3), 0.0);
        // many keys colliding in the low bits still sum apart
        b.reset(1000);
        for i in 0..1000u64 {
            b.add(i << 32, 1.0);
            b.add(i << 32, 1.0);
        }
        assert_eq!(b.iter().count(), 1000);
        assert!(b.iter().all(|(_, w)| w == 2.0));
    }
}
