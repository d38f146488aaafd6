//! The one error type of the command-line tool, and the exit code each kind maps to.
//!
//! Usage errors (bad or missing flags) exit with 2 and remind the user of the usage; input
//! errors (a missing file, a malformed OBJ, a truncated ray file, a failed write, threads the
//! system refuses to start) exit with 1.

use std::fmt;
use std::process::ExitCode;

/// Why a command failed, with a one-line message.
#[derive(Debug)]
pub enum CliError {
    /// The command line is wrong: exit code 2, usage reminder.
    Usage(String),
    /// The command line is fine but an input or output file (or the system) is not: exit code 1.
    Input(String),
}

impl CliError {
    pub fn usage(message: impl Into<String>) -> Self {
        CliError::Usage(message.into())
    }

    pub fn input(message: impl Into<String>) -> Self {
        CliError::Input(message.into())
    }

    pub fn exit_code(&self) -> ExitCode {
        match self {
            CliError::Usage(_) => ExitCode::from(2),
            CliError::Input(_) => ExitCode::from(1),
        }
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CliError::Usage(m) | CliError::Input(m) => f.write_str(m),
        }
    }
}
