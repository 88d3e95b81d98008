//! gp (to be written)
