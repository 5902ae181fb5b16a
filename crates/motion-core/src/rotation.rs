//! TODO(owner: foundations helper): rotation.
