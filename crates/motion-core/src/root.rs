//! TODO(owner: foundations helper): root.
