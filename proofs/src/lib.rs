//! taut-proofs (under construction).
