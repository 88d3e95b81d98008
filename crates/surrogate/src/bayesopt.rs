//! bayesopt (to be written)
