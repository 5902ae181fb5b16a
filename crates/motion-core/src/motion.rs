//! TODO(owner: foundations helper): motion.
