//! # tests
//!
//! End-to-end tests that cross crate boundaries live in `tests/tests/`. This library
//! holds only helpers shared by those tests.
