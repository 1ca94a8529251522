//! Nothing: the comparison is `tests/bvh_crates.rs`, which reads the shared test
//! support of rlpt's own BVH tests (`../tests/bvh_support`).
