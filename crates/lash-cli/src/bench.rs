//! `lash bench`: placeholder replaced below.
use crate::CliError;
pub fn run(_quick: bool) -> Result<(), CliError> {
    Err(CliError::Failure("not yet".into()))
}
