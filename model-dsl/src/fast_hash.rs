//! A fast hasher for the compiler's own maps of small keys (graph nodes, node ids, names):
//! the standard library's SipHash resists collisions an adversary chooses, which a
//! model's compiler does not need, and was a tenth of a large model's build time. Only
//! maps whose order nothing reads use it, so the generated code does not depend on it.

use std::collections::{HashMap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};

/// A map hashed by [`FastHasher`].
pub type FastMap<K, V> = HashMap<K, V, BuildHasherDefault<FastHasher>>;

/// A set hashed by [`FastHasher`].
pub type FastSet<T> = HashSet<T, BuildHasherDefault<FastHasher>>;

/// The multiply-and-rotate hash of rustc's own tables (`FxHasher`), word by word.
#[derive(Clone, Copy, Default)]
pub struct FastHasher {
    hash: u64,
}

/// An odd constant with well-spread bits (from `FxHasher`).
const SEED: u64 = 0x51_7c_c1_b7_27_22_0a_95;

impl FastHasher {
    fn add(&mut self, word: u64) {
        self.hash = (self.hash.rotate_left(5) ^ word).wrapping_mul(SEED);
    }
}

impl Hasher for FastHasher {
    fn write(&mut self, bytes: &[u8]) {
        let mut chunks = bytes.chunks_exact(8);
        for chunk in &mut chunks {
            let mut word = [0; 8];
            word.copy_from_slice(chunk);
            self.add(u64::from_le_bytes(word));
        }
        let mut rest = [0; 8];
        let tail = chunks.remainder();
        rest[..tail.len()].copy_from_slice(tail);
        self.add(u64::from_le_bytes(rest) ^ ((tail.len() as u64) << 59));
    }

    fn write_u8(&mut self, n: u8) {
        self.add(u64::from(n));
    }

    fn write_u32(&mut self, n: u32) {
        self.add(u64::from(n));
    }

    fn write_u64(&mut self, n: u64) {
        self.add(n);
    }

    fn write_usize(&mut self, n: usize) {
        self.add(n as u64);
    }

    fn finish(&self) -> u64 {
        self.hash
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maps_keyed_by_text_and_numbers_find_what_they_hold() {
        let mut names: FastSet<&str> = FastSet::default();
        let words: Vec<String> = (0..1000).map(|i| format!("p_{i}_{}", i % 7)).collect();
        names.extend(words.iter().map(String::as_str));
        assert!(words.iter().all(|w| names.contains(w.as_str())));
        assert!(!names.contains("p_1000_6") && !names.contains(""));
        let squares: FastMap<u32, u64> = (0..1000u32)
            .map(|i| (i, u64::from(i) * u64::from(i)))
            .collect();
        assert_eq!(squares.len(), 1000);
        assert_eq!(squares[&999], 998_001);
    }
}
