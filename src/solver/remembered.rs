//! A per-thread memory of work that depends on a sparsity pattern alone (a symbolic
//! factorization, an assembly plan): the `capacity` most recently used entries,
//! least recently used forgotten first. Kept per thread (in a `thread_local!`), so nothing
//! crosses threads and results do not depend on `--threads`.

use std::sync::Arc;

/// Entries `(key, value)`, most recently used last.
pub struct Remembered<K, V> {
    capacity: usize,
    entries: Vec<(K, Arc<V>)>,
}

impl<K, V> Remembered<K, V> {
    /// An empty memory of at most `capacity` entries.
    pub const fn new(capacity: usize) -> Self {
        Remembered {
            capacity,
            entries: Vec::new(),
        }
    }

    /// The value of the first entry whose key `matches`, else the one `make` builds (then
    /// remembered, forgetting the least recently used entry when full); either way it becomes
    /// the most recently used.
    pub fn get_or_make<E>(
        &mut self,
        matches: impl Fn(&K) -> bool,
        make: impl FnOnce() -> Result<(K, V), E>,
    ) -> Result<Arc<V>, E> {
        let entry = match self.entries.iter().position(|(k, _)| matches(k)) {
            Some(i) => self.entries.remove(i),
            None => {
                let (key, value) = make()?;
                if self.entries.len() == self.capacity {
                    self.entries.remove(0);
                }
                (key, Arc::new(value))
            }
        };
        let value = Arc::clone(&entry.1);
        self.entries.push(entry);
        Ok(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hit is not rebuilt and becomes the most recently used; a miss beyond the capacity
    /// forgets the least recently used.
    #[test]
    fn least_recently_used_is_forgotten() {
        let mut memory = Remembered::<u32, u32>::new(2);
        let mut built = Vec::new();
        let mut get = |memory: &mut Remembered<u32, u32>, key: u32| {
            *memory
                .get_or_make(
                    |&k| k == key,
                    || {
                        built.push(key);
                        Ok::<_, ()>((key, 10 * key))
                    },
                )
                .unwrap()
        };
        assert_eq!(get(&mut memory, 1), 10);
        assert_eq!(get(&mut memory, 2), 20);
        assert_eq!(get(&mut memory, 1), 10); // hit: 2 is now the least recently used
        assert_eq!(get(&mut memory, 3), 30); // forgets 2
        assert_eq!(get(&mut memory, 1), 10);
        assert_eq!(get(&mut memory, 2), 20); // rebuilt
        assert_eq!(built, vec![1, 2, 3, 2]);
        let failed = memory.get_or_make(|&k| k == 9, || Err::<(u32, u32), _>("no"));
        assert_eq!(failed.unwrap_err(), "no");
    }
}
