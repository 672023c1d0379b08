//! The paper's two-level BSP (section 3). Filled in by the two-level BSP issue.
