//! TODO: bvh.
