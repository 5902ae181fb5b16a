//! TODO(owner: foundations helper): kinematics.
