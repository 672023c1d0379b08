//! The explicit traversal stack of paper section 3 ("the far one is pushed to the stack"):
//! a fixed array on the call stack, never initialised beyond what is pushed.

use core::mem::MaybeUninit;

/// Room for one entry per tree level (trees are at most [`crate::MAX_TREE_DEPTH`] deep).
pub(crate) const STACK_SIZE: usize = 64;

pub(crate) struct Stack<T: Copy> {
    items: [MaybeUninit<T>; STACK_SIZE],
    len: usize,
}

impl<T: Copy> Stack<T> {
    #[inline(always)]
    pub fn new() -> Self {
        Self {
            items: [const { MaybeUninit::uninit() }; STACK_SIZE],
            len: 0,
        }
    }

    /// Panics past [`STACK_SIZE`] entries (a tree deeper than the build allows).
    #[inline(always)]
    pub fn push(&mut self, v: T) {
        self.items[self.len] = MaybeUninit::new(v);
        self.len += 1;
    }

    #[inline(always)]
    pub fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: entries below `len` were written by `push`.
        Some(unsafe { self.items[self.len].assume_init() })
    }
}
