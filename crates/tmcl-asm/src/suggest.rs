//! "Did you mean" suggestions by edit distance: one function for every tool, [`tmcl_model::names::closest`].

pub use tmcl_model::names::closest;
