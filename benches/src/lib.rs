//! Benchmarks of arm_core live in `benches/`; this crate has no library code.
