//! Progress of long work, reported to whoever draws it (the CLI's progress bars); the
//! library itself draws nothing.

/// Receives the steps of long work. Every method does nothing by default, so `&()`
/// is the progress of work nobody watches.
pub trait Progress: Sync {
    /// What the work is doing now.
    fn message(&self, _text: &str) {}
    /// The work has `steps` more steps than announced so far.
    fn add_steps(&self, _steps: u64) {}
    /// `steps` more steps are done.
    fn advance(&self, _steps: u64) {}
}

impl Progress for () {}
