//! How a successful command ended and the process exit status it maps to (docs/design.md §7:
//! 0 done, 3 written but the requested tolerance not met, 1 a failed distributed run).

/// How a successful command ended (see the exit-status table in `--help`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Done {
    /// Everything asked for was delivered: exit status 0.
    Met,
    /// The output was written but a requested accuracy was not reached: exit status 3.
    RequestNotMet,
    /// A distributed run failed and rank 0 has reported why: exit status 1, no message here.
    Failed,
}

impl Done {
    /// The process exit status.
    pub fn exit_code(self) -> i32 {
        match self {
            Done::Met => 0,
            Done::RequestNotMet => 3,
            Done::Failed => 1,
        }
    }

    /// The outcome a rank other than 0 reports for rank 0's exit status `code`.
    pub fn from_exit_code(code: i32) -> Done {
        match code {
            0 => Done::Met,
            3 => Done::RequestNotMet,
            _ => Done::Failed,
        }
    }
}
