//! Subcommands of the `rara` tool that live in their own files.

pub mod bench;
pub mod clip_args;
pub mod sweep;
