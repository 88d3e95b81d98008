//! smc (to be written)
