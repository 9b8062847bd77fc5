//! Truss geometry and sizing optimization on a ground structure (seed chapter 4).
