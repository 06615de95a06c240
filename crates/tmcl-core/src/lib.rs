//! The OpenTMCL firmware core.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![forbid(unsafe_code)]

pub mod hal;
pub mod model;
pub mod motion;
pub mod param;
pub mod time;
