//! A growable vector of bits: what the streamed passes keep per target or per check.
//!
//! The bits are kept in chunks of 8 KiB that never move: a vector grown by doubling copies itself
//! to a new place at each growth, and the places it leaves stay in the process's memory (freed
//! to the allocator, not to the system): about as much again as the bits themselves, which grow
//! with the file.

/// Words in a chunk (8 KiB: 65 536 bits).
const CHUNK_WORDS: usize = 1024;
/// Bits in a chunk.
const CHUNK_BITS: usize = CHUNK_WORDS * 64;

/// A growable vector of bits.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Bits {
    chunks: Vec<Box<[u64; CHUNK_WORDS]>>,
    len: usize,
}

impl Bits {
    /// Adds a bit at the end.
    pub(crate) fn push(&mut self, bit: bool) {
        if self.len.is_multiple_of(CHUNK_BITS) {
            self.chunks.push(Box::new([0; CHUNK_WORDS]));
        }
        let i = self.len;
        self.len += 1;
        if bit {
            self.set(i, true);
        }
    }

    /// Bit `i` (false past the end).
    pub(crate) fn get(&self, i: usize) -> bool {
        i < self.len && self.chunks[i / CHUNK_BITS][i % CHUNK_BITS / 64] & (1 << (i % 64)) != 0
    }

    /// Sets bit `i` (below the length).
    pub(crate) fn set(&mut self, i: usize, bit: bool) {
        let word = &mut self.chunks[i / CHUNK_BITS][i % CHUNK_BITS / 64];
        if bit {
            *word |= 1 << (i % 64);
        } else {
            *word &= !(1 << (i % 64));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bits_are_kept_across_chunks() {
        let pattern = |i: usize| (i * 7 + i / 3) % 5 < 2;
        let n = 2 * CHUNK_BITS + 100;
        let mut bits = Bits::default();
        for i in 0..n {
            bits.push(pattern(i));
        }
        assert_eq!(bits.chunks.len(), 3);
        assert!((0..n).all(|i| bits.get(i) == pattern(i)));
        assert!(!bits.get(n) && !bits.get(10 * n), "past the end");
        for i in [0, 63, 64, CHUNK_BITS - 1, CHUNK_BITS, n - 1] {
            bits.set(i, !pattern(i));
            assert_eq!(bits.get(i), !pattern(i), "bit {i}");
            bits.set(i, pattern(i));
        }
        assert!((0..n).all(|i| bits.get(i) == pattern(i)));
        let mut again = Bits::default();
        (0..n).for_each(|i| again.push(pattern(i)));
        assert_eq!(again, bits);
        again.set(5, !pattern(5));
        assert_ne!(again, bits);
    }
}
