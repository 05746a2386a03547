//! Stock systems.
