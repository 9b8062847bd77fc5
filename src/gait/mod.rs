//! Reduced-gradient spacetime optimization of articulated characters (seed chapter 3).
