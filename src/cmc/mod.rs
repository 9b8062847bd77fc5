//! Constant-mean-curvature surfaces (seed chapter 5).
