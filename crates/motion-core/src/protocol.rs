//! The standard H3.6M evaluation protocol: actions, the fixed test windows, loading them.
