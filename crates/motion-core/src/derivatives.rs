//! TODO(owner: foundations helper): derivatives.
