//! The 8-byte kd-tree node of paper section 3 (figure 2): flags, split axis and child offset
//! in one `u32`, the split position as `f32`; both children stored next to each other.

/// A kd-tree node (8 bytes).
///
/// `word` bits 0-1: the split axis (0, 1, 2) of an inner node, or 3 for a leaf. For an inner
/// node, bits 2 and 3 are set when its left or right child is an empty leaf (so that the
/// single-ray walk skips that child without loading it: most leaves a ray crosses are empty,
/// see [`crate::KdTree::mark_empty_children`]) and bits 4-31 hold the index of its left child
/// (the right child follows it); for a leaf, bits 2-31 hold the index of its first item in
/// the tree's item list. `data`: the split position's bits (inner) or the number of items
/// (leaf).
///
/// Children pairs start at even indices, so a pair never straddles a 16-byte boundary (and
/// so never a cache line).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(C, align(8))]
pub struct Node {
    word: u32,
    data: u32,
}

const LEAF: u32 = 3;

/// The largest item index a leaf can hold (30 bits).
pub const MAX_INDEX: usize = (1 << 30) - 1;

/// The largest child index an inner node can hold (28 bits).
pub const MAX_CHILD: usize = (1 << 28) - 1;

impl Node {
    /// An inner node splitting `axis` at `split`; children at `left` and `left + 1`.
    #[inline]
    pub fn inner(axis: usize, split: f32, left: usize) -> Self {
        debug_assert!(axis < 3 && left <= MAX_CHILD && left.is_multiple_of(2));
        Self {
            word: (left as u32) << 4 | axis as u32,
            data: split.to_bits(),
        }
    }

    /// A leaf holding items `first .. first + count`.
    #[inline]
    pub fn leaf(first: usize, count: usize) -> Self {
        debug_assert!(first <= MAX_INDEX && count <= u32::MAX as usize);
        Self {
            word: (first as u32) << 2 | LEAF,
            data: count as u32,
        }
    }

    #[inline(always)]
    pub fn is_leaf(self) -> bool {
        self.word & 3 == LEAF
    }

    /// Split axis of an inner node.
    #[inline(always)]
    pub fn axis(self) -> usize {
        (self.word & 3) as usize
    }

    /// Index of the left child of an inner node (the right one is `left() + 1`).
    #[inline(always)]
    pub fn left(self) -> usize {
        (self.word >> 4) as usize
    }

    /// Of an inner node: bit 0 set when the left child is an empty leaf, bit 1 when the right
    /// one is (`empty_children() >> side & 1` for child `left() + side`).
    #[inline(always)]
    pub fn empty_children(self) -> u32 {
        self.word >> 2 & 3
    }

    /// This inner node with [`Node::empty_children`] set to `bits`.
    #[inline]
    pub fn with_empty_children(self, bits: u32) -> Self {
        debug_assert!(!self.is_leaf() && bits < 4);
        Self {
            word: self.word & !(3 << 2) | bits << 2,
            data: self.data,
        }
    }

    /// Split position of an inner node.
    #[inline(always)]
    pub fn split(self) -> f32 {
        f32::from_bits(self.data)
    }

    /// Item range of a leaf.
    #[inline(always)]
    pub fn items(self) -> core::ops::Range<usize> {
        let first = (self.word >> 2) as usize;
        first..first + self.data as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packs_in_eight_bytes() {
        assert_eq!(size_of::<Node>(), 8);
        let n = Node::inner(2, -1.5, MAX_CHILD - 1);
        assert!(!n.is_leaf());
        assert_eq!((n.axis(), n.split(), n.left()), (2, -1.5, MAX_CHILD - 1));
        assert_eq!(n.empty_children(), 0);
        for bits in 0..4 {
            let e = n.with_empty_children(bits);
            assert_eq!(e.empty_children(), bits);
            assert_eq!((e.axis(), e.split(), e.left()), (2, -1.5, MAX_CHILD - 1));
        }
        let l = Node::leaf(MAX_INDEX, 7);
        assert!(l.is_leaf());
        assert_eq!(l.items(), MAX_INDEX..MAX_INDEX + 7);
    }
}
