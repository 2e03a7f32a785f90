//! taut-sim: the digital twin (under construction).
