//! The tile store: writing, resuming and locking, and corrupt or hostile
//! stores.

#[path = "../common/mod.rs"]
mod common;

mod hostile;
mod resume;
