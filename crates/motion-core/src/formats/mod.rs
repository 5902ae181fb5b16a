//! Motion file formats: H3.6M exp-map text, BVH and `.npy`.
pub mod bvh;
pub mod h36m_text;
pub mod npy;
pub mod expmap_bvh;
