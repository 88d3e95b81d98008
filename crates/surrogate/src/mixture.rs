//! mixture (to be written)
