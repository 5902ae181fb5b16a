//! TODO(owner: foundations helper): skeleton.
