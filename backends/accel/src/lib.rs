//! The traversal interface (paper section 3). Filled in by the two-level BSP issue.
