//! `wearnav`: the root package's library. It holds the tools that join the agents'
//! libraries in one process (the binary parses flags and calls them): so far the
//! virtual user study, [`course`].

pub mod course;
