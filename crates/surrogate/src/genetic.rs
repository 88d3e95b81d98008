//! genetic (to be written)
