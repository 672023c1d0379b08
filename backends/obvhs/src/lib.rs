//! obvhs BVH2 and CWBVH behind the traversal interface (paper section 3 comparison).
