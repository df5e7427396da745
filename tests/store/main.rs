//! The tile store: writing, resuming and locking, and corrupt or hostile
//! stores.

mod hostile;
mod resume;
