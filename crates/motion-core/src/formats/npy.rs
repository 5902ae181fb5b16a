//! TODO: npy.
