//! The compiler's maps of small keys (graph nodes, node ids, names), hashed by rustc's own
//! hasher (`rustc-hash`'s `FxHasher`): the standard library's SipHash resists collisions
//! an adversary chooses, which costs a tenth of a large model's build time; a model is
//! not such an adversary, and its size is bounded where it is read
//! (`front::limits`). Only maps whose order nothing reads use it, so the generated code
//! does not depend on it.

/// A map hashed by `FxHasher`.
pub type FastMap<K, V> = rustc_hash::FxHashMap<K, V>;

/// A set hashed by `FxHasher`.
pub type FastSet<T> = rustc_hash::FxHashSet<T>;

#[cfg(test)]
mod tests {
    use super::{FastMap, FastSet};

    #[test]
    fn maps_keyed_by_text_and_numbers_find_what_they_hold() {
        let mut names: FastMap<String, usize> = FastMap::default();
        let mut ids: FastSet<usize> = FastSet::default();
        for i in 0..1000 {
            names.insert(format!("tmp_{i}"), i);
            ids.insert(i * 7);
        }
        assert!((0..1000).all(|i| names[&format!("tmp_{i}")] == i));
        assert!((0..1000).all(|i| ids.contains(&(i * 7)) && !ids.contains(&(i * 7 + 1))));
    }
}
