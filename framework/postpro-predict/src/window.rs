//! A vector indexed by position in the whole program of which only a window is held: values are
//! pushed at the back and forgotten at the front. A streamed prediction holds the blocks and
//! pieces its look-ahead needs; a whole one forgets nothing, and the window is the vector.

use std::ops::{Index, IndexMut, Range};

/// Values at positions `base()..end()` of a sequence, the ones before forgotten.
#[derive(Clone, Debug, PartialEq)]
pub struct Window<T> {
    /// The position of `items[0]`.
    base: usize,
    items: Vec<T>,
}

impl<T> Default for Window<T> {
    fn default() -> Self {
        Window { base: 0, items: Vec::new() }
    }
}

impl<T> Window<T> {
    /// Adds the value at position `end()`.
    pub fn push(&mut self, value: T) {
        self.items.push(value);
    }

    /// Adds the values at positions `end()…`.
    pub fn extend_from_slice(&mut self, values: &[T])
    where
        T: Clone,
    {
        self.items.extend_from_slice(values);
    }

    /// The position after the last value: the number of values ever pushed.
    pub fn end(&self) -> usize {
        self.base + self.items.len()
    }

    /// The first position held.
    pub fn base(&self) -> usize {
        self.base
    }

    /// True before the first push.
    pub fn is_empty(&self) -> bool {
        self.end() == 0
    }

    /// The value at position `i`, if held.
    pub fn get(&self, i: usize) -> Option<&T> {
        i.checked_sub(self.base).and_then(|k| self.items.get(k))
    }

    /// The last value pushed, if held.
    pub fn last(&self) -> Option<&T> {
        self.items.last()
    }

    /// The last value pushed, mutable.
    pub fn last_mut(&mut self) -> Option<&mut T> {
        self.items.last_mut()
    }

    /// The values held.
    pub fn held(&self) -> &[T] {
        &self.items
    }

    /// The values at positions `range` (all held).
    pub fn slice(&self, range: Range<usize>) -> &[T] {
        &self.items[range.start - self.base..range.end - self.base]
    }

    /// Forgets the values before position `i`. The memory is given back in halves, so that a
    /// forgetting at every push costs nothing per value.
    pub fn forget_before(&mut self, i: usize) {
        let k = i.saturating_sub(self.base).min(self.items.len());
        if k > 0 && k * 2 >= self.items.len() {
            self.items.drain(..k);
            self.base += k;
        }
    }

    /// The values held, in order.
    pub fn iter(&self) -> std::slice::Iter<'_, T> {
        self.items.iter()
    }

    /// The values held, as a vector.
    pub fn into_vec(self) -> Vec<T> {
        self.items
    }
}

impl<T> Index<usize> for Window<T> {
    type Output = T;

    fn index(&self, i: usize) -> &T {
        &self.items[i - self.base]
    }
}

impl<T> IndexMut<usize> for Window<T> {
    fn index_mut(&mut self, i: usize) -> &mut T {
        &mut self.items[i - self.base]
    }
}

impl<'a, T> IntoIterator for &'a Window<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;

    fn into_iter(self) -> Self::IntoIter {
        self.items.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::Window;

    #[test]
    fn positions_survive_forgetting() {
        let mut w = Window::default();
        for i in 0..100usize {
            w.push(i * 10);
            w.forget_before(i.saturating_sub(3));
            assert_eq!(w[i], i * 10);
            assert!(w.base() <= i.saturating_sub(3));
            assert!(w.held().len() <= 8, "{} held at {i}", w.held().len());
        }
        assert_eq!(w.end(), 100);
        assert_eq!(w.get(10), None);
        assert_eq!(w.slice(97..100), &[970, 980, 990]);
    }
}
