//! Benchmark plots for carom. (Placeholder: being written.)
