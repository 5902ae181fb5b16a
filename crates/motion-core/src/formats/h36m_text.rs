//! TODO: h36m_text.
